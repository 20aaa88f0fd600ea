// kernels.h — INTERNAL to tensor/: dtype dispatch and argument checks shared by the ops_*.cpp files.
//
// dispatch_float(dtype, op, f) calls f(float{}) or f(double{}) and throws Error naming `op` for int64;
// dispatch_all also accepts int64. map_unary is the one-input elementwise kernel. The functor is a generic lambda: [&](auto zero) { using T = decltype(zero); }.
#pragma once
#include <cstdint>
#include <string>

#include "tensor/strided_iter.h"
#include "tensor/tensor.h"

namespace t2m::detail {

template <typename F>
decltype(auto) dispatch_float(DType dt, const char* op, F&& f) {
  switch (dt) {
    case DType::f32: return f(float{});
    case DType::f64: return f(double{});
    default: break;
  }
  throw Error(std::string(op) + ": dtype " + dtype_name(dt) + " is not supported (needs f32 or f64)");
}

template <typename F>
decltype(auto) dispatch_all(DType dt, F&& f) {
  switch (dt) {
    case DType::f32: return f(float{});
    case DType::f64: return f(double{});
    default: return f(int64_t{});
  }
}

inline void check_defined(const Tensor& t, const char* op, const char* what = "input") {
  if (!t.defined()) throw Error(std::string(op) + ": " + what + " tensor is undefined");
}

// Both defined, same dtype, floating point.
inline void check_float_pair(const Tensor& a, const Tensor& b, const char* op) {
  check_defined(a, op, "first");
  check_defined(b, op, "second");
  if (a.dtype() != b.dtype())
    throw Error(std::string(op) + ": dtype mismatch " + dtype_name(a.dtype()) + " " + shape_str(a.shape()) +
                " vs " + dtype_name(b.dtype()) + " " + shape_str(b.shape()));
  if (a.dtype() == DType::i64)
    throw Error(std::string(op) + ": dtype i64 is not supported (needs f32 or f64), shapes " + shape_str(a.shape()) +
                " and " + shape_str(b.shape()));
}

inline void check_index(const Tensor& index, const char* op) {
  check_defined(index, op, "index");
  if (index.dtype() != DType::i64)
    throw Error(std::string(op) + ": index must be int64, got " + dtype_name(index.dtype()) + " " +
                shape_str(index.shape()));
}

// A large operand whose last dim is strided while another dim has unit stride (a transposed view) is read
// faster through the tiled transposing copy (ops_copy.cpp) than element by element: returns that copy, or t.
inline Tensor untranspose_large(const Tensor& t) {
  if (t.dim() < 2 || t.numel() < 4096 || t.strides().back() <= 1 || t.shape().back() == 1) return t;
  for (int64_t d = 0; d + 1 < t.dim(); ++d)
    if (t.strides()[d] == 1 && t.shape()[d] > 1) return t.contiguous();
  return t;
}

// out = f(a) elementwise (out contiguous, a any strides); f is a generic functor T -> T; a must be f32/f64.
template <typename F>
Tensor map_unary(const Tensor& a_in, const char* op, F f) {
  check_defined(a_in, op);
  const Tensor a = untranspose_large(a_in);
  Tensor out = Tensor::empty(a.shape(), a.dtype());
  const std::array<Shape, 2> st{out.strides(), a.strides()};
  dispatch_float(a.dtype(), op, [&](auto z) {
    using T = decltype(z);
    T* po = out.data<T>();
    const T* pa = a.data<T>();
    strided_for_each<2>(a.shape(), st, [&](const std::array<int64_t, 2>& off, const std::array<int64_t, 2>& s,
                                           int64_t n) {
      T* __restrict o = po + off[0];
      const T* x = pa + off[1];
      if (s[0] == 1 && s[1] == 1)
        for (int64_t i = 0; i < n; ++i) o[i] = f(x[i]);
      else
        for (int64_t i = 0; i < n; ++i) o[i * s[0]] = f(x[i * s[1]]);
    });
  });
  return out;
}

// ops_copy.cpp: dst[i] = src[i] (src broadcast to dst's shape, dtype converted); fill every element of dst.
void copy_strided(Tensor& dst, const Tensor& src, const char* op);
void fill_strided(Tensor& dst, double value);

}  // namespace t2m::detail
