// ops_elementwise.cpp — forward/backward pairs of the binary elementwise ops. In every backward: g is the output
// gradient of shape broadcast(A, B); da/db are reduced to A/B with reduce_grad_to (node.h).
#include "autograd/ops_elementwise.h"

#include "autograd/ops_unary.h"
#include "tensor/ops.h"

namespace t2m::ag {

namespace {

Tensor zero_like_scalar(const Tensor& t) { return Tensor::zeros({}, t.dtype()); }

// maximum/minimum: wa = 1 where a wins, 1/2 on ties, 0 where b wins (out shape). da = g*wa, db = g*(1-wa).
std::vector<Tensor> select_backward(const Tensor& g, const Tensor& wa, const Shape& A, const Shape& B,
                                    const std::vector<bool>& need) {
  Tensor ga = mul(g, wa);
  return {need[0] ? reduce_grad_to(ga, A) : Tensor(), need[1] ? reduce_grad_to(sub(g, ga), B) : Tensor()};
}

}  // namespace

// out = a + b. da = reduce_grad_to(g, A), db = reduce_grad_to(g, B).
Variable add(const Variable& a, const Variable& b) {
  Shape A = a.shape(), B = b.shape();
  return record("add", t2m::add(a.data(), b.data()), {a, b}, [A, B](const Tensor& g, const std::vector<bool>& need) {
    return std::vector<Tensor>{need[0] ? reduce_grad_to(g, A) : Tensor(), need[1] ? reduce_grad_to(g, B) : Tensor()};
  });
}

// out = a - b. da = reduce_grad_to(g, A), db = -reduce_grad_to(g, B).
Variable sub(const Variable& a, const Variable& b) {
  Shape A = a.shape(), B = b.shape();
  return record("sub", t2m::sub(a.data(), b.data()), {a, b}, [A, B](const Tensor& g, const std::vector<bool>& need) {
    return std::vector<Tensor>{need[0] ? reduce_grad_to(g, A) : Tensor(),
                               need[1] ? t2m::neg(reduce_grad_to(g, B)) : Tensor()};
  });
}

// out = a * b. da = reduce_grad_to(g * b, A), db = reduce_grad_to(g * a, B).
// Saves a only when b needs a gradient and vice versa (x * constant_mask does not keep x alive).
Variable mul(const Variable& a, const Variable& b) {
  Shape A = a.shape(), B = b.shape();
  Tensor sa = b.requires_grad() ? a.data() : Tensor(), sb = a.requires_grad() ? b.data() : Tensor();
  return record("mul", t2m::mul(a.data(), b.data()), {a, b},
                [sa, sb, A, B](const Tensor& g, const std::vector<bool>& need) {
                  return std::vector<Tensor>{need[0] ? reduce_grad_to(t2m::mul(g, sb), A) : Tensor(),
                                             need[1] ? reduce_grad_to(t2m::mul(g, sa), B) : Tensor()};
                });
}

// out = a / b. da = reduce_grad_to(g / b, A), db = reduce_grad_to(-g * out / b, B).
Variable div(const Variable& a, const Variable& b) {
  Tensor ta = a.data(), tb = b.data();
  Tensor out = t2m::div(ta, tb);
  return record("div", out, {a, b}, [ta, tb, out](const Tensor& g, const std::vector<bool>& need) {
    Tensor gb = t2m::div(g, tb);
    return std::vector<Tensor>{need[0] ? reduce_grad_to(gb, ta.shape()) : Tensor(),
                               need[1] ? t2m::neg(reduce_grad_to(t2m::mul(gb, out), tb.shape())) : Tensor()};
  });
}

// out = a ^ b. da = reduce_grad_to(g * b * a^(b-1), A), db = reduce_grad_to(g * out * log(a), B).
Variable pow(const Variable& a, const Variable& b) {
  Tensor ta = a.data(), tb = b.data();
  Tensor out = t2m::pow(ta, tb);
  return record("pow", out, {a, b}, [ta, tb, out](const Tensor& g, const std::vector<bool>& need) {
    Tensor da, db;
    if (need[0]) da = reduce_grad_to(t2m::mul(g, t2m::mul(tb, t2m::pow(ta, t2m::add(tb, -1.0)))), ta.shape());
    if (need[1]) db = reduce_grad_to(t2m::mul(g, t2m::mul(out, t2m::log(ta))), tb.shape());
    return std::vector<Tensor>{da, db};
  });
}

// out = max(a, b); ties split the gradient evenly.
Variable maximum(const Variable& a, const Variable& b) {
  Tensor ta = a.data(), tb = b.data();
  return record("maximum", t2m::maximum(ta, tb), {a, b}, [ta, tb](const Tensor& g, const std::vector<bool>& need) {
    Tensor wa = t2m::add(t2m::gt(ta, tb), t2m::mul(t2m::eq(ta, tb), 0.5));
    return select_backward(g, wa, ta.shape(), tb.shape(), need);
  });
}

// out = min(a, b); ties split the gradient evenly.
Variable minimum(const Variable& a, const Variable& b) {
  Tensor ta = a.data(), tb = b.data();
  return record("minimum", t2m::minimum(ta, tb), {a, b}, [ta, tb](const Tensor& g, const std::vector<bool>& need) {
    Tensor wa = t2m::add(t2m::lt(ta, tb), t2m::mul(t2m::eq(ta, tb), 0.5));
    return select_backward(g, wa, ta.shape(), tb.shape(), need);
  });
}

// ---- scalar forms: out has a's shape ------------------------------------------------------------------------

// out = a + s. da = g.
Variable add(const Variable& a, double s) {
  return record("add_scalar", t2m::add(a.data(), s), {a},
                [](const Tensor& g, const std::vector<bool>&) { return std::vector<Tensor>{g}; });
}

Variable sub(const Variable& a, double s) { return add(a, -s); }

// out = s - a. da = -g.
Variable rsub(double s, const Variable& a) {
  return record("rsub_scalar", t2m::add(t2m::neg(a.data()), s), {a},
                [](const Tensor& g, const std::vector<bool>&) { return std::vector<Tensor>{t2m::neg(g)}; });
}

// out = a * s. da = g * s.
Variable mul(const Variable& a, double s) {
  return record("mul_scalar", t2m::mul(a.data(), s), {a},
                [s](const Tensor& g, const std::vector<bool>&) { return std::vector<Tensor>{t2m::mul(g, s)}; });
}

Variable div(const Variable& a, double s) { return mul(a, 1.0 / s); }

// out = s / a. da = -g * out / a.
Variable rdiv(double s, const Variable& a) {
  Tensor ta = a.data();
  Tensor out = t2m::mul(t2m::reciprocal(ta), s);
  return record("rdiv_scalar", out, {a}, [ta, out](const Tensor& g, const std::vector<bool>&) {
    return std::vector<Tensor>{t2m::neg(t2m::div(t2m::mul(g, out), ta))};
  });
}

// out = a ^ e. da = g * e * a^(e-1).
Variable pow(const Variable& a, double e) {
  Tensor ta = a.data();
  return record("pow_scalar", t2m::pow(ta, e), {a}, [ta, e](const Tensor& g, const std::vector<bool>&) {
    if (e == 0.0) return std::vector<Tensor>{t2m::mul(g, 0.0)};
    return std::vector<Tensor>{t2m::mul(g, t2m::mul(t2m::pow(ta, e - 1.0), e))};
  });
}

// ---- selection ------------------------------------------------------------------------------------------------

// out = cond ? a : b, shape broadcast(C, A, B). da = reduce_grad_to(where(cond, g, 0), A),
// db = reduce_grad_to(where(cond, 0, g), B).
Variable where(const Tensor& cond, const Variable& a, const Variable& b) {
  Shape A = a.shape(), B = b.shape();
  return record("where", t2m::where(cond, a.data(), b.data()), {a, b},
                [cond, A, B](const Tensor& g, const std::vector<bool>& need) {
                  Tensor z = zero_like_scalar(g);
                  return std::vector<Tensor>{need[0] ? reduce_grad_to(t2m::where(cond, g, z), A) : Tensor(),
                                             need[1] ? reduce_grad_to(t2m::where(cond, z, g), B) : Tensor()};
                });
}

// out = mask ? value : a, shape A. da = mask ? 0 : g.
Variable masked_fill(const Variable& a, const Tensor& mask, double value) {
  return record("masked_fill", t2m::masked_fill(a.data(), mask, value), {a},
                [mask](const Tensor& g, const std::vector<bool>&) {
                  return std::vector<Tensor>{t2m::masked_fill(g, mask, 0.0)};
                });
}

Tensor gt(const Variable& a, const Variable& b) { return t2m::gt(a.data(), b.data()); }
Tensor lt(const Variable& a, const Variable& b) { return t2m::lt(a.data(), b.data()); }
Tensor ge(const Variable& a, const Variable& b) { return t2m::ge(a.data(), b.data()); }
Tensor le(const Variable& a, const Variable& b) { return t2m::le(a.data(), b.data()); }
Tensor eq(const Variable& a, const Variable& b) { return t2m::eq(a.data(), b.data()); }
Tensor gt(const Variable& a, double s) { return t2m::gt(a.data(), s); }
Tensor lt(const Variable& a, double s) { return t2m::lt(a.data(), s); }

Variable operator+(const Variable& a, const Variable& b) { return add(a, b); }
Variable operator-(const Variable& a, const Variable& b) { return sub(a, b); }
Variable operator*(const Variable& a, const Variable& b) { return mul(a, b); }
Variable operator/(const Variable& a, const Variable& b) { return div(a, b); }
Variable operator-(const Variable& a) { return neg(a); }
Variable operator+(const Variable& a, double s) { return add(a, s); }
Variable operator+(double s, const Variable& a) { return add(a, s); }
Variable operator-(const Variable& a, double s) { return sub(a, s); }
Variable operator-(double s, const Variable& a) { return rsub(s, a); }
Variable operator*(const Variable& a, double s) { return mul(a, s); }
Variable operator*(double s, const Variable& a) { return mul(a, s); }
Variable operator/(const Variable& a, double s) { return div(a, s); }
Variable operator/(double s, const Variable& a) { return rdiv(s, a); }

}  // namespace t2m::ag
