// vbb_semantic_head.cpp — P_m, P_y and α of the VBB's frame-token loss.
#include "models/text2bfm/vbb_semantic_head.h"

#include <string>

#include "autograd/ops_shape.h"
#include "nn/loss_contrastive.h"

namespace t2m::text2bfm {

VbbSemanticHead::VbbSemanticHead(int64_t latent, int64_t text_dim, int64_t dim, Generator& gen)
    : latent_(latent), text_dim_(text_dim) {
  if (latent < 1 || text_dim < 1 || dim < 1)
    throw Error("vbb_semantic_head: latent, text_dim, dim must be >= 1, got " + std::to_string(latent) + ", " +
                std::to_string(text_dim) + ", " + std::to_string(dim));
  pm_ = register_module("pm", std::make_shared<nn::Linear>(latent, dim, true, gen));
  py_ = register_module("py", std::make_shared<nn::Linear>(text_dim, dim, true, gen));
  alpha_ = register_parameter("alpha", Tensor::full({1}, nn::kInitLogitScale));
}

// Text2BFM Eq 7: P_m(m_{i,t}) per program frame.  m (B, latent, Tm) -> (B, Tm, dim)
ag::Variable VbbSemanticHead::project_program(const ag::Variable& m) const {
  if (!m.defined() || m.dim() != 3 || m.size(1) != latent_)
    throw Error("vbb_semantic_head: m must be (B, " + std::to_string(latent_) + ", Tm), got " +
                (m.defined() ? shape_str(m.shape()) : std::string("undefined")));
  return pm_->forward(ag::transpose(m, 1, 2));
}

// Text2BFM Eq 7: P_y(y_{j,k}) per token.  y (B, K, text_dim) -> (B, K, dim)
ag::Variable VbbSemanticHead::project_tokens(const ag::Variable& y) const {
  if (!y.defined() || y.dim() != 3 || y.size(2) != text_dim_)
    throw Error("vbb_semantic_head: token features must be (B, K, " + std::to_string(text_dim_) + "), got " +
                (y.defined() ? shape_str(y.shape()) : std::string("undefined")));
  return py_->forward(y);
}

}  // namespace t2m::text2bfm
