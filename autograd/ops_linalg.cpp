// ops_linalg.cpp — forward/backward pairs of matmul and matmul_t.
#include "autograd/ops_linalg.h"

#include "tensor/ops.h"

namespace t2m::ag {

namespace {

// Gradients of out = op(a) · op(b) with a: [..., M, K] (or [..., K, M] when ta), b: [..., K, N] (or [..., N, K]),
// g: [batch..., M, N]. Returns da, db in the (possibly broadcast) batch shape; the caller sums them to A, B.
//   da = ta ? op(b) · g^T : g · op(b)^T          db = tb ? g^T · op(a) : op(a)^T · g
void matmul_t_backward(Tensor& da, Tensor& db, const Tensor& g, const Tensor& a, bool ta, const Tensor& b, bool tb,
                       const std::vector<bool>& need) {
  if (need[0]) da = ta ? t2m::matmul_t(b, tb, g, true) : t2m::matmul_t(g, false, b, !tb);
  if (need[1]) db = tb ? t2m::matmul_t(g, true, a, ta) : t2m::matmul_t(a, !ta, g, false);
}

}  // namespace

// a: [..., M, K] (or 1-D [K]), b: [..., K, N] (or 1-D [K]), out: [broadcast batch..., M, N] minus promoted dims.
// Saves a only when b needs a gradient and vice versa.
Variable matmul(const Variable& a, const Variable& b) {
  Tensor out = t2m::matmul(a.data(), b.data());
  Shape A = a.shape(), B = b.shape(), O = out.shape();
  Tensor sa = b.requires_grad() ? a.data() : Tensor(), sb = a.requires_grad() ? b.data() : Tensor();
  return record("matmul", out, {a, b}, [sa, sb, A, B, O](const Tensor& g, const std::vector<bool>& need) {
    // Promote 1-D operands to matrices ([K] -> [1, K] on the left, [K, 1] on the right) and g to [batch..., M, N].
    Shape A2 = A.size() == 1 ? Shape{1, A[0]} : A;
    Shape B2 = B.size() == 1 ? Shape{B[0], 1} : B;
    Shape gs = O;
    if (A.size() == 1) gs.insert(gs.end() - (B.size() == 1 ? 0 : 1), 1);
    if (B.size() == 1) gs.push_back(1);
    Tensor g2 = g.reshape(gs);
    Tensor a2 = sa.defined() ? sa.reshape(A2) : sa, b2 = sb.defined() ? sb.reshape(B2) : sb;
    Tensor da, db;
    matmul_t_backward(da, db, g2, a2, false, b2, false, need);
    if (need[0]) da = reduce_grad_to(da, A2).reshape(A);
    if (need[1]) db = reduce_grad_to(db, B2).reshape(B);
    return std::vector<Tensor>{da, db};
  });
}

// a, b at least 2-D; out: [broadcast batch..., M, N]. Saves a only when b needs a gradient and vice versa.
Variable matmul_t(const Variable& a, bool trans_a, const Variable& b, bool trans_b) {
  Shape A = a.shape(), B = b.shape();
  Tensor sa = b.requires_grad() ? a.data() : Tensor(), sb = a.requires_grad() ? b.data() : Tensor();
  return record("matmul_t", t2m::matmul_t(a.data(), trans_a, b.data(), trans_b), {a, b},
                [sa, sb, A, B, trans_a, trans_b](const Tensor& g, const std::vector<bool>& need) {
                  Tensor da, db;
                  matmul_t_backward(da, db, g, sa, trans_a, sb, trans_b, need);
                  if (need[0]) da = reduce_grad_to(da, A);
                  if (need[1]) db = reduce_grad_to(db, B);
                  return std::vector<Tensor>{da, db};
                });
}

}  // namespace t2m::ag
