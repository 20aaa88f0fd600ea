// dit_block.h — the DiT-style block of the flow-matching transformer (fm anchor, ../shared/anchor/torch_ref.py
// DiTBlock; Text2BFM §generator: adaLN timestep conditioning, self-attention with qkv bias + QK RMS-norm + RoPE,
// cross-attention to the text context, MLP x4 with tanh-GELU, gated residuals):
//
//   sh1, sc1, g1, sh2, sc2, g2 = ada(SiLU(c)).chunk(6)
//   x = x + g1 * attn(modulate(n1(x), sh1, sc1))      n1: LayerNorm without affine, eps 1e-6
//   x = x + xattn(n2(x), ctx)                         n2: LayerNorm with affine, eps 1e-6 (no gate)
//   x = x + g2 * mlp(modulate(n3(x), sh2, sc2))       n3: LayerNorm without affine, eps 1e-6
//
// forward: x (B, T, D), c (B, D) the conditioning vector, ctx (B, S, ctx_dim) the text context; optional
// x_mask (B, T) (motion padding; keys only) and ctx_mask (B, S); RoPE positions start at pos0. -> (B, T, D).
// Parameter names and registration order are torch_ref.py's, so PyTorch weights load by name:
//   attn.{qkv.weight, qkv.bias, qn.weight, kn.weight, proj.weight, proj.bias}, n2.{weight, bias},
//   xattn.{q.weight, q.bias, kv.weight, kv.bias, qn.weight, kn.weight, proj.weight, proj.bias},
//   mlp.{fc1.weight, fc1.bias, fc2.weight, fc2.bias}, ada.{weight, bias}   (n1, n3 have none).
// Initialisation: PyTorch defaults (Linear U(+-1/sqrt(in)), norm weights 1, biases 0) from the Generator.
// Errors (t2m::Error naming the block and the shapes): c not (B, D); others from the sub-modules.
#pragma once
#include <cstdint>
#include <memory>

#include "autograd/variable.h"
#include "nn/adaln.h"
#include "nn/attention.h"
#include "nn/mlp.h"
#include "nn/module.h"
#include "nn/norm.h"
#include "tensor/rng.h"

namespace t2m::nn {

struct DiTBlockConfig {
  int64_t dim = 0;        // D
  int64_t heads = 1;
  int64_t ctx_dim = 0;    // width of the text context; 0 means D
  int64_t mlp_ratio = 4;  // hidden width mlp_ratio * D
};

class DiTBlock : public Module {
 public:
  DiTBlock(const DiTBlockConfig& cfg, Generator& gen);
  ag::Variable forward(const ag::Variable& x, const ag::Variable& c, const ag::Variable& ctx,
                       const Tensor& x_mask = Tensor(), const Tensor& ctx_mask = Tensor(), int64_t pos0 = 0) const;
  const DiTBlockConfig& config() const { return cfg_; }

 private:
  DiTBlockConfig cfg_;
  std::shared_ptr<LayerNorm> n1_, n2_, n3_;
  std::shared_ptr<MultiheadAttention> attn_, xattn_;
  std::shared_ptr<MLP> mlp_;
  std::shared_ptr<AdaLN> ada_;
};

}  // namespace t2m::nn
