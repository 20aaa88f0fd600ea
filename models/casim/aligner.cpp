// aligner.cpp — joint [text ; motion] sequences (MHSA), the null condition, and the MHCA decoder block.
#include "models/casim/aligner.h"

#include <string>

#include "autograd/ops_elementwise.h"
#include "autograd/ops_join.h"
#include "autograd/ops_shape.h"
#include "tensor/ops.h"

namespace t2m::casim {

namespace {

std::string shape_str(const Shape& s) {
  std::string r = "(";
  for (size_t i = 0; i < s.size(); ++i) r += (i ? ", " : "") + std::to_string(s[i]);
  return r + ")";
}

// mask (B, N) float32 0/1, or ones when undefined.
Tensor mask_or_ones(const Tensor& m, int64_t B, int64_t N, const char* what) {
  if (!m.defined()) return Tensor::ones({B, N});
  if (m.dim() != 2 || m.size(0) != B || m.size(1) != N)
    throw Error(std::string("aligner: ") + what + " mask " + shape_str(m.shape()) + " for (" + std::to_string(B) +
                ", " + std::to_string(N) + ")");
  return m.to(DType::f32).contiguous();
}

}  // namespace

// CASIM Eq 4: the MHSA aligner's joint sequence [text ; motion].
JoinedSequence join_text_motion(const ag::Variable& text, const Tensor& text_mask, const ag::Variable& motion,
                                const Tensor& motion_mask) {
  const Shape& ts = text.data().shape();
  const Shape& ms = motion.data().shape();
  if (ts.size() != 3 || ms.size() != 3 || ts[0] != ms[0] || ts[2] != ms[2])
    throw Error("aligner: text " + shape_str(ts) + " and motion " + shape_str(ms) + " must be (B, L, W), (B, T, W)");
  const int64_t B = ts[0], L = ts[1], T = ms[1];
  JoinedSequence j;
  j.seq = ag::concat({text, motion}, 1);
  j.mask = concat({mask_or_ones(text_mask, B, L, "text"), mask_or_ones(motion_mask, B, T, "motion")}, 1);
  j.text_len = L;
  return j;
}

ag::Variable motion_part(const JoinedSequence& j, const ag::Variable& out) {
  const Shape& s = out.data().shape();
  if (s.size() != 3 || s[1] <= j.text_len) throw Error("aligner: joined output " + shape_str(s) + " too short");
  return ag::slice(out, 1, j.text_len, s[1]);
}

// Ho & Salimans 2022: condition dropout to one learned null token.
TextCondition with_null_condition(const ag::Variable& text, const Tensor& text_mask, const ag::Variable& null,
                                  const Tensor& drop) {
  const Shape& ts = text.data().shape();
  if (ts.size() != 3) throw Error("aligner: text " + shape_str(ts) + " must be (B, L, W)");
  const int64_t B = ts[0], L = ts[1], W = ts[2];
  if (null.data().numel() != W) throw Error("aligner: null token of " + std::to_string(null.data().numel()) +
                                            " values for width " + std::to_string(W));
  TextCondition c;
  c.mask = mask_or_ones(text_mask, B, L, "text");
  if (!drop.defined()) {
    c.tokens = text;
    return c;
  }
  if (drop.numel() != B) throw Error("aligner: drop has " + std::to_string(drop.numel()) + " values for B = " +
                                     std::to_string(B));
  const Tensor d = drop.to(DType::f64).contiguous();
  const DType dt = text.data().dtype();
  Tensor keep = Tensor::zeros({B, 1, 1}, dt), first = Tensor::zeros({B, L, 1}, dt);
  Tensor mask = c.mask.clone();
  for (int64_t b = 0; b < B; ++b) {
    const bool dropped = d.data<double>()[b] != 0;
    if (dt == DType::f64) {
      keep.data<double>()[b] = dropped ? 0 : 1;
      first.data<double>()[b * L] = dropped ? 1 : 0;
    } else {
      keep.data<float>()[b] = dropped ? 0.f : 1.f;
      first.data<float>()[b * L] = dropped ? 1.f : 0.f;
    }
    if (dropped)
      for (int64_t l = 0; l < L; ++l) mask.data<float>()[b * L + l] = l == 0 ? 1.f : 0.f;
  }
  c.tokens = text * ag::Variable(keep) + ag::reshape(null, {1, 1, W}) * ag::Variable(first);
  c.mask = mask;
  return c;
}

CrossAlignerBlock::CrossAlignerBlock(const CrossAlignerConfig& cfg, Generator& gen) : cfg_(cfg) {
  const int64_t D = cfg.dim;
  if (D < 1 || cfg.heads < 1 || cfg.mlp_ratio < 1 || D % cfg.heads != 0)
    throw Error("aligner: CrossAlignerBlock needs dim divisible by heads >= 1 (dim " + std::to_string(D) +
                ", heads " + std::to_string(cfg.heads) + ")");
  n1_ = register_module("n1", std::make_shared<nn::LayerNorm>(D, true, 1e-5));
  self_ = register_module("self_attn", std::make_shared<nn::MultiheadAttention>(
                                           nn::AttentionConfig{.dim = D, .heads = cfg.heads}, gen));
  n2_ = register_module("n2", std::make_shared<nn::LayerNorm>(D, true, 1e-5));
  cross_ = register_module("cross_attn", std::make_shared<nn::MultiheadAttention>(
                                             nn::AttentionConfig{.dim = D, .heads = cfg.heads, .cross = true}, gen));
  n3_ = register_module("n3", std::make_shared<nn::LayerNorm>(D, true, 1e-5));
  mlp_ = register_module("mlp", std::make_shared<nn::MLP>(D, cfg.mlp_ratio, nn::Activation::gelu_tanh, gen));
}

// CASIM Eq 5: motion self-attention, then MHCA to the (timestep-augmented) text tokens, then the MLP.
ag::Variable CrossAlignerBlock::forward(const ag::Variable& x, const Tensor& motion_mask, const ag::Variable& text,
                                        const Tensor& text_mask) const {
  ag::Variable h = x + self_->forward(n1_->forward(x), motion_mask);
  h = h + cross_->forward_cross(n2_->forward(h), text, text_mask);
  return h + mlp_->forward(n3_->forward(h));
}

}  // namespace t2m::casim
