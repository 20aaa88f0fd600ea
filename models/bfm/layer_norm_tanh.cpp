// layer_norm_tanh.cpp — forward: the fused LayerNorm kernel, then tanh in place, a block of rows at a time;
// backward: the fused LayerNorm backward with the tanh's (1 - y^2) applied to each row first (tanh_out; input
// gradient written, weight/bias gradients accumulated into fresh zeros).
#include "models/bfm/layer_norm_tanh.h"

#include <bit>
#include <cmath>
#include <algorithm>
#include <cstdint>
#include <string>

#include "autograd/node.h"
#include "tensor/fused/layer_norm.h"
#include "tensor/parallel.h"

namespace t2m::bfm {

namespace {

// e^x for x <= 0 (what tanh needs: x = -2|u|), x clamped to >= -20: x = n ln2 + r, |r| <= ln2/2, degree-6
// Taylor for e^r, 2^n through the exponent bits. Branch-free, so loops over it vectorise: the clamp is an
// unsigned min on the bit patterns (for x <= 0 a larger magnitude is a larger pattern), because a float compare
// is not if-converted under the default -ftrapping-math.
inline float exp_neg(float x) {
  constexpr float kRound = 12582912.f;  // 1.5 * 2^23: adding it rounds to the nearest integer
  x = std::bit_cast<float>(std::min(std::bit_cast<uint32_t>(x), std::bit_cast<uint32_t>(-20.f)));
  const float t = x * 1.44269504f + kRound;
  const float n = t - kRound;
  const int32_t ni = std::bit_cast<int32_t>(t) - std::bit_cast<int32_t>(kRound);
  const float r = (x - n * 0.693145751953125f) - n * 1.428606765330187e-6f;
  float p = 1.f / 720.f;
  p = p * r + 1.f / 120.f;
  p = p * r + 1.f / 24.f;
  p = p * r + 1.f / 6.f;
  p = p * r + 0.5f;
  p = p * r + 1.f;
  p = p * r + 1.f;
  return p * std::bit_cast<float>((ni + 127) << 23);
}

// tanh(u) = sign(u) (1 - e) / (1 + e), e = e^{-2|u|} in (0, 1]: no overflow, no cancellation near 0 beyond
// the absolute error of e.
inline float tanh_f(float u) {
  const float e = exp_neg(-2.f * std::fabs(u));
  const float m = (1.f - e) / (1.f + e);  // >= 0
  return std::bit_cast<float>(std::bit_cast<uint32_t>(m) | (std::bit_cast<uint32_t>(u) & 0x80000000u));
}

// y[i] = tanh(y[i]) over one span (a plain loop the compiler vectorises).
void tanh_span(float* __restrict y, int64_t n) {
  for (int64_t i = 0; i < n; ++i) y[i] = tanh_f(y[i]);
}

// y [N, C] = tanh(LayerNorm(x)) and the row statistics, in blocks of rows: each block's LayerNorm (the fused kernel,
// one thread) and then its tanh while the block is still in L1/L2 (as two passes over all of y, the tanh read y
// back from L3: ~1 % of an fb-w1024 step). Every row's arithmetic is the kernel's, so the bits are too.
template <typename T>
void layer_norm_tanh_rows(T* y, T* mean, T* rstd, const T* x, const T* w, const T* b, int64_t N, int64_t C, T eps) {
  const int64_t block = std::max<int64_t>(1, 8192 / C);  // rows of <= 32 KB (float): one L1's worth
  const int nt = N * C < kParallelGrain ? 1 : get_num_threads();
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int64_t r0 = 0; r0 < N; r0 += block) {
    const int64_t rows = std::min(block, N - r0);
    T* yr = y + r0 * C;
    fused::layer_norm_forward<T>(yr, mean + r0, rstd + r0, x + r0 * C, w, b, rows, C, eps);
    if constexpr (std::is_same_v<T, float>)
      tanh_span(yr, rows * C);
    else
      for (int64_t i = 0; i < rows * C; ++i) yr[i] = std::tanh(yr[i]);
  }
}

template <typename T>
T* ptr(const Tensor& t) { return t.defined() ? const_cast<T*>(t.data<T>()) : nullptr; }

}  // namespace

