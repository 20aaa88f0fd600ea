// attention.cpp — MultiheadAttention: projections around the fused attention core (autograd/ops_mha.h).
#include "nn/attention.h"

#include <string>

#include "autograd/ops_mha.h"
#include "autograd/ops_mha_ctx.h"

namespace t2m::nn {

namespace {

std::string config_str(const AttentionConfig& c) {
  return "dim " + std::to_string(c.dim) + ", heads " + std::to_string(c.heads) + ", cross " +
         std::to_string(c.cross) + ", ctx_dim " + std::to_string(c.ctx_dim) + ", rope " + std::to_string(c.rope) +
         ", causal " + std::to_string(c.causal);
}

void check_x(const char* where, const ag::Variable& x, int64_t D) {
  if (x.dim() != 3 || x.size(2) != D)
    throw Error(std::string("MultiheadAttention.") + where + ": x must be (B, T, " + std::to_string(D) + "), got " +
                shape_str(x.shape()));
}

}  // namespace

MultiheadAttention::MultiheadAttention(const AttentionConfig& cfg, Generator& gen) : cfg_(cfg) {
  if (cfg_.ctx_dim == 0) cfg_.ctx_dim = cfg_.dim;
  const AttentionConfig& c = cfg_;
  auto fail = [&](const std::string& what) { throw Error("MultiheadAttention: " + what + " (" + config_str(c) + ")"); };
  if (c.heads < 1 || c.dim < 1 || c.ctx_dim < 1) fail("dim, heads and ctx_dim must be >= 1");
  if (c.dim % c.heads != 0) fail("dim must be divisible by heads");
  if (c.cross && (c.rope || c.causal)) fail("rope and causal are for self-attention only");
  if (c.rope && (c.dim / c.heads) % 2 != 0) fail("rope needs an even head dim");
  const int64_t D = c.dim, d = c.dim / c.heads;
  if (!c.cross) {
    qkv_ = register_module("qkv", std::make_shared<Linear>(D, 3 * D, c.qkv_bias, gen));
  } else {
    q_ = register_module("q", std::make_shared<Linear>(D, D, c.qkv_bias, gen));
    kv_ = register_module("kv", std::make_shared<Linear>(c.ctx_dim, 2 * D, c.qkv_bias, gen));
  }
  if (c.qk_norm) {
    qn_ = register_module("qn", std::make_shared<RMSNorm>(d, true, c.norm_eps));
    kn_ = register_module("kn", std::make_shared<RMSNorm>(d, true, c.norm_eps));
  }
  proj_ = register_module("proj", std::make_shared<Linear>(D, D, true, gen));
}

// x (B,T,D) -> qkv (B,T,3D) -> core (B,T,D) -> proj (B,T,D)
ag::Variable MultiheadAttention::forward(const ag::Variable& x, const Tensor& key_mask, int64_t pos0) const {
  if (cfg_.cross) throw Error("MultiheadAttention.forward: this module is cross-attention; call forward_cross");
  check_x("forward", x, cfg_.dim);
  ag::MhaOptions o;
  o.heads = cfg_.heads;
  o.norm_eps = cfg_.norm_eps;
  o.rope = cfg_.rope;
  o.rope_pos0 = pos0;
  o.causal = cfg_.causal;
  return proj_->forward(ag::mha_self(qkv_->forward(x), norm_q(), norm_k(), key_mask, o));
}

// x (B,T,D) -> q (B,T,D); ctx (B,S,C) -> kv (B,S,2D) -> core, or ctx straight into mha_cross_ctx; proj (B,T,D)
ag::Variable MultiheadAttention::forward_cross(const ag::Variable& x, const ag::Variable& ctx,
                                               const Tensor& ctx_mask) const {
  if (!cfg_.cross) throw Error("MultiheadAttention.forward_cross: this module is self-attention; call forward");
  check_x("forward_cross", x, cfg_.dim);
  if (ctx.dim() != 3 || ctx.size(2) != cfg_.ctx_dim || ctx.size(0) != x.size(0))
    throw Error("MultiheadAttention.forward_cross: ctx must be (" + std::to_string(x.size(0)) + ", S, " +
                std::to_string(cfg_.ctx_dim) + "), got " + shape_str(ctx.shape()) + " (x " + shape_str(x.shape()) +
                ")");
  ag::MhaOptions o;
  o.heads = cfg_.heads;
  o.norm_eps = cfg_.norm_eps;
  // The value projection after the weighted sum where that takes fewer multiply-adds (autograd/ops_mha_ctx.h).
  if (ag::mha_cross_ctx_chosen(x.size(1), ctx.size(1), cfg_.ctx_dim, cfg_.heads, head_dim()))
    return proj_->forward(ag::mha_cross_ctx(q_->forward(x), ctx, kv_->weight(), kv_->bias(), norm_q(), norm_k(),
                                            ctx_mask, o));
  return proj_->forward(ag::mha_cross(q_->forward(x), kv_->forward(ctx), norm_q(), norm_k(), ctx_mask, o));
}

}  // namespace t2m::nn
