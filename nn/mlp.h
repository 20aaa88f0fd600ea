// mlp.h — the two-layer perceptron of transformer blocks: Linear(dim -> mult*dim) -> activation ->
// Linear(mult*dim -> out_dim) (the anchor's MLP: ratio 4, tanh-GELU).
// Children "fc1", "fc2" (nn::Linear, with bias unless bias = false), initialised in that order from gen.
// forward: x (..., dim) -> (..., out_dim). Errors: dim, mult < 1; out_dim < 1 (0 means out_dim = dim).
#pragma once
#include <cstdint>
#include <memory>

#include "autograd/variable.h"
#include "nn/activation.h"
#include "nn/linear.h"
#include "nn/module.h"
#include "tensor/rng.h"

namespace t2m::nn {

class MLP : public Module {
 public:
  MLP(int64_t dim, int64_t mult, Activation act, Generator& gen, int64_t out_dim = 0, bool bias = true);
  ag::Variable forward(const ag::Variable& x) const;
  ag::Variable operator()(const ag::Variable& x) const { return forward(x); }
  const Linear& fc1() const { return *fc1_; }
  const Linear& fc2() const { return *fc2_; }
  Activation activation() const { return act_; }

 private:
  Activation act_;
  std::shared_ptr<Linear> fc1_, fc2_;
};

}  // namespace t2m::nn
