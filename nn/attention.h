// attention.h — multi-head attention module for self- and cross-attention, as SelfAttention/CrossAttention of
// ../shared/anchor/torch_ref.py (the fm anchor) build it: input projection(s), the fused core of
// autograd/ops_mha.h (head split, optional QK RMS-norm, optional RoPE, softmax(q k^T / sqrt(d)) v with key
// padding mask and causal option, head merge), output projection.
//
// Self-attention (cross = false): x (B, T, D) -> (B, T, D).
//   Parameters, in this order: qkv.weight (3D, D), qkv.bias (3D) [qkv_bias], qn.weight (d), kn.weight (d)
//   [qk_norm], proj.weight (D, D), proj.bias (D). The qkv columns are [q | k | v], each H heads of d = D / H.
// Cross-attention (cross = true): x (B, T, D), ctx (B, S, ctx_dim) -> (B, T, D); ctx_dim may differ from D.
//   Parameters: q.weight (D, D), q.bias, kv.weight (2D, ctx_dim), kv.bias (2D) [qkv_bias], qn.weight,
//   kn.weight [qk_norm], proj.weight, proj.bias. kv columns are [k | v].
// key_mask: undefined or (B, Tkeys) (T for self, S for cross), nonzero = visible. RoPE (self only) rotates q and
// k at positions pos0 .. pos0 + T - 1 (rotate-half, base 10000, as torch_ref.py). causal: self only.
// Initialisation: PyTorch's nn.Linear default for every projection, QK-norm weights 1; all from the Generator.
// Errors (t2m::Error): bad config (dim not divisible by heads, heads < 1, rope/causal on cross-attention, odd
// head dim with rope) at construction, naming the config; the wrong forward for the mode, or bad input shapes,
// naming the module and the shapes.
#pragma once
#include <cstdint>
#include <memory>

#include "autograd/variable.h"
#include "nn/linear.h"
#include "nn/module.h"
#include "nn/norm.h"
#include "tensor/rng.h"

namespace t2m::nn {

struct AttentionConfig {
  int64_t dim = 0;       // D, the width of x and of the output
  int64_t heads = 1;     // H; head dim d = D / H
  bool cross = false;    // cross-attention: keys/values from a context
  int64_t ctx_dim = 0;   // context width (cross only); 0 means D
  bool qkv_bias = true;  // bias of the input projections (the output projection always has one)
  bool qk_norm = false;  // RMS-norm of q and k per head, learnable (d) weights
  double norm_eps = 1e-6;
  bool rope = false;     // self only
  bool causal = false;   // self only
};

class MultiheadAttention : public Module {
 public:
  MultiheadAttention(const AttentionConfig& cfg, Generator& gen);

  // Self-attention: x (B, T, D), key_mask (B, T) or undefined; RoPE positions start at pos0.
  ag::Variable forward(const ag::Variable& x, const Tensor& key_mask = Tensor(), int64_t pos0 = 0) const;
  // Cross-attention: x (B, T, D), ctx (B, S, ctx_dim), ctx_mask (B, S) or undefined.
  ag::Variable forward_cross(const ag::Variable& x, const ag::Variable& ctx, const Tensor& ctx_mask = Tensor()) const;

  const AttentionConfig& config() const { return cfg_; }
  int64_t head_dim() const { return cfg_.dim / cfg_.heads; }

 private:
  ag::Variable norm_q() const { return qn_ ? qn_->weight() : ag::Variable(); }
  ag::Variable norm_k() const { return kn_ ? kn_->weight() : ag::Variable(); }
  AttentionConfig cfg_;
  std::shared_ptr<Linear> qkv_, q_, kv_, proj_;
  std::shared_ptr<RMSNorm> qn_, kn_;  // parameter holders ("qn.weight"); the norm runs in the fused core
};

}  // namespace t2m::nn
