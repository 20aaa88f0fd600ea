// conv1d.cpp — Conv1d module: option checks, PyTorch default init, the padding rule, a call into ag::conv1d.
#include "nn/conv1d.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace t2m::nn {

Conv1d::Conv1d(int64_t cin, int64_t cout, int64_t k, const Conv1dOptions& opts, Generator& gen)
    : cin_(cin), cout_(cout), k_(k), opts_(opts) {
  if (cin < 1 || cout < 1 || k < 1 || opts.stride < 1 || opts.dilation < 1 || opts.pad < 0)
    throw Error("Conv1d: cin, cout, k, stride, dilation must be >= 1 and pad >= 0, got cin " + std::to_string(cin) +
                ", cout " + std::to_string(cout) + ", k " + std::to_string(k) + ", stride " +
                std::to_string(opts.stride) + ", dilation " + std::to_string(opts.dilation) + ", pad " +
                std::to_string(opts.pad));
  if (opts.mode == Conv1dPad::causal) {
    if (opts.pad != 0) throw Error("Conv1d: causal padding is implied; pad must be 0, got " + std::to_string(opts.pad));
    padding_ = ag::Conv1dPadding::causal(std::max<int64_t>(0, (k - 1) * opts.dilation + 1 - opts.stride),
                                         opts.exact_causal);
  } else {
    padding_ = ag::Conv1dPadding::same_zeros(opts.pad);
  }
  const double bound = 1.0 / std::sqrt((double)(cin * k));
  weight_ = register_parameter("weight", rand_uniform({cout, cin, k}, gen, -bound, bound));
  if (opts.bias) bias_ = register_parameter("bias", rand_uniform({cout}, gen, -bound, bound));
}

ag::Variable Conv1d::forward(const ag::Variable& x) const {
  return ag::conv1d(x, weight_, bias_, opts_.stride, opts_.dilation, padding_);
}

}  // namespace t2m::nn
