// rope.cpp — one rotation routine with a sign for the direction (forward +angle, backward -angle).
#include "tensor/fused/rope.h"

#include <cmath>
#include <string>

#include "tensor/fused/kernel_util.h"

namespace t2m::fused {

template <typename T>
void rope_rotate_row(T* y, const T* x, const T* c, const T* s, int64_t h, T sign) {
  for (int64_t i = 0; i < h; ++i) {
    const T x0 = x[i], x1 = x[i + h], si = sign * s[i];
    y[i] = x0 * c[i] - x1 * si;
    y[i + h] = x0 * si + x1 * c[i];
  }
}

namespace {

void check_rope(const char* op, int64_t N, int64_t Tlen, int64_t d) {
  check_dim(op, "N", N, 0);
  check_dim(op, "T", Tlen, 1);
  check_dim(op, "d", d, 2);
  if (d % 2 != 0) throw Error(std::string(op) + ": head dim d must be even, got " + std::to_string(d));
}

template <typename T>
void rope_rotate(const char* op, T* out, const T* inp, const T* cos_tab, const T* sin_tab, int64_t N, int64_t Tlen,
                 int64_t d, T sign) {
  check_rope(op, N, Tlen, d);
  if (N == 0) return;
  check_ptr(op, "output", out);
  check_ptr(op, "input", inp);
  check_ptr(op, "cos_tab", cos_tab);
  check_ptr(op, "sin_tab", sin_tab);
  const int64_t h = d / 2;
  const int nt = fused_threads(N * Tlen * d);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t r = 0; r < N * Tlen; ++r) {
    const int64_t t = r % Tlen;
    rope_rotate_row(out + r * d, inp + r * d, cos_tab + t * h, sin_tab + t * h, h, sign);
  }
}

}  // namespace

template <typename T>
void rope_table(T* cos_tab, T* sin_tab, int64_t Tlen, int64_t d, double base, int64_t pos0) {
  check_rope("rope_table", 1, Tlen, d);
  if (!(base > 0)) throw Error("rope_table: base must be > 0, got " + std::to_string(base));
  check_ptr("rope_table", "cos_tab", cos_tab);
  check_ptr("rope_table", "sin_tab", sin_tab);
  const int64_t h = d / 2;
  for (int64_t t = 0; t < Tlen; ++t)
    for (int64_t i = 0; i < h; ++i) {
      const double theta = std::pow(base, -2.0 * (double)i / (double)d);  // theta_i = base^(-2i/d)
      const double ang = (double)(pos0 + t) * theta;
      cos_tab[t * h + i] = (T)std::cos(ang);
      sin_tab[t * h + i] = (T)std::sin(ang);
    }
}

template <typename T>
void rope_forward(T* out, const T* inp, const T* cos_tab, const T* sin_tab, int64_t N, int64_t Tlen, int64_t d) {
  rope_rotate<T>("rope_forward", out, inp, cos_tab, sin_tab, N, Tlen, d, (T)1);
}

template <typename T>
void rope_backward(T* dinp, const T* dout, const T* cos_tab, const T* sin_tab, int64_t N, int64_t Tlen,
                   int64_t d) {
  rope_rotate<T>("rope_backward", dinp, dout, cos_tab, sin_tab, N, Tlen, d, (T)-1);
}

template void rope_rotate_row<float>(float*, const float*, const float*, const float*, int64_t, float);
template void rope_rotate_row<double>(double*, const double*, const double*, const double*, int64_t, double);
template void rope_table<float>(float*, float*, int64_t, int64_t, double, int64_t);
template void rope_table<double>(double*, double*, int64_t, int64_t, double, int64_t);
template void rope_forward<float>(float*, const float*, const float*, const float*, int64_t, int64_t, int64_t);
template void rope_forward<double>(double*, const double*, const double*, const double*, int64_t, int64_t, int64_t);
template void rope_backward<float>(float*, const float*, const float*, const float*, int64_t, int64_t, int64_t);
template void rope_backward<double>(double*, const double*, const double*, const double*, int64_t, int64_t,
                                    int64_t);

}  // namespace t2m::fused
