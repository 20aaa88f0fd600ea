// text_adapter.h — the generator's text adapter (Text2BFM §4.2: cross-attention "to a text adapter over token
// features"; the fm anchor's TextAdapter in ../shared/anchor/torch_ref.py): a small pre-LN transformer over the
// frozen text encoder's per-token features y_{j,k} (Eq 7) that maps them to the context the DiT blocks attend to.
//
//   x = inp(tokens) + pos[:L]          inp: Linear(tok_dim, width), or the identity when tok_dim == width
//   x = blocks(x, key_mask)            depth x nn::TransformerBlock (LayerNorm eps 1e-5, heads, MLP x4 tanh-GELU)
//   ctx = out(norm(x))                 norm: LayerNorm(width) eps 1e-5; out: Linear(width, ctx_dim)
//
// forward: tokens (B, L, tok_dim), key_mask (B, L) or undefined (nonzero = real token) -> ctx (B, L, ctx_dim).
// Padded tokens never influence real ones (their keys are masked); their own ctx rows are computed but
// meaningless, and must be masked again by whoever attends to ctx (the DiT cross-attention does).
// Parameters (torch_ref.py names and order): [inp.weight, inp.bias], pos (max_len, width), blocks.N.*,
// norm.{weight, bias}, out.{weight, bias}. Init: PyTorch defaults; pos ~ N(0, 0.02^2).
// Errors (t2m::Error "TextAdapter: ..."): bad config at construction; tokens not (B, L, tok_dim) or L > max_len
// at forward (naming the shapes); mask errors from the attention.
#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include "autograd/variable.h"
#include "nn/linear.h"
#include "nn/module.h"
#include "nn/norm.h"
#include "nn/transformer_block.h"
#include "tensor/rng.h"

namespace t2m::text2bfm {

struct TextAdapterConfig {
  int64_t tok_dim = 768;  // width of the text encoder's token features
  int64_t width = 768;
  int64_t depth = 2;
  int64_t heads = 8;
  int64_t ctx_dim = 1024;
  int64_t max_len = 77;   // rows of the learned position table
};

class TextAdapter : public nn::Module {
 public:
  TextAdapter(const TextAdapterConfig& cfg, Generator& gen);
  ag::Variable forward(const ag::Variable& tokens, const Tensor& key_mask = Tensor()) const;
  const TextAdapterConfig& config() const { return cfg_; }

 private:
  TextAdapterConfig cfg_;
  std::shared_ptr<nn::Linear> inp_, out_;  // inp_ null when tok_dim == width
  ag::Variable pos_;
  std::vector<std::shared_ptr<nn::TransformerBlock>> blocks_;
  std::shared_ptr<nn::LayerNorm> norm_;
};

}  // namespace t2m::text2bfm
