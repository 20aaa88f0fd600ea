// loss_token_pool.cpp — masked log-mean-exp forward/backward kernels (llm.c style), OpenMP over the N·J rows.
#include "nn/loss_token_pool.h"

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "autograd/node.h"
#include "tensor/parallel.h"

namespace t2m::nn {
namespace {

constexpr const char* kOp = "masked_log_mean_exp";

int threads_for(int64_t work) { return work >= kParallelGrain ? get_num_threads() : 1; }

// x (N, J, K), valid (J, K) 0/1 bytes -> out (N, J)
// Also writes lse[r] = log Σ_valid exp(x) in double: the backward uses it rather than the rounded float32 out.
template <typename T>
void lme_forward(const T* x, const std::vector<uint8_t>& valid, const std::vector<double>& log_k, T* out,
                 double* lse, int64_t N, int64_t J, int64_t K) {
  const int nt = threads_for(N * J * K);
#pragma omp parallel for if (nt > 1) num_threads(nt) schedule(static)
  for (int64_t r = 0; r < N * J; ++r) {
    const int64_t j = r % J;
    const T* row = x + r * K;
    const uint8_t* v = valid.data() + j * K;
    double mx = -std::numeric_limits<double>::infinity();
    for (int64_t k = 0; k < K; ++k)
      if (v[k] && (double)row[k] > mx) mx = (double)row[k];
    double s = 0.0;
    for (int64_t k = 0; k < K; ++k)
      if (v[k]) s += std::exp((double)row[k] - mx);
    lse[r] = mx + std::log(s);
    out[r] = (T)(lse[r] - log_k[j]);
  }
}

// g (N, J), x (N, J, K), lse (N, J) -> dx (N, J, K)
template <typename T>
void lme_backward(const T* g, const T* x, const double* lse, const std::vector<uint8_t>& valid, T* dx, int64_t N,
                  int64_t J, int64_t K) {
  const int nt = threads_for(N * J * K);
#pragma omp parallel for if (nt > 1) num_threads(nt) schedule(static)
  for (int64_t r = 0; r < N * J; ++r) {
    const int64_t j = r % J;
    const uint8_t* v = valid.data() + j * K;
    const double gr = (double)g[r];
    for (int64_t k = 0; k < K; ++k)
      dx[r * K + k] = v[k] ? (T)(gr * std::exp((double)x[r * K + k] - lse[r])) : T(0);
  }
}

}  // namespace

// x (N, J, K), valid (J, K) -> (N, J)
ag::Variable masked_log_mean_exp(const ag::Variable& x, const Tensor& valid) {
  if (!x.defined() || !valid.defined()) throw Error(std::string(kOp) + ": x or valid is undefined");
  if (x.dim() != 3 || (x.dtype() != DType::f32 && x.dtype() != DType::f64))
    throw Error(std::string(kOp) + ": x must be a float (N, J, K) tensor, got " + dtype_name(x.dtype()) + " " +
                shape_str(x.shape()));
  const int64_t N = x.size(0), J = x.size(1), K = x.size(2);
  if (valid.shape() != Shape{J, K})
    throw Error(std::string(kOp) + ": valid must be " + shape_str({J, K}) + " for x " + shape_str(x.shape()) +
                ", got " + shape_str(valid.shape()));
  const std::vector<double> vd = valid.to(DType::f64).contiguous().to_vector<double>();
  std::vector<uint8_t> v(vd.size());
  std::vector<double> log_k(J);
  for (int64_t j = 0; j < J; ++j) {
    int64_t n = 0;
    for (int64_t k = 0; k < K; ++k) n += (v[j * K + k] = vd[j * K + k] != 0.0 ? 1 : 0);
    if (n == 0) throw Error(std::string(kOp) + ": row " + std::to_string(j) + " of valid has no valid entry");
    log_k[j] = std::log((double)n);
  }
  const Tensor tx = x.data().contiguous();
  Tensor out = Tensor::empty({N, J}, tx.dtype());
  Tensor lse = Tensor::empty({N, J}, DType::f64);
  if (tx.dtype() == DType::f32)
    lme_forward(tx.data<float>(), v, log_k, out.data<float>(), lse.data<double>(), N, J, K);
  else
    lme_forward(tx.data<double>(), v, log_k, out.data<double>(), lse.data<double>(), N, J, K);
  const bool save = ag::any_requires_grad({x});
  Tensor sx = save ? tx : Tensor(), sl = save ? lse : Tensor();
  return ag::record(kOp, out, {x}, [sx, sl, v, N, J, K](const Tensor& g, const std::vector<bool>&) {
    const Tensor gc = g.contiguous();
    Tensor dx = Tensor::empty({N, J, K}, sx.dtype());
    if (sx.dtype() == DType::f32)
      lme_backward(gc.data<float>(), sx.data<float>(), sl.data<double>(), v, dx.data<float>(), N, J, K);
    else
      lme_backward(gc.data<double>(), sx.data<double>(), sl.data<double>(), v, dx.data<double>(), N, J, K);
    return std::vector<Tensor>{dx};
  });
}

}  // namespace t2m::nn