float fast_tanh(float u) { return tanh_f(u); }

// x [N, C] (leading dims flattened) -> y [N, C];  saved: x, y, mean [N], rstd [N], weight
ag::Variable layer_norm_tanh(const ag::Variable& x, const ag::Variable& weight, const ag::Variable& bias,
                             double eps) {
  if (x.dim() < 1 || x.size(-1) < 1)
    throw Error("layer_norm_tanh: x must have a non-empty last dim, got " + shape_str(x.shape()));
  const DType dt = x.dtype();
  if (dt != DType::f32 && dt != DType::f64) throw Error("layer_norm_tanh: x must be f32 or f64");
  const int64_t C = x.size(-1), N = x.numel() / C;
  for (const ag::Variable* p : {&weight, &bias})
    if (p->defined() && (p->shape() != Shape{C} || p->dtype() != dt))
      throw Error("layer_norm_tanh: weight/bias must be [" + std::to_string(C) + "] " + dtype_name(dt) + ", got " +
                  shape_str(p->shape()) + " " + dtype_name(p->dtype()));
  const Tensor xc = x.data().contiguous();
  const Tensor w = weight.defined() ? weight.data().contiguous() : Tensor();
  const Tensor b = bias.defined() ? bias.data().contiguous() : Tensor();
  Tensor y = Tensor::empty(xc.shape(), dt), mean = Tensor::empty({N}, dt), rstd = Tensor::empty({N}, dt);
  if (dt == DType::f32) {
    layer_norm_tanh_rows<float>(y.data<float>(), mean.data<float>(), rstd.data<float>(), xc.data<float>(),
                                ptr<float>(w), ptr<float>(b), N, C, (float)eps);
  } else {
    layer_norm_tanh_rows<double>(y.data<double>(), mean.data<double>(), rstd.data<double>(), xc.data<double>(),
                                 ptr<double>(w), ptr<double>(b), N, C, eps);
  }
  std::vector<ag::Variable> inputs = {x};
  if (weight.defined()) inputs.push_back(weight);
  if (bias.defined()) inputs.push_back(bias);
  if (!ag::any_requires_grad(inputs)) return ag::Variable(y);
  const bool has_w = weight.defined(), has_b = bias.defined();
  return ag::record(
      "layer_norm_tanh", y, inputs,
      [xc, y, mean, rstd, w, N, C, has_w, has_b](const Tensor& g, const std::vector<bool>& need) {
        const DType dt = xc.dtype();
        Tensor dx = need[0] ? Tensor::empty(xc.shape(), dt) : Tensor();
        const size_t iw = 1, ib = has_w ? 2 : 1;
        Tensor dw = has_w && need[iw] ? Tensor::zeros({C}, dt) : Tensor();
        Tensor db = has_b && need[ib] ? Tensor::zeros({C}, dt) : Tensor();
        if (need[0] || dw.defined() || db.defined()) {  // the tanh's backward runs inside the LayerNorm's (tanh_out)
          const Tensor gc = g.contiguous();
          Tensor dxs = dx.defined() ? dx : Tensor::empty(xc.shape(), dt);
          if (dt == DType::f32)
            fused::layer_norm_backward<float>(dxs.data<float>(), ptr<float>(dw), ptr<float>(db), gc.data<float>(),
                                              xc.data<float>(), ptr<float>(w), mean.data<float>(),
                                              rstd.data<float>(), N, C, y.data<float>());
          else
            fused::layer_norm_backward<double>(dxs.data<double>(), ptr<double>(dw), ptr<double>(db),
                                               gc.data<double>(), xc.data<double>(), ptr<double>(w),
                                               mean.data<double>(), rstd.data<double>(), N, C, y.data<double>());
        }
        std::vector<Tensor> out = {dx};
        if (has_w) out.push_back(dw);
        if (has_b) out.push_back(db);
        return out;
      });
}

}  // namespace t2m::bfm
