// ops_embedding.cpp — forward (row copies) and backward (scatter-add of rows) of the embedding lookup.
#include "autograd/ops_embedding.h"

#include <omp.h>

#include <cstring>
#include <string>

#include "autograd/node.h"
#include "tensor/parallel.h"

namespace t2m::ag {

namespace {

// out (N, D) = w[ids[n]] rows.
template <typename T>
void embedding_forward(T* out, const T* w, const int64_t* ids, int64_t N, int64_t D) {
  const int nt = N * D < kParallelGrain ? 1 : get_num_threads();
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int64_t n = 0; n < N; ++n) std::memcpy(out + n * D, w + ids[n] * D, (size_t)D * sizeof(T));
}

// dw (V, D) zeroed by the caller; dw[ids[n]] += g[n] in n order. Columns split across threads, so every
// element is summed in the same order for any thread count.
template <typename T>
void embedding_backward(T* dw, const T* g, const int64_t* ids, int64_t N, int64_t D) {
  const int nt = N * D < kParallelGrain || D < 16 ? 1 : get_num_threads();
#pragma omp parallel num_threads(nt)
  {
    const int tid = omp_get_thread_num(), nth = omp_get_num_threads();
    const int64_t c0 = D * tid / nth, c1 = D * (tid + 1) / nth;
    for (int64_t n = 0; n < N; ++n) {
      T* dst = dw + ids[n] * D;
      const T* src = g + n * D;
      for (int64_t c = c0; c < c1; ++c) dst[c] += src[c];
    }
  }
}

}  // namespace

// weight (V, D), ids S -> out (S..., D).
Variable embedding(const Variable& weight, const Tensor& ids) {
  if (weight.dim() != 2 || (weight.dtype() != DType::f32 && weight.dtype() != DType::f64))
    throw Error("embedding: weight must be a 2-D f32/f64 tensor (V, D), got " + shape_str(weight.shape()) + " " +
                dtype_name(weight.dtype()));
  if (!ids.defined() || ids.dtype() != DType::i64)
    throw Error(std::string("embedding: ids must be int64, got ") +
                (ids.defined() ? dtype_name(ids.dtype()) : "an undefined tensor"));
  const int64_t V = weight.size(0), D = weight.size(1);
  const Tensor idc = ids.contiguous();
  const int64_t N = idc.numel();
  const int64_t* id = N > 0 ? idc.data<int64_t>() : nullptr;
  for (int64_t n = 0; n < N; ++n)
    if (id[n] < 0 || id[n] >= V)
      throw Error("embedding: id " + std::to_string(id[n]) + " at flat position " + std::to_string(n) +
                  " is out of range for V = " + std::to_string(V) + " (ids " + shape_str(ids.shape()) +
                  ", weight " + shape_str(weight.shape()) + ")");
  const Tensor wc = weight.data().contiguous();
  Shape os = ids.shape();
  os.push_back(D);
  Tensor out = Tensor::empty(os, wc.dtype());
  if (N > 0 && D > 0) {
    if (wc.dtype() == DType::f32)
      embedding_forward<float>(out.data<float>(), wc.data<float>(), id, N, D);
    else
      embedding_forward<double>(out.data<double>(), wc.data<double>(), id, N, D);
  }
  return record("embedding", out, {weight}, [idc, V, D, N](const Tensor& grad, const std::vector<bool>&) {
    const Tensor g = grad.contiguous();
    Tensor dw = Tensor::zeros({V, D}, g.dtype());
    if (N == 0 || D == 0) return std::vector<Tensor>{dw};
    if (g.dtype() == DType::f32)
      embedding_backward<float>(dw.data<float>(), g.data<float>(), idc.data<int64_t>(), N, D);
    else
      embedding_backward<double>(dw.data<double>(), g.data<double>(), idc.data<int64_t>(), N, D);
    return std::vector<Tensor>{dw};
  });
}

}  // namespace t2m::ag
