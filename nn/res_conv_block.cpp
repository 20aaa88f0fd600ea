// res_conv_block.cpp — GroupNorm -> ReLU -> causal dilated conv k3 -> GroupNorm -> ReLU -> conv k1 -> dropout,
// plus the skip connection (each GroupNorm -> ReLU is one fused op, and so are the dropout and the skip's add).
#include "nn/res_conv_block.h"

namespace t2m::nn {

ResConvBlock::ResConvBlock(int64_t channels, int64_t dilation, Generator& gen, int64_t groups, double dropout)
    : dilation_(dilation) {
  n1_ = register_module("n1", std::make_shared<GroupNorm>(groups, channels));
  Conv1dOptions causal;
  causal.dilation = dilation;
  causal.mode = Conv1dPad::causal;
  causal.exact_causal = false;  // n1/n2 pool over the whole time axis already: the block is not strictly causal
  c1_ = register_module("c1", std::make_shared<Conv1d>(channels, channels, 3, causal, gen));
  n2_ = register_module("n2", std::make_shared<GroupNorm>(groups, channels));
  c2_ = register_module("c2", std::make_shared<Conv1d>(channels, channels, 1, Conv1dOptions{}, gen));
  drop_ = register_module("drop", std::make_shared<Dropout>(dropout));
}

ag::Variable ResConvBlock::forward(const ag::Variable& x, Generator& gen) const {
  ag::Variable h = c1_->forward(n1_->forward_relu(x));
  h = c2_->forward(n2_->forward_relu(h));
  return drop_->forward_residual(x, h, gen);
}

}  // namespace t2m::nn
