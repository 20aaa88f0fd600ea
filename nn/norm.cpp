// norm.cpp — LayerNorm / RMSNorm / GroupNorm modules: parameter registration and a call into the fused op.
#include "nn/norm.h"

#include <string>

#include "autograd/ops_norm.h"

namespace t2m::nn {

namespace {
void check_channels(const char* mod, int64_t C) {
  if (C < 1) throw Error(std::string(mod) + ": channels must be >= 1, got " + std::to_string(C));
}
}  // namespace

LayerNorm::LayerNorm(int64_t C, bool affine, double eps, bool bias) : C_(C), eps_(eps) {
  check_channels("LayerNorm", C);
  if (affine) {
    weight_ = register_parameter("weight", Tensor::ones({C}));
    if (bias) bias_ = register_parameter("bias", Tensor::zeros({C}));
  }
}

ag::Variable LayerNorm::forward(const ag::Variable& x) const { return ag::layer_norm(x, weight_, bias_, eps_); }

RMSNorm::RMSNorm(int64_t C, bool affine, double eps) : C_(C), eps_(eps) {
  check_channels("RMSNorm", C);
  if (affine) weight_ = register_parameter("weight", Tensor::ones({C}));
}

ag::Variable RMSNorm::forward(const ag::Variable& x) const { return ag::rms_norm(x, weight_, eps_); }

GroupNorm::GroupNorm(int64_t groups, int64_t C, bool affine, double eps) : groups_(groups), C_(C), eps_(eps) {
  check_channels("GroupNorm", C);
  if (groups < 1 || C % groups != 0)
    throw Error("GroupNorm: channels = " + std::to_string(C) + " must be divisible by groups = " +
                std::to_string(groups));
  if (affine) {
    weight_ = register_parameter("weight", Tensor::ones({C}));
    bias_ = register_parameter("bias", Tensor::zeros({C}));
  }
}

ag::Variable GroupNorm::forward(const ag::Variable& x) const {
  return ag::group_norm(x, groups_, weight_, bias_, eps_);
}

ag::Variable GroupNorm::forward_relu(const ag::Variable& x) const {
  return ag::group_norm_relu(x, groups_, weight_, bias_, eps_);
}

}  // namespace t2m::nn
