// dropout.cpp — Dropout module over ag::dropout.
#include "nn/dropout.h"

#include <string>

#include "autograd/ops_activation.h"

namespace t2m::nn {

Dropout::Dropout(double p) : p_(p) {
  if (!(p >= 0.0 && p <= 1.0)) throw Error("Dropout: p must be in [0, 1], got " + std::to_string(p));
}

ag::Variable Dropout::forward(const ag::Variable& x, Generator& gen) const {
  return ag::dropout(x, p_, gen, is_training());
}

ag::Variable Dropout::forward_residual(const ag::Variable& x, const ag::Variable& h, Generator& gen) const {
  return ag::residual_dropout(x, h, p_, gen, is_training());
}

}  // namespace t2m::nn
