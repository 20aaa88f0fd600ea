// vq_codebook.cpp — nearest-code assignment, straight-through quantisation, EMA updates and dead-code reset.
#include "models/casim/vq_codebook.h"

#include <cmath>
#include <limits>
#include <string>

#include "autograd/ops_elementwise.h"
#include "tensor/tensor.h"
#include "tensor/ops.h"

namespace t2m::casim {

namespace {

std::string shape_str(const Shape& s) {
  std::string r = "(";
  for (size_t i = 0; i < s.size(); ++i) r += (i ? ", " : "") + std::to_string(s[i]);
  return r + ")";
}

void check_z(const Tensor& z, int64_t C, const char* who) {
  if (z.dim() != 2 || z.size(1) != C)
    throw Error(std::string("vq codebook: ") + who + ": z must be (N, " + std::to_string(C) + "), got " +
                shape_str(z.shape()));
}

void check_ids(const Tensor& ids, int64_t N, int64_t K, const char* who) {
  if (ids.dtype() != DType::i64 || ids.dim() != 1 || ids.size(0) != N)
    throw Error(std::string("vq codebook: ") + who + ": ids must be int64 (" + std::to_string(N) + "), got " +
                shape_str(ids.shape()));
  const Tensor c = ids.contiguous();
  const int64_t* p = c.data<int64_t>();
  for (int64_t n = 0; n < N; ++n)
    if (p[n] < 0 || p[n] >= K)
      throw Error(std::string("vq codebook: ") + who + ": id " + std::to_string(p[n]) + " at " + std::to_string(n) +
                  " outside [0, " + std::to_string(K) + ")");
}

}  // namespace

VqCodebook::VqCodebook(const VqCodebookConfig& cfg, Generator& gen) : cfg_(cfg) {
  if (cfg.codes < 1 || cfg.dim < 1) throw Error("vq codebook: codes and dim must be >= 1");
  if (!(cfg.decay >= 0 && cfg.decay < 1)) throw Error("vq codebook: decay must be in [0, 1)");
  if (!(cfg.dead_threshold >= 0)) throw Error("vq codebook: dead_threshold must be >= 0");
  codebook_ = register_parameter("codebook", rand_normal({cfg.codes, cfg.dim}, gen));
  ema_sum_ = register_parameter("ema_sum", codebook_.data().clone());
  ema_count_ = register_parameter("ema_count", Tensor::ones({cfg.codes}));
  init_ = register_parameter("initialised", Tensor::zeros({1}));
  for (auto* v : {&codebook_, &ema_sum_, &ema_count_, &init_}) v->set_requires_grad(false);
}

bool VqCodebook::initialised() const { return init_.data().contiguous().data<float>()[0] != 0.0f; }

// VQ-VAE Eq 1: k*(n) = argmin_k ||z_n − e_k||² = argmin_k (||e_k||² − 2 z_n·e_k).
Tensor VqCodebook::assign(const Tensor& z) const {
  check_z(z, cfg_.dim, "assign");
  const int64_t N = z.size(0), K = cfg_.codes;
  const Tensor e = codebook_.data().to(z.dtype()).contiguous();
  const Tensor dots = matmul_t(z, false, e, true).to(DType::f64).contiguous();  // (N, K)
  const Tensor e2 = sum(square(e.to(DType::f64)), {1}).contiguous();            // (K)
  const double* pd = dots.data<double>();
  const double* pe = e2.data<double>();
  std::vector<int64_t> ids(N);
  for (int64_t n = 0; n < N; ++n) {
    double best = std::numeric_limits<double>::infinity();
    int64_t bk = 0;
    for (int64_t k = 0; k < K; ++k) {
      const double d = pe[k] - 2.0 * pd[n * K + k];
      if (d < best) best = d, bk = k;
    }
    ids[n] = bk;
  }
  return Tensor::from_vector(ids, {N});
}

Tensor VqCodebook::lookup(const Tensor& ids) const {
  check_ids(ids, ids.dim() == 1 ? ids.size(0) : -1, cfg_.codes, "lookup");
  return index_select(codebook_.data(), 0, ids);
}

// Straight-through estimator (VQ-VAE Sec. 3.1): forward e_{ids}, backward the identity to z_e.
ag::Variable VqCodebook::quantize_st(const ag::Variable& z_e, const Tensor& ids) const {
  check_z(z_e.data(), cfg_.dim, "quantize_st");
  check_ids(ids, z_e.size(0), cfg_.codes, "quantize_st");
  const Tensor zq = lookup(ids).to(z_e.dtype());
  return ag::add(z_e, ag::Variable(sub(zq, z_e.data())));
}

// VQ-VAE App. A.1 (EMA codebook) + T2M-GPT's dead-code reset.
int64_t VqCodebook::ema_update(const Tensor& z_in, const Tensor& ids_in, Generator& gen) {
  check_z(z_in, cfg_.dim, "ema_update");
  const int64_t N = z_in.size(0), K = cfg_.codes, C = cfg_.dim;
  if (N < 1) throw Error("vq codebook: ema_update: empty batch");
  check_ids(ids_in, N, K, "ema_update");
  const Tensor z = z_in.to(DType::f32).contiguous();
  const Tensor ids = ids_in.contiguous();
  const float* pz = z.data<float>();
  const int64_t* pi = ids.data<int64_t>();
  float* pe = codebook_.data().data<float>();
  float* ps = ema_sum_.data().data<float>();
  float* pc = ema_count_.data().data<float>();
  // One random encoder output per code, drawn for every code so the Generator advances the same way each step.
  const std::vector<int64_t> pick = randint({K}, gen, 0, N).to_vector<int64_t>();
  if (!initialised()) {
    for (int64_t k = 0; k < K; ++k) {
      for (int64_t c = 0; c < C; ++c) pe[k * C + c] = ps[k * C + c] = pz[pick[k] * C + c];
      pc[k] = 1.0f;
    }
    init_.data().data<float>()[0] = 1.0f;
    return K;
  }
  std::vector<double> cnt(K, 0.0), sm(K * C, 0.0);
  for (int64_t n = 0; n < N; ++n) {
    cnt[pi[n]] += 1.0;
    for (int64_t c = 0; c < C; ++c) sm[pi[n] * C + c] += pz[n * C + c];
  }
  const double mu = cfg_.decay;
  int64_t reset = 0;
  for (int64_t k = 0; k < K; ++k) {
    pc[k] = (float)(mu * pc[k] + (1.0 - mu) * cnt[k]);
    for (int64_t c = 0; c < C; ++c) ps[k * C + c] = (float)(mu * ps[k * C + c] + (1.0 - mu) * sm[k * C + c]);
    if (pc[k] >= cfg_.dead_threshold) {
      for (int64_t c = 0; c < C; ++c) pe[k * C + c] = ps[k * C + c] / pc[k];
    } else {
      ++reset;
      for (int64_t c = 0; c < C; ++c) pe[k * C + c] = ps[k * C + c] = pz[pick[k] * C + c];
      pc[k] = 1.0f;
    }
  }
  return reset;
}

std::vector<int64_t> code_usage(const Tensor& ids, int64_t codes) {
  std::vector<int64_t> counts(codes, 0);
  for (int64_t v : ids.to_vector<int64_t>())
    if (v >= 0 && v < codes) ++counts[v];
  return counts;
}

double code_perplexity(const std::vector<int64_t>& counts) {
  double n = 0, h = 0;
  for (int64_t c : counts) n += (double)c;
  if (n <= 0) return 0.0;
  for (int64_t c : counts)
    if (c > 0) h -= (c / n) * std::log(c / n);
  return std::exp(h);
}

}  // namespace t2m::casim
