// ops_elementwise.cpp — binary elementwise ops with numpy broadcasting, comparisons, where, in-place updates.
//
// One kernel shape for all of them: the output is contiguous; the strided walker (strided_iter.h) coalesces
// dims, so contiguous same-shape inputs run as one flat loop the compiler vectorises, and a broadcast scalar
// operand (inner stride 0) gets its own loop. Everything else takes the general strided loop.
#include <cmath>

#include "tensor/kernels.h"
#include "tensor/ops.h"
#include "tensor/strided_iter.h"

namespace t2m {
namespace {

using detail::broadcast_strides;
using detail::check_float_pair;
using detail::dispatch_float;
using detail::strided_for_each;
using Off = std::array<int64_t, 3>;

// out = f(a, b) with broadcasting; f is a generic functor (T, T) -> T.
template <typename F>
Tensor binary_op(const Tensor& a_in, const Tensor& b_in, const char* op, F f) {
  check_float_pair(a_in, b_in, op);
  const Tensor a = detail::untranspose_large(a_in), b = detail::untranspose_large(b_in);
  const Shape shape = broadcast_shapes(a.shape(), b.shape(), op);
  Tensor out = Tensor::empty(shape, a.dtype());
  const std::array<Shape, 3> st{out.strides(), broadcast_strides(a, shape, op), broadcast_strides(b, shape, op)};
  dispatch_float(a.dtype(), op, [&](auto z) {
    using T = decltype(z);
    T* po = out.data<T>();
    const T* pa = a.data<T>();
    const T* pb = b.data<T>();
    strided_for_each<3>(shape, st, [&](const Off& off, const Off& s, int64_t n) {
      T* __restrict o = po + off[0];
      const T* x = pa + off[1];
      const T* y = pb + off[2];
      if (s[0] == 1 && s[1] == 1 && s[2] == 1) {
        for (int64_t i = 0; i < n; ++i) o[i] = f(x[i], y[i]);
      } else if (s[0] == 1 && s[1] == 1 && s[2] == 0) {
        const T yv = y[0];
        for (int64_t i = 0; i < n; ++i) o[i] = f(x[i], yv);
      } else if (s[0] == 1 && s[1] == 0 && s[2] == 1) {
        const T xv = x[0];
        for (int64_t i = 0; i < n; ++i) o[i] = f(xv, y[i]);
      } else {
        for (int64_t i = 0; i < n; ++i) o[i * s[0]] = f(x[i * s[1]], y[i * s[2]]);
      }
    });
  });
  return out;
}

}  // namespace

// ---- binary ----------------------------------------------------------------------------------------------------
Tensor add(const Tensor& a, const Tensor& b) { return binary_op(a, b, "add", [](auto x, auto y) { return x + y; }); }
Tensor sub(const Tensor& a, const Tensor& b) { return binary_op(a, b, "sub", [](auto x, auto y) { return x - y; }); }
Tensor mul(const Tensor& a, const Tensor& b) { return binary_op(a, b, "mul", [](auto x, auto y) { return x * y; }); }
Tensor div(const Tensor& a, const Tensor& b) { return binary_op(a, b, "div", [](auto x, auto y) { return x / y; }); }
Tensor pow(const Tensor& a, const Tensor& b) {
  return binary_op(a, b, "pow", [](auto x, auto y) { return std::pow(x, y); });
}
// NaN propagates (either operand NaN gives NaN), like torch.maximum/minimum.
Tensor maximum(const Tensor& a, const Tensor& b) {
  return binary_op(a, b, "maximum", [](auto x, auto y) { return (x > y || x != x) ? x : y; });
}
Tensor minimum(const Tensor& a, const Tensor& b) {
  return binary_op(a, b, "minimum", [](auto x, auto y) { return (x < y || x != x) ? x : y; });
}

// ---- with a scalar ----------------------------------------------------------------------------------------------
Tensor add(const Tensor& a, double s) {
  return detail::map_unary(a, "add", [s](auto x) { return x + (decltype(x))s; });
}
Tensor mul(const Tensor& a, double s) {
  return detail::map_unary(a, "mul", [s](auto x) { return x * (decltype(x))s; });
}
Tensor pow(const Tensor& a, double e) {
  if (e == 2.0) return detail::map_unary(a, "pow", [](auto x) { return x * x; });
  if (e == 1.0) return detail::map_unary(a, "pow", [](auto x) { return x; });
  return detail::map_unary(a, "pow", [e](auto x) { return std::pow(x, (decltype(x))e); });
}

// ---- comparisons (masks of 0/1 in a's dtype) -----------------------------------------------------------------------
#define T2M_CMP(name, expr)                                                                          \
  Tensor name(const Tensor& a, const Tensor& b) {                                                    \
    return binary_op(a, b, #name, [](auto x, auto y) { return (decltype(x))(expr); });               \
  }
T2M_CMP(gt, x > y)
T2M_CMP(lt, x < y)
T2M_CMP(ge, x >= y)
T2M_CMP(le, x <= y)
T2M_CMP(eq, x == y)
#undef T2M_CMP
Tensor gt(const Tensor& a, double s) {
  return detail::map_unary(a, "gt", [s](auto x) { return (decltype(x))(x > (decltype(x))s); });
}
Tensor lt(const Tensor& a, double s) {
  return detail::map_unary(a, "lt", [s](auto x) { return (decltype(x))(x < (decltype(x))s); });
}

// ---- where ----------------------------------------------------------------------------------------------------------
Tensor where(const Tensor& cond, const Tensor& a, const Tensor& b) {
  check_float_pair(a, b, "where");
  detail::check_defined(cond, "where", "condition");
  const Shape shape = broadcast_shapes(cond.shape(), broadcast_shapes(a.shape(), b.shape(), "where"), "where");
  Tensor out = Tensor::empty(shape, a.dtype());
  const std::array<Shape, 4> st{out.strides(), broadcast_strides(cond, shape, "where"),
                                broadcast_strides(a, shape, "where"), broadcast_strides(b, shape, "where")};
  dispatch_float(a.dtype(), "where", [&](auto z) {
    using T = decltype(z);
    T* po = out.data<T>();
    const T* pa = a.data<T>();
    const T* pb = b.data<T>();
    detail::dispatch_all(cond.dtype(), [&](auto cz) {
      using C = decltype(cz);
      const C* pc = cond.data<C>();
      strided_for_each<4>(shape, st, [&](const std::array<int64_t, 4>& off, const std::array<int64_t, 4>& s,
                                         int64_t n) {
        T* o = po + off[0];
        const C* c = pc + off[1];
        const T* x = pa + off[2];
        const T* y = pb + off[3];
        for (int64_t i = 0; i < n; ++i) o[i * s[0]] = c[i * s[1]] != C(0) ? x[i * s[2]] : y[i * s[3]];
      });
    });
  });
  return out;
}

// ---- in place ---------------------------------------------------------------------------------------------------------
void add_(Tensor& dst, const Tensor& src, double alpha) {
  check_float_pair(dst, src, "add_");
  if (broadcast_shapes(dst.shape(), src.shape(), "add_") != dst.shape())
    throw Error("add_: cannot broadcast " + shape_str(src.shape()) + " into destination " + shape_str(dst.shape()));
  const std::array<Shape, 2> st{dst.strides(), broadcast_strides(src, dst.shape(), "add_")};
  dispatch_float(dst.dtype(), "add_", [&](auto z) {
    using T = decltype(z);
    T* pd = dst.data<T>();
    const T* ps = src.data<T>();
    const T al = (T)alpha;
    strided_for_each<2>(dst.shape(), st, [&](const std::array<int64_t, 2>& off, const std::array<int64_t, 2>& s,
                                             int64_t n) {
      T* o = pd + off[0];
      const T* x = ps + off[1];
      if (s[0] == 1 && s[1] == 1) {
        if (al == T(1))
          for (int64_t i = 0; i < n; ++i) o[i] += x[i];
        else
          for (int64_t i = 0; i < n; ++i) o[i] += al * x[i];
      } else {
        for (int64_t i = 0; i < n; ++i) o[i * s[0]] += al * x[i * s[1]];
      }
    });
  });
}

void mul_(Tensor& dst, double s) {
  detail::check_defined(dst, "mul_");
  const std::array<Shape, 1> st{dst.strides()};
  dispatch_float(dst.dtype(), "mul_", [&](auto z) {
    using T = decltype(z);
    T* pd = dst.data<T>();
    const T sv = (T)s;
    strided_for_each<1>(dst.shape(), st, [&](const std::array<int64_t, 1>& off, const std::array<int64_t, 1>& k,
                                             int64_t n) {
      T* o = pd + off[0];
      if (k[0] == 1)
        for (int64_t i = 0; i < n; ++i) o[i] *= sv;
      else
        for (int64_t i = 0; i < n; ++i) o[i * k[0]] *= sv;
    });
  });
}

}  // namespace t2m
