// res_conv_block.h — the VBB residual block (ARCHITECTURE.md section 7; anchor REFERENCE.md "vae"):
//   h = c1(relu(n1(x)))        n1 GroupNorm(groups, C), c1 causal dilated Conv1d k3 (replicate-left padding; not
//                              exact_causal: GroupNorm's statistics see every frame anyway, so c1 may use F(4, 3))
//   h = c2(relu(n2(h)))        n2 GroupNorm(groups, C), c2 Conv1d k1
//   y = x + dropout(h)         dropout p (0.1 in the paper), from the Generator passed to forward
// x, y (B, C, T). Children "n1", "c1", "n2", "c2", "drop" (parameters initialised from gen in that order, as the
// anchor's torch ResBlock orders them). Errors: C not divisible by groups, dilation < 1, p outside [0, 1].
#pragma once
#include <cstdint>
#include <memory>

#include "autograd/variable.h"
#include "nn/conv1d.h"
#include "nn/dropout.h"
#include "nn/module.h"
#include "nn/norm.h"
#include "tensor/rng.h"

namespace t2m::nn {

class ResConvBlock : public Module {
 public:
  ResConvBlock(int64_t channels, int64_t dilation, Generator& gen, int64_t groups = 32, double dropout = 0.1);
  ag::Variable forward(const ag::Variable& x, Generator& gen) const;
  ag::Variable operator()(const ag::Variable& x, Generator& gen) const { return forward(x, gen); }
  int64_t dilation() const { return dilation_; }

 private:
  int64_t dilation_;
  std::shared_ptr<GroupNorm> n1_, n2_;
  std::shared_ptr<Conv1d> c1_, c2_;
  std::shared_ptr<Dropout> drop_;
};

}  // namespace t2m::nn
