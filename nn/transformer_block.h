// transformer_block.h — a pre-LN transformer encoder block (the text adapter's EncBlock in
// ../shared/anchor/torch_ref.py, also used by the text encoder):
//
//   x = x + attn(n1(x), key_mask)       self-attention with qkv bias, no QK-norm, no RoPE (by default)
//   x = x + mlp(n2(x))                  MLP mlp_ratio x D with tanh-GELU
//
// forward: x (B, T, D), key_mask (B, T) or undefined (nonzero = real token; padded tokens are never attended to,
// their own outputs are computed but meaningless) -> (B, T, D).
// Parameters (torch_ref.py names, in order): n1.{weight, bias}, attn.{qkv.weight, qkv.bias, proj.weight,
// proj.bias} (+ qn/kn.weight with qk_norm), n2.{weight, bias}, mlp.{fc1.weight, fc1.bias, fc2.weight, fc2.bias}.
// LayerNorm eps 1e-5 (PyTorch's default, as EncBlock). Initialisation: PyTorch defaults from the Generator.
// Errors: from the sub-modules (bad dims, mask shape), naming the module and shapes.
#pragma once
#include <cstdint>
#include <memory>

#include "autograd/variable.h"
#include "nn/attention.h"
#include "nn/mlp.h"
#include "nn/module.h"
#include "nn/norm.h"
#include "tensor/rng.h"

namespace t2m::nn {

struct TransformerBlockConfig {
  int64_t dim = 0;
  int64_t heads = 1;
  int64_t mlp_ratio = 4;
  bool qkv_bias = true;
  bool qk_norm = false;
  bool causal = false;
  double norm_eps = 1e-5;
};

class TransformerBlock : public Module {
 public:
  TransformerBlock(const TransformerBlockConfig& cfg, Generator& gen);
  ag::Variable forward(const ag::Variable& x, const Tensor& key_mask = Tensor()) const;
  const TransformerBlockConfig& config() const { return cfg_; }

 private:
  TransformerBlockConfig cfg_;
  std::shared_ptr<LayerNorm> n1_, n2_;
  std::shared_ptr<MultiheadAttention> attn_;
  std::shared_ptr<MLP> mlp_;
};

}  // namespace t2m::nn
