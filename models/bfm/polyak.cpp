// polyak.cpp — one pass per tensor: t = t * (1 - tau) then t = t + tau * p.
#include "models/bfm/polyak.h"

#include <string>

#include "tensor/parallel.h"

namespace t2m::bfm {

namespace {
template <typename T>
void soft_update(T* t, const T* p, int64_t n, T keep, T tau) {
  const int nt = n < kParallelGrain ? 1 : get_num_threads();
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int64_t i = 0; i < n; ++i) {
    const T a = t[i] * keep;
    const T b = tau * p[i];
    t[i] = a + b;
  }
}
}  // namespace

void polyak_update(const std::vector<ag::Variable>& target, const std::vector<ag::Variable>& source, double tau) {
  if (!(tau >= 0 && tau <= 1)) throw Error("polyak_update: tau must be in [0, 1], got " + std::to_string(tau));
  if (target.size() != source.size())
    throw Error("polyak_update: " + std::to_string(target.size()) + " target vs " + std::to_string(source.size()) +
                " source parameters");
  for (size_t i = 0; i < target.size(); ++i) {
    Tensor& t = target[i].data();
    const Tensor& p = source[i].data();
    if (t.shape() != p.shape() || t.dtype() != p.dtype() || !t.is_contiguous() || !p.is_contiguous())
      throw Error("polyak_update: parameter " + std::to_string(i) + " ('" + source[i].name() + "') target " +
                  shape_str(t.shape()) + " vs source " + shape_str(p.shape()) + " (shape/dtype/layout differ)");
    if (t.dtype() == DType::f32)
      soft_update<float>(t.data<float>(), p.data<float>(), t.numel(), (float)(1 - tau), (float)tau);
    else
      soft_update<double>(t.data<double>(), p.data<double>(), t.numel(), 1 - tau, tau);
  }
}

}  // namespace t2m::bfm
