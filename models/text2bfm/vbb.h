// vbb.h — the variational behavioral bottleneck of Text2BFM (Eq 3–4): a causal 1-D conv encoder q_φ(m | z) that
// compresses a policy-latent sequence z_{1:Tz} into the posterior of a shorter motion program m_{1:Tm}, and a
// decoder D_θ(m) back to ẑ_{1:Tz}. Exactly the anchor's MotionVAE (../shared/anchor/torch_ref.py, REFERENCE.md
// "vae"); ARCHITECTURE.md section 7.
//
// Layout (C = width, L = levels, "causal" = replicate padding on the left only, nn::Conv1dPad::causal):
//   encoder "enc":  0: causal conv k3 in_dim->C, ReLU;
//                   per level l: 2+2l: causal conv k4 stride 2 C->C,  3+2l: ResStack dilations 1, g, g^2, ...;
//                   2+2L: causal conv k3 C->2*latent  -> chunk along channels into (mu, logvar)
//   decoder "dec":  0: causal conv k3 latent->C, ReLU;
//                   per level l: 2+3l: ResStack dilations reversed, (3+3l: nearest x2 upsample),
//                                4+3l: causal conv k3 C->C;
//                   2+3L: causal conv k3 C->C, ReLU, 4+3L: causal conv k3 C->in_dim
//   ResStack "i": children "0".."depth-1", nn::ResConvBlock (GroupNorm -> ReLU -> causal dilated conv k3 ->
//   GroupNorm -> ReLU -> conv k1 -> dropout, + skip).
// Parameter names are torch's with the CausalConv1d wrapper's ".conv" removed: torch "enc.3.0.c1.conv.weight" is
// ours "enc.3.0.c1.weight", torch "enc.0.conv.bias" is ours "enc.0.bias" (vbb_torch_name maps ours -> torch).
// Parameters are drawn from the Generator in torch's construction order (enc then dec, front to back).
//
// Shapes: z (B, Tz, in_dim) time-major like the anchor's input; mu, logvar, m (B, latent, Tm) channel-first like
// the anchor's chunk; ẑ (B, Tz, in_dim). Tm = Tz / 2^L (compression 1/4/8/16 for L = 0/2/3/4; L = 0 is the
// "no compression" ablation of Table 3: no stride-2 level, no upsampling, Tm = Tz); Tz must be a
// positive multiple of 2^L (padding shorter clips is the caller's job, with frame masks in the losses).
// Causality: through the convolutions (replicate-left padding, strides, upsampling) encoder output frame j
// depends only on input frames < (j+1)·2^L and decoder frame t only on program frames <= t / 2^L. GroupNorm, as in
// the anchor (torch nn.GroupNorm), pools its statistics over the whole time axis of each group, so with depth >= 1
// every output also depends, through those two numbers per (sample, group), on every frame: the model is causal in
// its receptive field, not strictly causal (depth 0, no residual blocks, is strictly causal).
// Dropout (p = config.dropout) acts in train mode only and draws from the Generator passed to forward; eval()
// turns it off (parity, inference).
// Errors (t2m::Error "vbb: ..."): bad config (sizes < 1, depth < 0, width not divisible by groups, levels outside 0..6,
// dropout outside [0, 1)); z not 3-D, its last dim != in_dim, Tz not a positive multiple of 2^L; m not
// (B, latent, Tm); eps shape != mu shape.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "autograd/variable.h"
#include "nn/conv1d.h"
#include "nn/module.h"
#include "nn/res_conv_block.h"
#include "nn/upsample.h"
#include "tensor/rng.h"

namespace t2m::text2bfm {

struct VbbConfig {
  int64_t in_dim = 64;   // d, the policy-latent width (the anchor's bench config uses 256)
  int64_t width = 256;   // C
  int64_t latent = 48;   // d_m, channels of the motion program
  int64_t levels = 3;    // stride-2 levels: compression 2^levels (0/2/3/4 -> 1/4/8/16)
  int64_t depth = 3;     // residual blocks per level (0 allowed: no residual blocks)
  int64_t growth = 3;    // dilation growth: 1, 3, 9
  int64_t groups = 32;   // GroupNorm groups
  double dropout = 0.1;  // residual dropout

