// vbb_semantic_head.h — the trainable parts of the VBB's frame-token alignment (Text2BFM Eq 7 and Eq 11): the
// projections P_m (motion-program frames) and P_y (frozen text-encoder token features) into one shared space, and
// the learnable logit scale α (γ = exp(α), nn::logit_scale_gamma clamps it to [0, ln 100]).
//
// VbbSemanticHead(latent, text_dim, dim, gen): children "pm" = Linear(latent, dim), "py" = Linear(text_dim, dim)
//   (PyTorch default init from gen, pm first), parameter "alpha" (1) = nn::kInitLogitScale = ln(1/0.07).
//   project_program(m (B, latent, Tm)) -> (B, Tm, dim)   P_m applied per program frame (channel-first input, as
//                                                        Vbb returns it)
//   project_tokens(y (B, K, text_dim)) -> (B, K, dim)     P_y applied per token
//   The L2 normalisation of Eq 7 happens inside nn::frame_token_similarity.
// Errors (t2m::Error "vbb_semantic_head: ..."): sizes < 1; m or y of the wrong rank or channel count.
#pragma once
#include <cstdint>
#include <memory>

#include "autograd/variable.h"
#include "nn/linear.h"
#include "nn/module.h"
#include "tensor/rng.h"

namespace t2m::text2bfm {

class VbbSemanticHead : public nn::Module {
 public:
  VbbSemanticHead(int64_t latent, int64_t text_dim, int64_t dim, Generator& gen);
  ag::Variable project_program(const ag::Variable& m) const;  // Eq 7 P_m: (B, latent, Tm) -> (B, Tm, dim)
  ag::Variable project_tokens(const ag::Variable& y) const;   // Eq 7 P_y: (B, K, text_dim) -> (B, K, dim)
  const ag::Variable& alpha() const { return alpha_; }        // Eq 11 log logit scale, shape (1)

 private:
  int64_t latent_, text_dim_;
  std::shared_ptr<nn::Linear> pm_, py_;
  ag::Variable alpha_;
};

}  // namespace t2m::text2bfm
