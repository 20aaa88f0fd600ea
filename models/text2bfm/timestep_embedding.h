// timestep_embedding.h — the flow time r of Text2BFM Eq 14-16 as the generator's conditioning vector c
// (the fm anchor's `timestep_embedding` + `t_mlp` in ../shared/anchor/torch_ref.py, DiT-style).
//
// timestep_embedding(t, dim, max_period): sinusoidal features of the scaled time 1000 t,
//   t (B) -> (B, dim), dim even: [cos(1000 t f_0), ..., cos(1000 t f_{h-1}), sin(1000 t f_0), ..., sin(...)],
//   f_i = exp(-ln(max_period) i / h), h = dim / 2. A plain tensor function (t is data, not a parameter);
//   float32 or float64, the dtype of t. Errors (t2m::Error "timestep_embedding: ..."): t not 1-D, dim odd or < 2,
//   non-float t.
// TimestepMLP(freq_dim, width): Linear(freq_dim, width) -> SiLU -> Linear(width, width), children "0" and "2"
//   (torch's nn.Sequential indices, so the anchor's `t_mlp.0.weight` ... load by name). PyTorch default init.
//   forward(t (B)) -> c (B, width).
#pragma once
#include <cstdint>
#include <memory>

#include "autograd/variable.h"
#include "nn/linear.h"
#include "nn/module.h"
#include "tensor/rng.h"

namespace t2m::text2bfm {

Tensor timestep_embedding(const Tensor& t, int64_t dim = 256, double max_period = 10000.0);

class TimestepMLP : public nn::Module {
 public:
  TimestepMLP(int64_t freq_dim, int64_t width, Generator& gen);
  ag::Variable forward(const Tensor& t) const;  // t (B) -> (B, width)
  int64_t freq_dim() const { return freq_dim_; }

 private:
  int64_t freq_dim_;
  std::shared_ptr<nn::Linear> fc0_, fc2_;
};

}  // namespace t2m::text2bfm