  int64_t compression() const { return int64_t{1} << levels; }
  void validate() const;  // throws Error "vbb: ..." naming the bad field
  // The paper's VBB at compression factor 1 (no compression), 4, 8 or 16 (anything else throws) over d = in_dim
  // policy latents.
  static VbbConfig with_compression(int64_t factor, int64_t in_dim = 64);
};

// torch's resnet1d: `depth` ResConvBlocks named "0".., dilations growth^i (reversed for the decoder).
class ResStack : public nn::Module {
 public:
  ResStack(const VbbConfig& cfg, bool reverse, Generator& gen);
  ag::Variable forward(const ag::Variable& x, Generator& gen) const;  // (B, C, T) -> (B, C, T)

 private:
  std::vector<std::shared_ptr<nn::ResConvBlock>> blocks_;
};

// q_φ of Eq 3 up to the chunk: x (B, in_dim, Tz) -> (B, 2*latent, Tz / 2^L).
class VbbEncoder : public nn::Module {
 public:
  VbbEncoder(const VbbConfig& cfg, Generator& gen);
  ag::Variable forward(const ag::Variable& x, Generator& gen) const;

 private:
  std::shared_ptr<nn::Conv1d> in_, out_;
  std::vector<std::shared_ptr<nn::Conv1d>> down_;
  std::vector<std::shared_ptr<ResStack>> res_;
};

// D_θ of Eq 4: m (B, latent, Tm) -> (B, in_dim, Tm * 2^L).
class VbbDecoder : public nn::Module {
 public:
  VbbDecoder(const VbbConfig& cfg, Generator& gen);
  ag::Variable forward(const ag::Variable& m, Generator& gen) const;

 private:
  std::shared_ptr<nn::Conv1d> in_, post_, out_;
  std::vector<std::shared_ptr<ResStack>> res_;
  std::vector<std::shared_ptr<nn::Upsample1d>> up_;
  std::vector<std::shared_ptr<nn::Conv1d>> up_conv_;
};

struct VbbPosterior {
  ag::Variable mu, logvar;  // (B, latent, Tm) each: q_φ(m | z) = N(mu, diag(exp(logvar)))
};

struct VbbOutput {
  ag::Variable z_hat;       // (B, Tz, in_dim)   Eq 4
  ag::Variable mu, logvar;  // (B, latent, Tm)   Eq 3
  ag::Variable m;           // (B, latent, Tm)   the sampled program mu + eps * exp(logvar / 2)
};

class Vbb : public nn::Module {
 public:
  Vbb(const VbbConfig& cfg, Generator& gen);
  const VbbConfig& config() const { return cfg_; }

  // Text2BFM Eq 3: posterior q_φ(m | z). z (B, Tz, in_dim).
  VbbPosterior encode(const ag::Variable& z, Generator& gen) const;
  // Reparameterisation: m = mu + eps * exp(logvar / 2); eps has mu's shape (standard normal noise).
  static ag::Variable reparameterize(const ag::Variable& mu, const ag::Variable& logvar, const Tensor& eps);
  // Text2BFM Eq 4: ẑ = D_θ(m). m (B, latent, Tm) -> (B, Tm * 2^L, in_dim).
  ag::Variable decode(const ag::Variable& m, Generator& gen) const;
  // encode, m = mu + eps * sigma with eps ~ N(0, I) drawn from gen (after the encoder's dropout draws), decode.
  VbbOutput forward(const ag::Variable& z, Generator& gen) const;
  // The same with caller-given eps (B, latent, Tm) (parity fixtures; eps = 0 decodes the posterior mean).
  VbbOutput forward(const ag::Variable& z, const Tensor& eps, Generator& gen) const;

 private:
  VbbConfig cfg_;
  std::shared_ptr<VbbEncoder> enc_;
  std::shared_ptr<VbbDecoder> dec_;
};

// Our parameter name -> the anchor MotionVAE's (inserts ".conv" after a causal conv's index / "c1").
std::string vbb_torch_name(const std::string& ours);

}  // namespace t2m::text2bfm
