// optim_sgd.h — stochastic gradient descent with momentum, dampening, Nesterov and (coupled, L2) weight decay,
// the update of torch.optim.SGD:
//   g <- g + wd p
//   b <- g                          on the first update (step_count() == 0)
//   b <- mu b + (1 - dampening) g   afterwards
//   d <- g + mu b  (nesterov)  or  b  (momentum > 0)  or  g  (momentum == 0)
//   p <- p - lr d
// "First update" is the optimizer's (step_count() == 0), not per parameter as in torch: a parameter without a grad
// on the first step later starts from b = 0, which differs from torch only when dampening != 0.
// Loops over each parameter in element order (float32 or float64; arithmetic in the parameter's type).
// State slot "momentum_buffer"; save/check/load as in nn/optim.h.
// Errors (t2m::Error "SGD: ..."): momentum or dampening outside [0, 1], weight_decay < 0, nesterov with
// momentum == 0 or dampening != 0, plus those of nn/optim.h.
#pragma once
#include "nn/optim.h"

namespace t2m::nn {

struct SGDOptions {
  double lr = 1e-2;
  double momentum = 0.0;
  double dampening = 0.0;
  double weight_decay = 0.0;
  bool nesterov = false;
};

class SGD : public Optimizer {
 public:
  SGD(NamedParams params, SGDOptions opt = {});
  void step() override;
  const SGDOptions& options() const { return opt_; }

 private:
  SGDOptions opt_;
};

}  // namespace t2m::nn
