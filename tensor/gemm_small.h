// gemm_small.h — internal to tensor/gemm*.cpp: the unpacked path for matrix-vector-like and tiny products, where
// packing would cost more than it saves (gemm.cpp sends them here; segmented products always take the packed path).
#pragma once
#include <cstdint>

#include "tensor/gemm_args.h"

namespace t2m::gemm_detail {

// Matrix-vector-like or tiny problems.
template <typename T>
bool is_small(const GemmArgs<T>& g) {
  return g.M <= 2 || g.N <= 2 || g.K <= 2 || g.M * g.N * g.K <= 24 * 24 * 24;
}

// C = alpha op(A) op(B) + beta C (or the bias epilogue) for such a problem, rows split over nt threads; each row's
// arithmetic is the same whatever the split. The ReLU epilogue is the caller's.
template <typename T>
void gemm_small(const GemmArgs<T>& g, int nt);

}  // namespace t2m::gemm_detail
