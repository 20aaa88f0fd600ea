// generator.cpp — FlowGenerator: configs, text context (+ null condition), DiT stack, final adaLN layer.
#include "models/text2bfm/generator.h"

#include "autograd/ops_elementwise.h"
#include "autograd/ops_shape.h"
#include "models/text2bfm/module_list.h"
#include "tensor/ops.h"

namespace t2m::text2bfm {

FlowGeneratorConfig FlowGeneratorConfig::small() { return FlowGeneratorConfig{}; }

FlowGeneratorConfig FlowGeneratorConfig::paper() {
  FlowGeneratorConfig c;
  c.width = 512, c.depth = 8, c.heads = 8, c.ctx_dim = 1024;
  c.adapter = TextAdapterConfig{.tok_dim = 768, .width = 768, .depth = 2, .heads = 8, .ctx_dim = 1024, .max_len = 77};
  return c;
}

FlowGeneratorConfig FlowGeneratorConfig::by_name(const std::string& name) {
  if (name == "fm-small") return small();
  if (name == "fm-paper") return paper();
  throw Error("FlowGenerator: unknown config '" + name + "' (known: fm-small, fm-paper)");
}

// Registration order = torch_ref.py FlowTransformer.__init__: x_in, t_mlp, text, blocks, (f_norm), f_ada, f_out.
FlowGenerator::FlowGenerator(const FlowGeneratorConfig& cfg, Generator& gen) : cfg_(cfg) {
  if (cfg_.latent < 1 || cfg_.width < 1 || cfg_.depth < 0 || cfg_.heads < 1 || cfg_.ctx_dim < 1 ||
      cfg_.adapter.ctx_dim != cfg_.ctx_dim || cfg_.cond_dropout < 0 || cfg_.cond_dropout > 1)
    throw Error("FlowGenerator: bad config (latent " + std::to_string(cfg_.latent) + ", width " +
                std::to_string(cfg_.width) + ", depth " + std::to_string(cfg_.depth) + ", heads " +
                std::to_string(cfg_.heads) + ", ctx_dim " + std::to_string(cfg_.ctx_dim) + ", adapter ctx_dim " +
                std::to_string(cfg_.adapter.ctx_dim) + ", cond_dropout " + std::to_string(cfg_.cond_dropout) + ")");
  x_in_ = register_module("x_in", std::make_shared<nn::Linear>(cfg_.latent, cfg_.width, true, gen));
  t_mlp_ = register_module("t_mlp", std::make_shared<TimestepMLP>(cfg_.freq_dim, cfg_.width, gen));
  text_ = register_module("text", std::make_shared<TextAdapter>(cfg_.adapter, gen));
  for (int64_t i = 0; i < cfg_.depth; ++i)
    blocks_.push_back(std::make_shared<nn::DiTBlock>(
        nn::DiTBlockConfig{
            .dim = cfg_.width, .heads = cfg_.heads, .ctx_dim = cfg_.ctx_dim, .mlp_ratio = cfg_.mlp_ratio},
        gen));
  register_module("blocks", std::make_shared<ModuleList<nn::DiTBlock>>(blocks_));
  f_norm_ = register_module("f_norm", std::make_shared<nn::LayerNorm>(cfg_.width, /*affine=*/false, 1e-6));
  f_ada_ = register_module("f_ada", std::make_shared<nn::AdaLN>(cfg_.width, cfg_.width, 2, gen));
  f_out_ = register_module("f_out", std::make_shared<nn::Linear>(cfg_.width, cfg_.latent, true, gen));
  null_ctx_ = register_parameter("null_ctx", rand_normal({cfg_.ctx_dim}, gen, 0.0, 0.02));
}

// tokens (B,L,tok_dim) -> ctx (B,L,ctx_dim)
FlowContext FlowGenerator::encode_text(const ag::Variable& tokens, const Tensor& tok_mask) const {
  return FlowContext{text_->forward(tokens, tok_mask), tok_mask};
}

// -> ctx (B,1,ctx_dim), every row null_ctx
FlowContext FlowGenerator::null_context(int64_t B) const {
  if (B < 0) throw Error("FlowGenerator: null_context needs B >= 0, got " + std::to_string(B));
  return FlowContext{ag::expand(ag::view(null_ctx_, {1, 1, cfg_.ctx_dim}), {B, 1, cfg_.ctx_dim}), Tensor()};
}

// ctx (B,S,C), drop (B) -> ctx with dropped rows = null_ctx, their mask rows all visible
FlowContext FlowGenerator::drop_condition(const FlowContext& c, const Tensor& drop) const {
  if (!drop.defined()) return c;
  const int64_t B = c.ctx.size(0), S = c.ctx.size(1);
  if (drop.dim() != 1 || drop.size(0) != B)
    throw Error("FlowGenerator: drop must be (B) = [" + std::to_string(B) + "], got " + shape_str(drop.shape()) +
                " (ctx " + shape_str(c.ctx.shape()) + ")");
  const Tensor d = drop.to(DType::f64).contiguous();
  const Tensor cond = d.view({B, 1, 1}).to(c.ctx.dtype());
  FlowContext r;
  r.ctx = ag::where(cond, ag::view(null_ctx_, {1, 1, cfg_.ctx_dim}), c.ctx);
  if (c.mask.defined()) {
    if (c.mask.dim() != 2 || c.mask.size(0) != B || c.mask.size(1) != S)
      throw Error("FlowGenerator: text mask must be (B, S) = [" + std::to_string(B) + ", " + std::to_string(S) +
                  "], got " + shape_str(c.mask.shape()));
    r.mask = c.mask.to(DType::f64).clone();
    double* m = r.mask.data<double>();
    const double* dp = d.data<double>();
    for (int64_t b = 0; b < B; ++b)
      if (dp[b] != 0.0)
        for (int64_t s = 0; s < S; ++s) m[b * S + s] = 1.0;
  }
  return r;
}

Tensor FlowGenerator::sample_condition_drop(int64_t B, Generator& gen) const {
  return lt(rand_uniform({B}, gen), cfg_.cond_dropout);
}

// m (B,Tm,latent), t (B), ctx (B,S,ctx_dim) -> v (B,Tm,latent)
ag::Variable FlowGenerator::velocity(const ag::Variable& m, const Tensor& t, const FlowContext& c,
                                     const Tensor& m_mask) const {
  if (m.dim() != 3 || m.size(2) != cfg_.latent)
    throw Error("FlowGenerator: m must be (B, Tm, " + std::to_string(cfg_.latent) + "), got " + shape_str(m.shape()));
  const int64_t B = m.size(0);
  if (t.dim() != 1 || t.size(0) != B)
    throw Error("FlowGenerator: t must be (B) = [" + std::to_string(B) + "], got " + shape_str(t.shape()));
  if (!c.ctx.defined() || c.ctx.dim() != 3 || c.ctx.size(0) != B || c.ctx.size(2) != cfg_.ctx_dim)
    throw Error("FlowGenerator: ctx must be (B, S, " + std::to_string(cfg_.ctx_dim) + ") with B = " +
                std::to_string(B) + ", got " + (c.ctx.defined() ? shape_str(c.ctx.shape()) : "undefined"));
  if (m_mask.defined() && (m_mask.dim() != 2 || m_mask.size(0) != B || m_mask.size(1) != m.size(1)))
    throw Error("FlowGenerator: m_mask must be (B, Tm) = [" + std::to_string(B) + ", " + std::to_string(m.size(1)) +
                "], got " + shape_str(m_mask.shape()));
  const ag::Variable cvec = t_mlp_->forward(t.to(m.dtype()));  // (B, width)
  ag::Variable h = x_in_->forward(m);                            // (B, Tm, width)
  for (const auto& b : blocks_) h = b->forward(h, cvec, c.ctx, m_mask, c.mask, 0);
  const std::vector<ag::Variable> f = f_ada_->forward(cvec);     // shift, scale
  return f_out_->forward(nn::modulate(f_norm_->forward(h), f[0], f[1]));
}

ag::Variable FlowGenerator::forward(const ag::Variable& m, const Tensor& t, const ag::Variable& tokens,
                                    const Tensor& tok_mask, const Tensor& drop, const Tensor& m_mask) const {
  if (tokens.dim() != 3 || m.dim() != 3 || tokens.size(0) != m.size(0))
    throw Error("FlowGenerator: tokens (B, L, tok_dim) and m (B, Tm, latent) must share B, got tokens " +
                shape_str(tokens.shape()) + ", m " + shape_str(m.shape()));
  return velocity(m, t, drop_condition(encode_text(tokens, tok_mask), drop), m_mask);
}

}  // namespace t2m::text2bfm
