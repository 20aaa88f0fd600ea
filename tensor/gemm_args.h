// gemm_args.h — internal to tensor/gemm*.cpp: one C = alpha op(A) op(B) + beta C problem as the driver passes it
// around (GemmArgs: operands, strides, the bias and ReLU epilogues, column segments), and the checks of the public
// entry points' arguments.
#pragma once
#include <algorithm>
#include <cstdint>
#include <string>
#include <utility>

#include "tensor/gemm.h"
#include "tensor/gemm_columns.h"
#include "tensor/tensor.h"

namespace t2m::gemm_detail {

// One C = alpha op(A) op(B) + beta C problem.
template <typename T>
struct GemmArgs {
  bool ta, tb;
  int64_t M, N, K;
  T alpha;
  const T* A;
  int64_t lda;
  const T* B;
  int64_t ldb;
  T beta;
  T* C;
  int64_t ldc;
  const T* bias = nullptr;  // length N, added to every row of C; only with beta == 0 (gemm_bias)
  bool relu = false;        // C = max(C, 0) once the product is complete (gemm_bias_relu)
  GemmColumns ac{}, bc{}, cc{};  // the stored matrices' column segments (gemm_segmented); plain by default
  bool stream = false;           // C is written once and not read again soon (gemm_stream)
  bool segmented() const { return ac.len || bc.len || cc.len; }
  const T* a_at(int64_t i, int64_t k) const {  // &op(A)[i,k]
    return ta ? A + k * lda + segment_col(ac, i) : A + i * lda + segment_col(ac, k);
  }
  const T* b_at(int64_t k, int64_t j) const {  // &op(B)[k,j]
    return tb ? B + j * ldb + segment_col(bc, k) : B + k * ldb + segment_col(bc, j);
  }
  T* c_at(int64_t i, int64_t j) const { return C + i * ldc + segment_col(cc, j); }
};

// Throws Error (message starting with `op`) for negative dimensions, bad column segments, a row stride shorter
// than its matrix's row, or a null matrix the product needs.
template <typename T>
void check_args(const char* op, const GemmArgs<T>& g) {
  auto fail = [&](const std::string& what) {
    throw Error(std::string(op) + ": " + what + " (trans_a=" + std::to_string(g.ta) + " trans_b=" +
                std::to_string(g.tb) + " M=" + std::to_string(g.M) + " N=" + std::to_string(g.N) +
                " K=" + std::to_string(g.K) + " lda=" + std::to_string(g.lda) + " ldb=" + std::to_string(g.ldb) +
                " ldc=" + std::to_string(g.ldc) + ")");
  };
  if (g.M < 0 || g.N < 0 || g.K < 0) fail("negative dimension");
  for (const auto& [name, s] : {std::pair{"A", g.ac}, std::pair{"B", g.bc}, std::pair{"C", g.cc}})
    if (s.len < 0 || (s.len > 0 && s.stride < 1))
      fail(std::string("column segments of ") + name + ": len " + std::to_string(s.len) + ", stride " +
           std::to_string(s.stride) + " (len >= 0; stride >= 1 when len > 0)");
  // The row length each row stride must hold: the stored column count, or one segment's.
  auto row_len = [](int64_t cols, const GemmColumns& s) { return s.len ? std::min(cols, s.len) : cols; };
  const int64_t a_cols = row_len(g.ta ? g.M : g.K, g.ac), b_cols = row_len(g.tb ? g.K : g.N, g.bc);
  if (g.lda < std::max<int64_t>(1, a_cols)) fail("lda smaller than the row length of A (" + std::to_string(a_cols) + ")");
  if (g.ldb < std::max<int64_t>(1, b_cols)) fail("ldb smaller than the row length of B (" + std::to_string(b_cols) + ")");
  if (g.ldc < std::max<int64_t>(1, row_len(g.N, g.cc))) fail("ldc smaller than the row length of C");
  if (g.M > 0 && g.N > 0 && !g.C) fail("C is null");
  if (g.M > 0 && g.N > 0 && g.K > 0 && g.alpha != T(0) && (!g.A || !g.B)) fail("A or B is null");
}

}  // namespace t2m::gemm_detail
