// transformer_block.cpp — pre-LN encoder block: x + attn(n1(x)), then + mlp(n2(x)).
#include "nn/transformer_block.h"

#include "autograd/ops_elementwise.h"

namespace t2m::nn {

// Registration order = torch_ref.py EncBlock.__init__: n1, attn, n2, mlp.
TransformerBlock::TransformerBlock(const TransformerBlockConfig& cfg, Generator& gen) : cfg_(cfg) {
  const int64_t D = cfg_.dim;
  n1_ = register_module("n1", std::make_shared<LayerNorm>(D, /*affine=*/true, cfg_.norm_eps));
  attn_ = register_module("attn", std::make_shared<MultiheadAttention>(
                                      AttentionConfig{.dim = D, .heads = cfg_.heads, .qkv_bias = cfg_.qkv_bias,
                                                      .qk_norm = cfg_.qk_norm, .causal = cfg_.causal},
                                      gen));
  n2_ = register_module("n2", std::make_shared<LayerNorm>(D, /*affine=*/true, cfg_.norm_eps));
  mlp_ = register_module("mlp", std::make_shared<MLP>(D, cfg_.mlp_ratio, Activation::gelu_tanh, gen));
}

// x (B,T,D), key_mask (B,T) -> (B,T,D)
ag::Variable TransformerBlock::forward(const ag::Variable& x, const Tensor& key_mask) const {
  ag::Variable h = x + attn_->forward(n1_->forward(x), key_mask);
  return h + mlp_->forward(n2_->forward(h));
}

}  // namespace t2m::nn
