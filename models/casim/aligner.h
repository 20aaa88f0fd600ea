// aligner.h — the text-motion aligner of CASIM (§3.1, Fig. 2 middle): motion tokens attend to the text tokens so
// that every motion frame picks the words it needs. Shared by the diffusion (diffusion_*) and autoregressive
// (ar_*) CASIM baselines. Two forms:
//
// MHSA (CASIM Eq 4, encoder denoiser / GPT prefix): the text tokens are concatenated IN FRONT of the motion tokens
//   and one self-attention mixes the joint sequence:
//     join_text_motion(text (B, L, W), text_mask (B, L), motion (B, T, W), motion_mask (B, T))
//       -> seq (B, L + T, W) = [text ; motion], mask (B, L + T) = [text_mask ; motion_mask], text_len = L.
//     motion_part(joined, out (B, L + T, W)) -> out[:, L:] (B, T, W): the motion tokens after the blocks.
//   Masks: undefined = all real. Padded text tokens and padded motion frames are never attended to (key mask), so
//   the outputs at real positions do not depend on what padding holds or on how much padding there is.
// MHCA (CASIM Eq 5, decoder denoiser): CrossAlignerBlock, a pre-LN decoder block
//     x = x + SA(n1(x), motion_mask);  x = x + CA(n2(x), text, text_mask);  x = x + MLP(n3(x))
//   x (B, T, W) motion tokens, text (B, L, W) -> (B, T, W). Parameters: n1.*, self_attn.*, n2.*, cross_attn.*
//   (nn/attention.h cross form, q.*, kv.*, proj.*), n3.*, mlp.* (fc1, fc2; tanh-GELU). PyTorch default init.
// Null condition for classifier-free guidance (Ho & Salimans 2022): with_null_condition(text, text_mask, null,
//   drop) replaces the text of every sample b with drop[b] != 0 by ONE learned token `null` (W) (position 0, mask
//   [1, 0, ..., 0]); other samples are unchanged. drop (B) any dtype or undefined (nothing dropped). The
//   gradient reaches `null` from dropped samples only and `text` from kept ones.
// Errors (t2m::Error "aligner: ..."): rank/size mismatches (B, W, mask shapes), naming the shapes.
#pragma once
#include <cstdint>
#include <memory>

#include "autograd/variable.h"
#include "nn/attention.h"
#include "nn/mlp.h"
#include "nn/module.h"
#include "nn/norm.h"
#include "tensor/rng.h"

namespace t2m::casim {

struct JoinedSequence {
  ag::Variable seq;      // (B, L + T, W)
  Tensor mask;           // (B, L + T) float 0/1
  int64_t text_len = 0;  // L
};

// CASIM Eq 4: [text ; motion] with the joint key mask.
JoinedSequence join_text_motion(const ag::Variable& text, const Tensor& text_mask, const ag::Variable& motion,
                                const Tensor& motion_mask);
ag::Variable motion_part(const JoinedSequence& j, const ag::Variable& out);

struct TextCondition {
  ag::Variable tokens;  // (B, L, W)
  Tensor mask;          // (B, L) float 0/1
};
TextCondition with_null_condition(const ag::Variable& text, const Tensor& text_mask, const ag::Variable& null,
                                  const Tensor& drop);

struct CrossAlignerConfig {
  int64_t dim = 128;
  int64_t heads = 4;
  int64_t mlp_ratio = 4;
};

// CASIM Eq 5: self-attention over motion, cross-attention (MHCA) from motion to text, MLP.
class CrossAlignerBlock : public nn::Module {
 public:
  CrossAlignerBlock(const CrossAlignerConfig& cfg, Generator& gen);
  ag::Variable forward(const ag::Variable& x, const Tensor& motion_mask, const ag::Variable& text,
                       const Tensor& text_mask) const;

 private:
  CrossAlignerConfig cfg_;
  std::shared_ptr<nn::LayerNorm> n1_, n2_, n3_;
  std::shared_ptr<nn::MultiheadAttention> self_, cross_;
  std::shared_ptr<nn::MLP> mlp_;
};

}  // namespace t2m::casim
