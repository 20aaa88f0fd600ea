// vq_codebook.h — the vector-quantisation codebook of the T2M-GPT motion tokenizer (van den Oord et al. 2017;
// T2M-GPT's QuantizeEMAReset), used by models/casim/vq_vae.h.
//
// State (all registered as non-trainable module tensors so that save_to/load_from and nn::TrainState carry them;
// they never get gradients, the optimizer must not see them — see trainable_parameters in vq_vae.h):
//   "codebook"   (K, C)  the codes e_k
//   "ema_sum"    (K, C)  exponential moving average of the sum of encoder outputs assigned to code k
//   "ema_count"  (K)     exponential moving average of the number of encoder outputs assigned to code k
//   "initialised" (1)    0 until the first training batch has set the codes from encoder outputs
//
// assign(z) z (N, C) -> (N) int64: k*(n) = argmin_k ||z_n − e_k||² (ties: the lowest k)           VQ-VAE Eq 1
// lookup(ids) ids (N) -> (N, C): e_{ids}
// quantize_st(z_e, ids) z_e (N, C) -> z_e + sg(e_{ids} − z_e): the value of e_{ids}, the gradient of z_e
//   (straight-through estimator, VQ-VAE Sec. 3.1).
// ema_update(z, ids): with counts c_k = #{n: ids_n = k}, sums s_k = Σ_{ids_n = k} z_n and decay μ:
//     ema_count ← μ ema_count + (1 − μ) c,   ema_sum ← μ ema_sum + (1 − μ) s                   (VQ-VAE App. A.1)
//     e_k ← ema_sum_k / ema_count_k  where ema_count_k ≥ dead_threshold (the code is alive)
//   Dead-code reset (T2M-GPT): every code with ema_count_k < dead_threshold is "dead" (unused for a while) and is
//   replaced by an encoder output of this batch, z_{r_k}, r_k drawn uniformly from [0, N) with the Generator; its
//   ema_sum becomes z_{r_k} and its ema_count 1 (T2M-GPT sets the code only; we also restart its averages so the
//   next update does not pull it straight back). Returns the number of codes reset.
//   The very first update (initialised = 0) instead sets every code from random encoder outputs (T2M-GPT's init)
//   with ema_count 1.
// Usage statistics: code_usage(ids, K) -> counts; perplexity = exp(−Σ p_k log p_k) with p = counts / N.
// Errors (t2m::Error "vq codebook: ..."): K < 1 or C < 1, decay outside [0, 1), dead_threshold < 0; z not (N, C);
// ids not int64 (N) or out of [0, K); an empty batch in ema_update.
#pragma once
#include <cstdint>
#include <vector>

#include "autograd/variable.h"
#include "nn/module.h"
#include "tensor/rng.h"

namespace t2m::casim {

struct VqCodebookConfig {
  int64_t codes = 512;          // K
  int64_t dim = 128;            // C
  double decay = 0.99;          // μ (T2M-GPT)
  double dead_threshold = 1.0;  // ema_count below this = dead (T2M-GPT: usage = code_count >= 1)
};

class VqCodebook : public nn::Module {
 public:
  VqCodebook(const VqCodebookConfig& cfg, Generator& gen);

  Tensor assign(const Tensor& z) const;                                           // VQ-VAE Eq 1
  Tensor lookup(const Tensor& ids) const;
  ag::Variable quantize_st(const ag::Variable& z_e, const Tensor& ids) const;     // straight-through
  int64_t ema_update(const Tensor& z, const Tensor& ids, Generator& gen);        // EMA + dead-code reset
  bool initialised() const;

  const Tensor& codebook() const { return codebook_.data(); }
  const Tensor& ema_sum() const { return ema_sum_.data(); }
  const Tensor& ema_count() const { return ema_count_.data(); }
  const VqCodebookConfig& config() const { return cfg_; }

 private:
  VqCodebookConfig cfg_;
  ag::Variable codebook_, ema_sum_, ema_count_, init_;
};

// Counts per code (K) of the ids (any shape, int64; entries < 0 are skipped).
std::vector<int64_t> code_usage(const Tensor& ids, int64_t codes);
// exp(entropy) of the code distribution given by counts; 0 when there are no counts.
double code_perplexity(const std::vector<int64_t>& counts);

}  // namespace t2m::casim
