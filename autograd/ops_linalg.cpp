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
Variable matmul(const Variable& a, const Variable& b) {
  Tensor ta = a.data(), tb = b.data();
  Tensor out = t2m::matmul(ta, tb);
  return record("matmul", out, {a, b}, [ta, tb, out](const Tensor& g, const std::vector<bool>& need) {
    // Promote 1-D operands to matrices and g to the matching [batch..., M, N] shape.
    Tensor a2 = ta.dim() == 1 ? ta.reshape({1, ta.size(0)}) : ta;
    Tensor b2 = tb.dim() == 1 ? tb.reshape({tb.size(0), 1}) : tb;
    Shape gs = out.shape();
    if (ta.dim() == 1) gs.insert(gs.end() - (tb.dim() == 1 ? 0 : 1), 1);
    if (tb.dim() == 1) gs.push_back(1);
    Tensor g2 = g.reshape(gs);
    Tensor da, db;
    matmul_t_backward(da, db, g2, a2, false, b2, false, need);
    if (need[0]) da = sum_to(da, a2.shape()).reshape(ta.shape());
    if (need[1]) db = sum_to(db, b2.shape()).reshape(tb.shape());
    return std::vector<Tensor>{da, db};
  });
}

// a, b at least 2-D; out: [broadcast batch..., M, N].
Variable matmul_t(const Variable& a, bool trans_a, const Variable& b, bool trans_b) {
  Tensor ta = a.data(), tb = b.data();
  return record("matmul_t", t2m::matmul_t(ta, trans_a, tb, trans_b), {a, b},
                [ta, tb, trans_a, trans_b](const Tensor& g, const std::vector<bool>& need) {
                  Tensor da, db;
                  matmul_t_backward(da, db, g, ta, trans_a, tb, trans_b, need);
                  if (need[0]) da = sum_to(da, ta.shape());
                  if (need[1]) db = sum_to(db, tb.shape());
                  return std::vector<Tensor>{da, db};
                });
}

}  // namespace t2m::ag
