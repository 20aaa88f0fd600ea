// ops_unary.cpp — elementwise unary math (detail::map_unary does the walking; see kernels.h).
// NaN inputs propagate to NaN outputs for every op here (relu, abs, clamp included).
#include <cmath>

#include "tensor/kernels.h"
#include "tensor/ops.h"

namespace t2m {

using detail::map_unary;

Tensor neg(const Tensor& a) { return map_unary(a, "neg", [](auto x) { return -x; }); }
Tensor exp(const Tensor& a) { return map_unary(a, "exp", [](auto x) { return std::exp(x); }); }
Tensor log(const Tensor& a) { return map_unary(a, "log", [](auto x) { return std::log(x); }); }
Tensor sqrt(const Tensor& a) { return map_unary(a, "sqrt", [](auto x) { return std::sqrt(x); }); }
Tensor rsqrt(const Tensor& a) {
  return map_unary(a, "rsqrt", [](auto x) { return decltype(x)(1) / std::sqrt(x); });
}
Tensor tanh(const Tensor& a) { return map_unary(a, "tanh", [](auto x) { return std::tanh(x); }); }

// sigmoid(x) = 1 / (1 + e^-x), evaluated so that e^(-|x|) never overflows.
Tensor sigmoid(const Tensor& a) {
  return map_unary(a, "sigmoid", [](auto x) {
    using T = decltype(x);
    if (x >= T(0)) return T(1) / (T(1) + std::exp(-x));
    const T e = std::exp(x);
    return e / (T(1) + e);
  });
}

Tensor relu(const Tensor& a) {
  return map_unary(a, "relu", [](auto x) { return x < decltype(x)(0) ? decltype(x)(0) : x; });
}
Tensor abs(const Tensor& a) { return map_unary(a, "abs", [](auto x) { return std::abs(x); }); }
Tensor sign(const Tensor& a) {
  return map_unary(a, "sign", [](auto x) {
    using T = decltype(x);
    return x != x ? x : T(x > T(0)) - T(x < T(0));
  });
}
Tensor sin(const Tensor& a) { return map_unary(a, "sin", [](auto x) { return std::sin(x); }); }
Tensor cos(const Tensor& a) { return map_unary(a, "cos", [](auto x) { return std::cos(x); }); }
Tensor square(const Tensor& a) { return map_unary(a, "square", [](auto x) { return x * x; }); }
Tensor reciprocal(const Tensor& a) {
  return map_unary(a, "reciprocal", [](auto x) { return decltype(x)(1) / x; });
}

Tensor clamp(const Tensor& a, double lo, double hi) {
  if (!(lo <= hi))
    throw Error("clamp: lo " + std::to_string(lo) + " > hi " + std::to_string(hi) + " (shape " +
                shape_str(a.shape()) + ")");
  return map_unary(a, "clamp", [lo, hi](auto x) {
    using T = decltype(x);
    return x < T(lo) ? T(lo) : (x > T(hi) ? T(hi) : x);
  });
}

}  // namespace t2m
