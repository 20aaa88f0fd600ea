// upsample.cpp — Upsample1d module over ag::upsample_nearest1d.
#include "nn/upsample.h"

#include <string>

#include "autograd/ops_conv.h"

namespace t2m::nn {

Upsample1d::Upsample1d(int64_t scale) : scale_(scale) {
  if (scale < 1) throw Error("Upsample1d: scale must be >= 1, got " + std::to_string(scale));
}

ag::Variable Upsample1d::forward(const ag::Variable& x) const { return ag::upsample_nearest1d(x, scale_); }

}  // namespace t2m::nn
