// ops_unary.cpp — forward/backward pairs of the unary ops. a, out, g (output gradient) and da share one shape.
#include "autograd/ops_unary.h"

#include "autograd/bit_mask.h"
#include "tensor/ops.h"
#include "tensor/parallel.h"

namespace t2m::ag {

namespace {
using Grads = std::vector<Tensor>;
using Need = std::vector<bool>;

// da[i] = g[i] * (a[i] > 0 ? 1 : 0): the product of g and the step mask in one pass (the same bits as multiplying
// by a mask tensor, -0 and NaN included).
template <typename T>
void relu_backward(T* da, const T* g, const T* a, int64_t n) {
  const int nt = n < kParallelGrain ? 1 : get_num_threads();
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int64_t i = 0; i < n; ++i) da[i] = g[i] * keep_or_zero((T)1, a[i] > (T)0);
}
}  // namespace

// da = -g
Variable neg(const Variable& a) {
  return record("neg", t2m::neg(a.data()), {a}, [](const Tensor& g, const Need&) { return Grads{t2m::neg(g)}; });
}

// da = g * out
Variable exp(const Variable& a) {
  Tensor out = t2m::exp(a.data());
  return record("exp", out, {a}, [out](const Tensor& g, const Need&) { return Grads{t2m::mul(g, out)}; });
}

// da = g / a
Variable log(const Variable& a) {
  Tensor ta = a.data();
  return record("log", t2m::log(ta), {a}, [ta](const Tensor& g, const Need&) { return Grads{t2m::div(g, ta)}; });
}

// da = g * 0.5 / out
Variable sqrt(const Variable& a) {
  Tensor out = t2m::sqrt(a.data());
  return record("sqrt", out, {a},
                [out](const Tensor& g, const Need&) { return Grads{t2m::mul(t2m::div(g, out), 0.5)}; });
}

// out = a^(-1/2); da = -0.5 * g * out^3
Variable rsqrt(const Variable& a) {
  Tensor out = t2m::rsqrt(a.data());
  return record("rsqrt", out, {a}, [out](const Tensor& g, const Need&) {
    return Grads{t2m::mul(t2m::mul(g, t2m::mul(out, t2m::square(out))), -0.5)};
  });
}

// da = g * (1 - out^2)
Variable tanh(const Variable& a) {
  Tensor out = t2m::tanh(a.data());
  return record("tanh", out, {a}, [out](const Tensor& g, const Need&) {
    return Grads{t2m::mul(g, t2m::add(t2m::neg(t2m::square(out)), 1.0))};
  });
}

// da = g * out * (1 - out)
Variable sigmoid(const Variable& a) {
  Tensor out = t2m::sigmoid(a.data());
  return record("sigmoid", out, {a}, [out](const Tensor& g, const Need&) {
    return Grads{t2m::mul(g, t2m::mul(out, t2m::add(t2m::neg(out), 1.0)))};
  });
}

// g * (ref > 0)
Tensor relu_grad(const Tensor& g, const Tensor& ref) {
  const DType dt = ref.dtype();
  if ((dt != DType::f32 && dt != DType::f64) || g.dtype() != dt || g.shape() != ref.shape())
    return t2m::mul(g, t2m::gt(ref, 0.0));  // the general (broadcasting, mixed dtype) path
  const Tensor gc = g.contiguous(), rc = ref.contiguous();
  Tensor da = Tensor::empty(rc.shape(), dt);
  if (dt == DType::f32)
    relu_backward<float>(da.data<float>(), gc.data<float>(), rc.data<float>(), rc.numel());
  else
    relu_backward<double>(da.data<double>(), gc.data<double>(), rc.data<double>(), rc.numel());
  return da;
}

// da = g * (a > 0)
Variable relu(const Variable& a) {
  Tensor ta = a.data();
  return record("relu", t2m::relu(ta), {a}, [ta](const Tensor& g, const Need&) { return Grads{relu_grad(g, ta)}; });
}

// da = g * sign(a)
Variable abs(const Variable& a) {
  Tensor ta = a.data();
  return record("abs", t2m::abs(ta), {a},
                [ta](const Tensor& g, const Need&) { return Grads{t2m::mul(g, t2m::sign(ta))}; });
}

// da = g * cos(a)
Variable sin(const Variable& a) {
  Tensor ta = a.data();
  return record("sin", t2m::sin(ta), {a},
                [ta](const Tensor& g, const Need&) { return Grads{t2m::mul(g, t2m::cos(ta))}; });
}

// da = -g * sin(a)
Variable cos(const Variable& a) {
  Tensor ta = a.data();
  return record("cos", t2m::cos(ta), {a},
                [ta](const Tensor& g, const Need&) { return Grads{t2m::neg(t2m::mul(g, t2m::sin(ta)))}; });
}

// da = 2 * g * a
Variable square(const Variable& a) {
  Tensor ta = a.data();
  return record("square", t2m::square(ta), {a},
                [ta](const Tensor& g, const Need&) { return Grads{t2m::mul(t2m::mul(g, ta), 2.0)}; });
}

// out = 1/a; da = -g * out^2
Variable reciprocal(const Variable& a) {
  Tensor out = t2m::reciprocal(a.data());
  return record("reciprocal", out, {a},
                [out](const Tensor& g, const Need&) { return Grads{t2m::neg(t2m::mul(g, t2m::square(out)))}; });
}

// da = g where lo <= a <= hi, else 0
Variable clamp(const Variable& a, double lo, double hi) {
  Tensor ta = a.data();
  return record("clamp", t2m::clamp(ta, lo, hi), {a}, [ta, lo, hi](const Tensor& g, const Need&) {
    // inside = (1 - [a < lo]) * (1 - [a > hi])
    Tensor inside = t2m::mul(t2m::add(t2m::neg(t2m::lt(ta, lo)), 1.0), t2m::add(t2m::neg(t2m::gt(ta, hi)), 1.0));
    return Grads{t2m::mul(g, inside)};
  });
}

// da = 0 (sign is piecewise constant)
Variable sign(const Variable& a) {
  return record("sign", t2m::sign(a.data()), {a},
                [](const Tensor& g, const Need&) { return Grads{Tensor::zeros(g.shape(), g.dtype())}; });
}

}  // namespace t2m::ag
