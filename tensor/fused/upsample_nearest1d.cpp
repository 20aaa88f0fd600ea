// upsample_nearest1d.cpp — row-parallel copy / strided sum.
#include "tensor/fused/upsample_nearest1d.h"

#include "tensor/fused/kernel_util.h"

namespace t2m::fused {

namespace {
void check_up(const char* op, int64_t N, int64_t Tlen, int64_t scale, const void* a, const void* b) {
  check_dim(op, "N", N, 0);
  check_dim(op, "T", Tlen, 1);
  check_dim(op, "scale", scale, 1);
  if (N == 0) return;
  check_ptr(op, "output", a);
  check_ptr(op, "input", b);
}
}  // namespace

template <typename T>
void upsample_nearest1d_forward(T* out, const T* inp, int64_t N, int64_t Tlen, int64_t scale) {
  check_up("upsample_nearest1d_forward", N, Tlen, scale, out, inp);
  const int64_t To = Tlen * scale;
  const int nt = fused_threads(N * To);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t i = 0; i < N; ++i) {
    const T* x = inp + i * Tlen;
    T* y = out + i * To;
    for (int64_t t = 0; t < Tlen; ++t)
      for (int64_t s = 0; s < scale; ++s) y[t * scale + s] = x[t];
  }
}

template <typename T>
void upsample_nearest1d_backward(T* dinp, const T* dout, int64_t N, int64_t Tlen, int64_t scale) {
  check_up("upsample_nearest1d_backward", N, Tlen, scale, dinp, dout);
  const int64_t To = Tlen * scale;
  const int nt = fused_threads(N * To);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t i = 0; i < N; ++i) {
    const T* dy = dout + i * To;
    T* dx = dinp + i * Tlen;
    for (int64_t t = 0; t < Tlen; ++t) {
      T s = 0;
      for (int64_t k = 0; k < scale; ++k) s += dy[t * scale + k];
      dx[t] = s;
    }
  }
}

template void upsample_nearest1d_forward<float>(float*, const float*, int64_t, int64_t, int64_t);
template void upsample_nearest1d_forward<double>(double*, const double*, int64_t, int64_t, int64_t);
template void upsample_nearest1d_backward<float>(float*, const float*, int64_t, int64_t, int64_t);
template void upsample_nearest1d_backward<double>(double*, const double*, int64_t, int64_t, int64_t);

}  // namespace t2m::fused
