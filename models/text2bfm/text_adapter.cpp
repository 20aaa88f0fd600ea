// text_adapter.cpp — input projection + learned positions, pre-LN encoder blocks, final LayerNorm + projection.
#include "models/text2bfm/text_adapter.h"

#include <string>

#include "autograd/ops_elementwise.h"
#include "autograd/ops_shape.h"
#include "models/text2bfm/module_list.h"
#include "tensor/ops.h"

namespace t2m::text2bfm {

// Registration order = torch_ref.py TextAdapter.__init__: inp, pos, blocks, norm, out.
TextAdapter::TextAdapter(const TextAdapterConfig& cfg, Generator& gen) : cfg_(cfg) {
  if (cfg_.tok_dim < 1 || cfg_.width < 1 || cfg_.depth < 0 || cfg_.heads < 1 || cfg_.ctx_dim < 1 || cfg_.max_len < 1)
    throw Error("TextAdapter: bad config (tok_dim " + std::to_string(cfg_.tok_dim) + ", width " +
                std::to_string(cfg_.width) + ", depth " + std::to_string(cfg_.depth) + ", heads " +
                std::to_string(cfg_.heads) + ", ctx_dim " + std::to_string(cfg_.ctx_dim) + ", max_len " +
                std::to_string(cfg_.max_len) + ")");
  if (cfg_.tok_dim != cfg_.width)
    inp_ = register_module("inp", std::make_shared<nn::Linear>(cfg_.tok_dim, cfg_.width, true, gen));
  pos_ = register_parameter("pos", rand_normal({cfg_.max_len, cfg_.width}, gen, 0.0, 0.02));
  for (int64_t i = 0; i < cfg_.depth; ++i)
    blocks_.push_back(std::make_shared<nn::TransformerBlock>(
        nn::TransformerBlockConfig{.dim = cfg_.width, .heads = cfg_.heads, .mlp_ratio = 4}, gen));
  register_module("blocks", std::make_shared<ModuleList<nn::TransformerBlock>>(blocks_));
  norm_ = register_module("norm", std::make_shared<nn::LayerNorm>(cfg_.width, true, 1e-5));
  out_ = register_module("out", std::make_shared<nn::Linear>(cfg_.width, cfg_.ctx_dim, true, gen));
}

// tokens (B,L,tok_dim), key_mask (B,L) -> ctx (B,L,ctx_dim)
ag::Variable TextAdapter::forward(const ag::Variable& tokens, const Tensor& key_mask) const {
  if (tokens.dim() != 3 || tokens.size(2) != cfg_.tok_dim || tokens.size(1) < 1 || tokens.size(1) > cfg_.max_len)
    throw Error("TextAdapter: tokens must be (B, L, " + std::to_string(cfg_.tok_dim) + ") with 1 <= L <= " +
                std::to_string(cfg_.max_len) + ", got " + shape_str(tokens.shape()));
  const int64_t L = tokens.size(1);
  ag::Variable x = inp_ ? inp_->forward(tokens) : tokens;
  x = x + ag::narrow(pos_, 0, 0, L);  // (B,L,W) + (L,W)
  for (const auto& b : blocks_) x = b->forward(x, key_mask);
  return out_->forward(norm_->forward(x));
}

}  // namespace t2m::text2bfm
