// mlp.cpp — MLP: fc1 -> activation -> fc2.
#include "nn/mlp.h"

#include <string>

namespace t2m::nn {

MLP::MLP(int64_t dim, int64_t mult, Activation act, Generator& gen, int64_t out_dim, bool bias) : act_(act) {
  if (dim < 1 || mult < 1 || out_dim < 0)
    throw Error("MLP: dim and mult must be >= 1 and out_dim >= 0, got dim " + std::to_string(dim) + ", mult " +
                std::to_string(mult) + ", out_dim " + std::to_string(out_dim));
  fc1_ = register_module("fc1", std::make_shared<Linear>(dim, mult * dim, bias, gen));
  fc2_ = register_module("fc2", std::make_shared<Linear>(mult * dim, out_dim == 0 ? dim : out_dim, bias, gen));
}

ag::Variable MLP::forward(const ag::Variable& x) const {
  if (act_ == Activation::relu) return fc2_->forward(fc1_->forward_relu(x));  // fused, the same bits
  return fc2_->forward(apply_activation(act_, fc1_->forward(x)));
}

}  // namespace t2m::nn
