// generator.h — the Text2BFM flow-matching generator v_η(m(r), r, Y) (Eq 14-16; §4.2; ARCHITECTURE.md §7), built
// exactly as the fm anchor's FlowTransformer in ../shared/anchor/torch_ref.py:
//
//   c   = t_mlp(timestep_embedding(r))                  (B, width)     conditioning vector (adaLN)
//   ctx = text(tokens, tok_mask)                         (B, L, ctx)    TextAdapter over token features (Eq 7)
//   h   = x_in(m)                                        (B, Tm, width)
//   h   = blocks(h, c, ctx)                              depth x nn::DiTBlock (RoPE from position 0)
//   sh, sc = f_ada(SiLU(c)); v = f_out(modulate(f_norm(h), sh, sc))   (B, Tm, latent)
//
// m is the compact motion program (B, Tm, latent), r the flow time per sample (B) in [0, 1], tokens
// (B, L, tok_dim) the frozen text encoder's token features with a key padding mask (B, L) (nonzero = real).
// Classifier-free guidance support (Ho & Salimans 2022): the "null" condition is a learned context vector
// null_ctx (ctx_dim) that replaces the whole text context of a sample (one key; every key the same, so the
// cross-attention output is the null value whatever the sequence length). During training each sample's text
// is dropped with probability cond_dropout (0.2) — sample_condition_drop() — and at sampling the guided field is
// v_u + w (v_c - v_u) (flow_sampler.h).
//
// Parameters, torch_ref.py names: x_in.*, t_mlp.{0,2}.*, text.* (text_adapter.h), blocks.N.* (nn/dit_block.h),
// f_ada.{weight, bias}, f_out.{weight, bias}, and ours only: null_ctx (ctx_dim) ~ N(0, 0.02^2). named_parameters()
// lists a module's own parameters before its children's (as torch does), so the order is null_ctx followed by
// exactly the anchor's order (fm-small: 117 + 1 tensors, 7,150,384 + 256 values; fm-paper 66,412,848 + 1024).
// Init: PyTorch defaults from the Generator passed to the constructor (so a seed fixes every weight).
// Errors (t2m::Error "FlowGenerator: ..."): bad config; m not (B, Tm, latent), t not (B), ctx/tok shapes, drop
// not (B), m_mask not (B, Tm) — each message names the shapes.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "autograd/variable.h"
#include "models/text2bfm/text_adapter.h"
#include "models/text2bfm/timestep_embedding.h"
#include "nn/adaln.h"
#include "nn/dit_block.h"
#include "nn/linear.h"
#include "nn/module.h"
#include "nn/norm.h"
#include "tensor/rng.h"

namespace t2m::text2bfm {

struct FlowGeneratorConfig {
  int64_t latent = 48;     // width of a program frame m_i (the VBB latent)
  int64_t width = 256;
  int64_t depth = 4;
  int64_t heads = 4;
  int64_t ctx_dim = 256;
  int64_t mlp_ratio = 4;
  int64_t freq_dim = 256;  // sinusoidal time features
  TextAdapterConfig adapter{.tok_dim = 768, .width = 256, .depth = 1, .heads = 4, .ctx_dim = 256, .max_len = 77};
  double cond_dropout = 0.2;  // training: P(text replaced by the null condition)
  double guidance = 1.5;      // sampling: classifier-free guidance weight w

  static FlowGeneratorConfig small();  // fm-small: 256/4/4, ctx 256, adapter 256/1/4 (7.15M + null_ctx)
  static FlowGeneratorConfig paper();  // fm-paper: 512/8/8, ctx 1024, adapter 768/2/8 (66.4M + null_ctx)
  static FlowGeneratorConfig by_name(const std::string& name);  // "fm-small" | "fm-paper"; Error otherwise
};

// The text side of a call: ctx (B, S, ctx_dim) and its key mask (B, S) or undefined.
struct FlowContext {
  ag::Variable ctx;
  Tensor mask;
};

class FlowGenerator : public nn::Module {
 public:
  FlowGenerator(const FlowGeneratorConfig& cfg, Generator& gen);

  // tokens (B, L, tok_dim), tok_mask (B, L) or undefined -> the text context (mask kept).
  FlowContext encode_text(const ag::Variable& tokens, const Tensor& tok_mask = Tensor()) const;
  // The null condition for B samples: ctx (B, 1, ctx_dim) = null_ctx, no mask.
  FlowContext null_context(int64_t B) const;
  // Condition dropout: rows b with drop[b] != 0 get the null context (every key = null_ctx, mask row all
  // visible); the others are unchanged. drop (B) of any dtype, or undefined (nothing dropped).
  FlowContext drop_condition(const FlowContext& c, const Tensor& drop) const;
  // (B) 0/1 draws, 1 with probability cond_dropout, from gen (Philox: deterministic in its state).
  Tensor sample_condition_drop(int64_t B, Generator& gen) const;

  // v_η(m, r, Y): m (B, Tm, latent), t (B), context -> (B, Tm, latent). m_mask (B, Tm) or undefined marks real
  // program frames (padded frames are never attended to; their own outputs are meaningless).
  ag::Variable velocity(const ag::Variable& m, const Tensor& t, const FlowContext& c,
                        const Tensor& m_mask = Tensor()) const;
  // encode_text + drop_condition + velocity: the training forward.
  ag::Variable forward(const ag::Variable& m, const Tensor& t, const ag::Variable& tokens,
                       const Tensor& tok_mask = Tensor(), const Tensor& drop = Tensor(),
                       const Tensor& m_mask = Tensor()) const;

  const FlowGeneratorConfig& config() const { return cfg_; }
  const ag::Variable& null_ctx() const { return null_ctx_; }

 private:
  FlowGeneratorConfig cfg_;
  std::shared_ptr<nn::Linear> x_in_, f_out_;
  std::shared_ptr<TimestepMLP> t_mlp_;
  std::shared_ptr<TextAdapter> text_;
  std::vector<std::shared_ptr<nn::DiTBlock>> blocks_;
  std::shared_ptr<nn::LayerNorm> f_norm_;
  std::shared_ptr<nn::AdaLN> f_ada_;
  ag::Variable null_ctx_;
};

}  // namespace t2m::text2bfm
