// vq_vae.h — the T2M-GPT motion tokenizer (VQ-VAE over per-frame motion features) for the autoregressive half of
// the CASIM baseline (issue 11; CASIM paper Sec. 3.2: "an encoder-decoder network is trained to transform [the
// motion] into a sequence of motion tokens").
//
// Input: normalised features x (B, T, D) time-major (D = 257, models/data/features.h, normalised with the train-
// split statistics stored next to the model, vq_checkpoint.h), T a positive multiple of 2^levels (= 4 here).
// Layout (all convolutions zero-padded, non-causal, channel-first (B, C, T) inside; W = width):
//   encoder: "enc_in" conv k3 D->W, ReLU; per level l: "down<l>" conv k4 stride 2 W->W, "enc<l>_<i>"
//            nn::ResConvBlock (dilation growth^i, GroupNorm groups, no dropout) i < depth; "enc_out" conv k3 W->C
//   codebook "quant": models/casim/vq_codebook.h, K codes of width C
//   decoder: "dec_in" conv k3 C->W, ReLU; per level: "dec<l>_<i>" ResConvBlocks (dilations reversed), nearest x2
//            upsample, "up<l>" conv k3 W->W; "dec_mid" conv k3 W->W, ReLU; "dec_out" conv k3 W->D
// encode: x (B, T, D) -> z_e (B, T/4, C); decode: z_q (B, n, C) -> x̂ (B, 4n, D).
//
// Loss (vq_loss; T2M-GPT's recipe with MSE instead of smooth-L1, documented in docs/CASIM.md):
//   L = ||x̂ − x||²_mean + λ_vel ||Δx̂ − Δx||²_mean + β ||z_e − sg(z_q)||²_mean
//   Δ = difference of consecutive frames (the temporal velocity of every feature), means over real frames and
//   all channels (mask (B, T), 1 = real, padding only at the end), the commitment term over real latent frames
//   (latent frame j is real iff frame 4j is). λ_vel = 0.5 (T2M-GPT's vel weight), β = 0.02 (T2M-GPT commit).
//   The codebook is not in the graph: it learns by EMA (VqCodebook::ema_update, called by the trainer with
//   VqStep::z_real / ids_real after the gradient step).
// Errors (t2m::Error "vq vae: ..."): bad config; x not (B, T, D) with T a positive multiple of 4; mask not (B, T);
// ids out of range.
#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include <nlohmann/json.hpp>

#include "autograd/variable.h"
#include "models/casim/vq_codebook.h"
#include "nn/conv1d.h"
#include "nn/module.h"
#include "nn/optim.h"
#include "nn/res_conv_block.h"
#include "tensor/rng.h"

namespace t2m::casim {

struct VqVaeConfig {
  int64_t feature_dim = 257;  // D
  int64_t width = 128;        // W
  int64_t levels = 2;         // downsampling 2^levels = 4
  int64_t depth = 2;          // residual blocks per level
  int64_t growth = 3;         // dilations 1, 3, ...
  int64_t groups = 32;        // GroupNorm groups
  VqCodebookConfig codebook;  // K = 512, C = 128 (CPU config)
  double vel_weight = 0.5;    // λ_vel
  double commit = 0.02;       // β

  int64_t downsample() const { return int64_t{1} << levels; }
  nlohmann::json to_json() const;
  static VqVaeConfig from_json(const nlohmann::json& j);
  void validate() const;
};

class VqVae : public nn::Module {
 public:
  VqVae(const VqVaeConfig& cfg, Generator& gen);
  ag::Variable encode(const ag::Variable& x) const;     // (B, T, D) -> z_e (B, T/4, C)
  ag::Variable decode(const ag::Variable& z_q) const;   // (B, n, C) -> (B, 4n, D)
  // Code ids of normalised features: x (B, T, D) -> (B, T/4) int64 (no graph).
  Tensor tokenize(const Tensor& x) const;
  // Normalised features of code ids: ids (B, n) int64 -> (B, 4n, D) (no graph).
  Tensor detokenize(const Tensor& ids) const;
  // Every parameter except the codebook's EMA state (what the optimizer updates).
  nn::NamedParams trainable_parameters() const;

  VqCodebook& codebook() { return *quant_; }
  const VqCodebook& codebook() const { return *quant_; }
  const VqVaeConfig& config() const { return cfg_; }

 private:
  VqVaeConfig cfg_;
  std::shared_ptr<nn::Conv1d> enc_in_, enc_out_, dec_in_, dec_mid_, dec_out_;
  std::vector<std::shared_ptr<nn::Conv1d>> down_, up_;
  std::vector<std::vector<std::shared_ptr<nn::ResConvBlock>>> enc_res_, dec_res_;
  std::shared_ptr<VqCodebook> quant_;
  mutable Generator dropout_gen_{0};  // the residual blocks have dropout 0; forward still asks for a Generator
};

struct VqStep {
  ag::Variable loss;            // scalar L
  double rec = 0, vel = 0, commit = 0;
  Tensor ids;                   // (B, T/4) int64, -1 at padded latent frames
  Tensor z_real, ids_real;      // encoder outputs (N, C) and their codes (N) at the real latent frames
  ag::Variable recon;           // x̂ (B, T, D)
};

// One forward of the VQ-VAE with the loss above. x (B, T, D), mask (B, T) float (1 = real).
VqStep vq_loss(const VqVae& m, const Tensor& x, const Tensor& mask);

}  // namespace t2m::casim
