// dit_block.cpp — DiTBlock: adaLN chunks, gated self-attention, ungated cross-attention, gated MLP.
#include "nn/dit_block.h"

#include <string>

#include "autograd/ops_elementwise.h"

namespace t2m::nn {

// Registration order = torch_ref.py DiTBlock.__init__: n1, attn, n2, xattn, n3, mlp, ada.
DiTBlock::DiTBlock(const DiTBlockConfig& cfg, Generator& gen) : cfg_(cfg) {
  if (cfg_.ctx_dim == 0) cfg_.ctx_dim = cfg_.dim;
  const int64_t D = cfg_.dim;
  n1_ = register_module("n1", std::make_shared<LayerNorm>(D, /*affine=*/false, 1e-6));
  attn_ = register_module("attn", std::make_shared<MultiheadAttention>(
                                      AttentionConfig{.dim = D, .heads = cfg_.heads, .qkv_bias = true,
                                                      .qk_norm = true, .norm_eps = 1e-6, .rope = true},
                                      gen));
  n2_ = register_module("n2", std::make_shared<LayerNorm>(D, /*affine=*/true, 1e-6));
  xattn_ = register_module("xattn", std::make_shared<MultiheadAttention>(
                                        AttentionConfig{.dim = D, .heads = cfg_.heads, .cross = true,
                                                        .ctx_dim = cfg_.ctx_dim, .qkv_bias = true, .qk_norm = true,
                                                        .norm_eps = 1e-6},
                                        gen));
  n3_ = register_module("n3", std::make_shared<LayerNorm>(D, /*affine=*/false, 1e-6));
  mlp_ = register_module("mlp", std::make_shared<MLP>(D, cfg_.mlp_ratio, Activation::gelu_tanh, gen));
  ada_ = register_module("ada", std::make_shared<AdaLN>(D, D, 6, gen));
}

// x (B,T,D), c (B,D), ctx (B,S,C) -> (B,T,D)
ag::Variable DiTBlock::forward(const ag::Variable& x, const ag::Variable& c, const ag::Variable& ctx,
                               const Tensor& x_mask, const Tensor& ctx_mask, int64_t pos0) const {
  if (c.dim() != 2 || x.dim() != 3 || c.size(0) != x.size(0) || c.size(1) != cfg_.dim)
    throw Error("DiTBlock: c must be (B, D) = [" + std::to_string(x.dim() == 3 ? x.size(0) : -1) + ", " +
                std::to_string(cfg_.dim) + "] (x " + shape_str(x.shape()) + ", c " + shape_str(c.shape()) + ")");
  const std::vector<ag::Variable> m = ada_->forward(c);  // sh1, sc1, g1, sh2, sc2, g2, each (B, D)
  ag::Variable h = gated_residual(x, m[2], attn_->forward(modulate(n1_->forward(x), m[0], m[1]), x_mask, pos0));
  h = h + xattn_->forward_cross(n2_->forward(h), ctx, ctx_mask);
  return gated_residual(h, m[5], mlp_->forward(modulate(n3_->forward(h), m[3], m[4])));
}

}  // namespace t2m::nn
