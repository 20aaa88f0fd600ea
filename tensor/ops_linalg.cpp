// ops_linalg.cpp — matmul / matmul_t with numpy batching on top of gemm_batched.
//
// Each operand's last two dims are used in place when their layout is row-major (inner stride 1) or
// column-major (outer stride 1: passed to GEMM as the transposed row-major matrix); any other layout is copied
// to contiguous first. Broadcast batch dims get stride 0. Batch dims are coalesced jointly for A, B and C; the
// innermost coalesced batch dim goes to one gemm_batched call, any outer ones are looped over.
#include <algorithm>

#include "tensor/gemm.h"
#include "tensor/kernels.h"
#include "tensor/ops.h"

namespace t2m {
namespace {

// How GEMM reads a [R, C] matrix view: storage is row-major with leading dimension ld, transposed or not.
struct MatLayout {
  bool trans = false;
  int64_t ld = 1;
};

// Layout of the last two dims of t (shape [.., R, C]); false when neither row- nor column-major.
bool mat_layout(const Tensor& t, MatLayout& L) {
  const int64_t R = t.size(-2), C = t.size(-1);
  const int64_t sr = t.strides()[t.dim() - 2], sc = t.strides()[t.dim() - 1];
  if ((sc == 1 || C == 1) && (R == 1 || sr >= std::max<int64_t>(C, 1))) {
    L = {false, R == 1 ? std::max<int64_t>(C, 1) : sr};
    return true;
  }
  if ((sr == 1 || R == 1) && (C == 1 || sc >= std::max<int64_t>(R, 1))) {
    L = {true, C == 1 ? std::max<int64_t>(R, 1) : sc};
    return true;
  }
  return false;
}

// C[batch.., M, N] = op(A) op(B); a and b are at least 2-D (already transposed views when requested).
Tensor matmul_nd(Tensor a, Tensor b, const char* op, const Shape& a_orig, const Shape& b_orig) {
  const int64_t M = a.size(-2), K = a.size(-1), K2 = b.size(-2), N = b.size(-1);
  if (K != K2)
    throw Error(std::string(op) + ": inner dims differ, cannot multiply " + shape_str(a_orig) + " by " +
                shape_str(b_orig));
  const Shape ab(a.shape().begin(), a.shape().end() - 2), bb(b.shape().begin(), b.shape().end() - 2);
  Shape batch;
  try {
    batch = broadcast_shapes(ab, bb, op);
  } catch (const Error&) {
    throw Error(std::string(op) + ": batch dims do not broadcast, cannot multiply " + shape_str(a_orig) + " by " +
                shape_str(b_orig));
  }
  Shape out_shape = batch;
  out_shape.push_back(M);
  out_shape.push_back(N);
  Tensor c = Tensor::empty(out_shape, a.dtype());
  if (M == 0 || N == 0 || shape_numel(batch) == 0) return c;
  if (K == 0) {  // empty inner dim: a sum of nothing
    c.zero_();
    return c;
  }

  MatLayout la, lb;
  if (!mat_layout(a, la)) {
    a = a.contiguous();
    mat_layout(a, la);
  }
  if (!mat_layout(b, lb)) {
    b = b.contiguous();
    mat_layout(b, lb);
  }
  // Batch strides broadcast to `batch` (size-1 / missing dims -> 0), then coalesced jointly with C's.
  auto batch_strides = [&](const Tensor& t) {
    const Shape full(t.strides().begin(), t.strides().end() - 2);
    const Shape sh(t.shape().begin(), t.shape().end() - 2);
    Shape r(batch.size(), 0);
    for (size_t i = 0; i < sh.size(); ++i) {
      const size_t d = batch.size() - sh.size() + i;
      r[d] = sh[i] == 1 ? 0 : full[i];
    }
    return r;
  };
  const std::array<Shape, 3> bst{batch_strides(a), batch_strides(b), contiguous_strides(batch)};
  Shape bst_c = bst[2];
  for (int64_t& s : bst_c) s *= M * N;
  const auto plan = detail::make_plan<3>(batch, {bst[0], bst[1], bst_c});
  const int64_t nb = (int64_t)plan.shape.size();
  const int64_t inner = plan.shape[nb - 1];
  const int64_t outer = plan.numel / inner;

  detail::dispatch_float(a.dtype(), op, [&](auto z) {
    using T = decltype(z);
    const T* pa = a.data<T>();
    const T* pb = b.data<T>();
    T* pc = c.data<T>();
    for (int64_t o = 0; o < outer; ++o) {
      // Offsets of the outer batch index o (all coalesced dims but the innermost).
      int64_t rem = o, oa = 0, ob = 0, oc = 0;
      for (int64_t d = nb - 2; d >= 0; --d) {
        const int64_t i = rem % plan.shape[d];
        rem /= plan.shape[d];
        oa += i * plan.strides[0][d];
        ob += i * plan.strides[1][d];
        oc += i * plan.strides[2][d];
      }
      gemm_batched(la.trans, lb.trans, inner, M, N, K, T(1), pa + oa, la.ld, plan.strides[0][nb - 1], pb + ob,
                   lb.ld, plan.strides[1][nb - 1], T(0), pc + oc, N, plan.strides[2][nb - 1]);
    }
  });
  return c;
}

void check_matmul_args(const Tensor& a, const Tensor& b, const char* op) {
  detail::check_float_pair(a, b, op);
  if (a.dim() == 0 || b.dim() == 0)
    throw Error(std::string(op) + ": 0-d operand, cannot multiply " + shape_str(a.shape()) + " by " +
                shape_str(b.shape()));
}

}  // namespace

Tensor matmul(const Tensor& a, const Tensor& b) { return matmul_t(a, false, b, false); }

Tensor matmul_t(const Tensor& a, bool trans_a, const Tensor& b, bool trans_b) {
  const char* op = (trans_a || trans_b) ? "matmul_t" : "matmul";
  check_matmul_args(a, b, op);
  if ((trans_a && a.dim() < 2) || (trans_b && b.dim() < 2))
    throw Error(std::string(op) + ": transpose needs a >= 2-d operand, got " + shape_str(a.shape()) + " (trans " +
                std::to_string(trans_a) + ") and " + shape_str(b.shape()) + " (trans " + std::to_string(trans_b) +
                ")");
  // numpy rules for 1-d operands: a [K] -> [1, K] (dim removed from the result), b [K] -> [K, 1] (likewise).
  Tensor a2 = a.dim() == 1 ? a.unsqueeze(0) : (trans_a ? a.transpose(-1, -2) : a);
  Tensor b2 = b.dim() == 1 ? b.unsqueeze(1) : (trans_b ? b.transpose(-1, -2) : b);
  Tensor c = matmul_nd(a2, b2, op, a.shape(), b.shape());
  if (b.dim() == 1) c = c.squeeze(-1);
  if (a.dim() == 1) c = c.squeeze(b.dim() == 1 ? -1 : -2);
  return c;
}

}  // namespace t2m
