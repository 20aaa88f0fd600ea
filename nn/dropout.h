// dropout.h — the Dropout module: inverted dropout with probability p while training, identity in eval mode.
// Randomness comes from the Generator passed to forward (see ag::dropout for the exact Philox mask and how far
// the generator advances; in eval mode or with p = 0 it is untouched). No parameters.
// Errors: p outside [0, 1] at construction.
#pragma once
#include "autograd/variable.h"
#include "nn/module.h"
#include "tensor/rng.h"

namespace t2m::nn {

class Dropout : public Module {
 public:
  explicit Dropout(double p);
  ag::Variable forward(const ag::Variable& x, Generator& gen) const;
  ag::Variable operator()(const ag::Variable& x, Generator& gen) const { return forward(x, gen); }
  // x + forward(h, gen) as one op (ag::residual_dropout): the same values, mask and generator advance.
  ag::Variable forward_residual(const ag::Variable& x, const ag::Variable& h, Generator& gen) const;
  double p() const { return p_; }

 private:
  double p_;
};

}  // namespace t2m::nn
