// test_tensor_util.h — helpers for the tensor/ops tests: error-message checks, raw strided element access that
// does not go through the code under test, deterministic test data, and layout variants of one logical tensor
// (contiguous, strided slice, transposed storage, stride-0 expand) for running every op on every layout.
#pragma once
#include <gtest/gtest.h>

#include <functional>
#include <random>
#include <string>
#include <vector>

#include "tensor/ops.h"
#include "tensor/rng.h"
#include "tensor/tensor.h"

namespace t2m::testing {

// Runs f, expects t2m::Error whose message contains every part.
template <typename F>
void expect_error(F&& f, const std::vector<std::string>& parts) {
  try {
    f();
  } catch (const Error& e) {
    const std::string msg = e.what();
    for (const auto& p : parts) EXPECT_NE(msg.find(p), std::string::npos) << "message '" << msg << "' lacks '" << p << "'";
    return;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected t2m::Error, got another exception: " << e.what();
    return;
  }
  ADD_FAILURE() << "expected t2m::Error, nothing was thrown";
}

// Raw read/write by multi-index straight from storage + offset + strides.
inline double raw_get(const Tensor& t, const std::vector<int64_t>& idx) {
  int64_t off = t.offset();
  for (size_t d = 0; d < idx.size(); ++d) off += idx[d] * t.strides()[d];
  switch (t.dtype()) {
    case DType::f32: return static_cast<const float*>(t.storage()->data)[off];
    case DType::f64: return static_cast<const double*>(t.storage()->data)[off];
    default: return (double)static_cast<const int64_t*>(t.storage()->data)[off];
  }
}
inline void raw_set(const Tensor& t, const std::vector<int64_t>& idx, double v) {
  int64_t off = t.offset();
  for (size_t d = 0; d < idx.size(); ++d) off += idx[d] * t.strides()[d];
  switch (t.dtype()) {
    case DType::f32: static_cast<float*>(t.storage()->data)[off] = (float)v; break;
    case DType::f64: static_cast<double*>(t.storage()->data)[off] = v; break;
    default: static_cast<int64_t*>(t.storage()->data)[off] = (int64_t)v; break;
  }
}

// Calls f(idx) for every multi-index of shape in row-major order.
inline void for_each_index(const Shape& shape, const std::function<void(const std::vector<int64_t>&)>& f) {
  for (int64_t v : shape)
    if (v == 0) return;
  std::vector<int64_t> idx(shape.size(), 0);
  while (true) {
    f(idx);
    int64_t d = (int64_t)shape.size() - 1;
    for (; d >= 0; --d) {
      if (++idx[d] < shape[d]) break;
      idx[d] = 0;
    }
    if (d < 0) return;
  }
}

// Row-major values of t read through raw_get.
inline std::vector<double> raw_values(const Tensor& t) {
  std::vector<double> v;
  for_each_index(t.shape(), [&](const std::vector<int64_t>& i) { v.push_back(raw_get(t, i)); });
  return v;
}

// N(0, 1) samples from t2m's own Generator seeded with `seed` (model-style test data).
inline Tensor randn(const Shape& shape, uint64_t seed, DType dt = DType::f64) {
  Generator g(seed);
  return rand_normal(shape, g, 0.0, 1.0, dt);
}

// A contiguous tensor with values uniform in [lo, hi) from std::mt19937 (independent of t2m's RNG).
inline Tensor random_tensor(const Shape& shape, DType dt, uint32_t seed, double lo = -2.0, double hi = 2.0) {
  Tensor t = Tensor::empty(shape, dt);
  std::mt19937 g(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  for_each_index(shape, [&](const std::vector<int64_t>& i) { raw_set(t, i, u(g)); });
  return t;
}

// Copies of `base` (same logical values) in other layouts.
// Strided: the tensor lives in every second element of the last dim of a bigger buffer.
inline Tensor strided_copy(const Tensor& base) {
  if (base.dim() == 0) return base.clone();
  Shape big = base.shape();
  big.back() = big.back() * 2 + 1;
  Tensor t = Tensor::full(big, 777.0, base.dtype()).slice(-1, 1, big.back(), 2);
  for_each_index(base.shape(), [&](const std::vector<int64_t>& i) { raw_set(t, i, raw_get(base, i)); });
  return t;
}
// Transposed storage: a contiguous tensor with the first and last dims swapped, viewed back.
inline Tensor transposed_copy(const Tensor& base) {
  if (base.dim() < 2) return strided_copy(base);
  Shape s = base.shape();
  std::swap(s.front(), s.back());
  Tensor t = Tensor::empty(s, base.dtype()).transpose(0, -1);
  for_each_index(base.shape(), [&](const std::vector<int64_t>& i) { raw_set(t, i, raw_get(base, i)); });
  return t;
}

// All layout variants of base: {contiguous, strided, transposed}.
inline std::vector<Tensor> layouts(const Tensor& base) { return {base, strided_copy(base), transposed_copy(base)}; }

// Expect t (any layout) to hold exactly shape `shape` and row-major values `want` within tol.
inline void expect_values(const Tensor& t, const Shape& shape, const std::vector<double>& want, double tol,
                          const std::string& what = "") {
  ASSERT_EQ(shape_str(t.shape()), shape_str(shape)) << what;
  const std::vector<double> got = raw_values(t);
  ASSERT_EQ(got.size(), want.size()) << what;
  for (size_t i = 0; i < got.size(); ++i) {
    if (std::isnan(want[i])) {
      EXPECT_TRUE(std::isnan(got[i])) << what << " at " << i;
      continue;
    }
    if (got[i] == want[i]) continue;  // also equal infinities
    EXPECT_NEAR(got[i], want[i], tol * std::max(1.0, std::abs(want[i]))) << what << " at flat index " << i;
  }
}

inline double tol_for(DType dt) { return dt == DType::f32 ? 2e-6 : 1e-13; }

}  // namespace t2m::testing
