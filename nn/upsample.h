// upsample.h — the Upsample1d module: nearest-neighbour upsampling along time by an integer factor
// (x (B, C, T) -> (B, C, T*scale), ag::upsample_nearest1d). No parameters. Errors: scale < 1.
#pragma once
#include <cstdint>

#include "autograd/variable.h"
#include "nn/module.h"

namespace t2m::nn {

class Upsample1d : public Module {
 public:
  explicit Upsample1d(int64_t scale = 2);
  ag::Variable forward(const ag::Variable& x) const;
  ag::Variable operator()(const ag::Variable& x) const { return forward(x); }
  int64_t scale() const { return scale_; }

 private:
  int64_t scale_;
};

}  // namespace t2m::nn
