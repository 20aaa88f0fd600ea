// adaln.h — adaptive LayerNorm conditioning of the DiT block (Peebles & Xie 2023) as torch_ref.py uses it:
// a conditioning vector c (B, C) goes through SiLU -> Linear(C, n*D) and is cut into n chunks of (B, D)
// (shift, scale, gate, ...), which act on a (B, T, D) sequence, broadcast over time.
//
// modulate(x, shift, scale) = x * (1 + scale[:, None]) + shift[:, None]
//   x (B, T, D), shift and scale (B, D) -> (B, T, D). One op: dx = g (1 + scale), dshift = sum_t g,
//   dscale = sum_t g x.
// gated_residual(x, gate, y) = x + gate[:, None] * y
//   x, y (B, T, D), gate (B, D) -> (B, T, D). One op: dx = g, dy = g gate, dgate = sum_t g y.
// Both accept any strides and float32/float64; errors (t2m::Error naming the op and all shapes): x not 3-D,
// (B, D) operands of another shape, y not x's shape, mixed or non-float dtypes.
//
// AdaLN: the module. Its parameters are "weight" (n*D, C) and "bias" (n*D) — the names of torch_ref.py's
// `ada = nn.Linear(d, 6 * d)` (and `f_ada`), so PyTorch weights load by name. Initialisation: PyTorch's Linear
// default, U(-1/sqrt(C), 1/sqrt(C)) for both, from the Generator; zero_init() gives the DiT "adaLN-Zero" start.
// forward(c): c (B, C) -> n chunks, each (B, D) (views of one (B, n*D) result). Errors: c not (B, C).
#pragma once
#include <cstdint>
#include <vector>

#include "autograd/variable.h"
#include "nn/module.h"
#include "tensor/rng.h"

namespace t2m::nn {

ag::Variable modulate(const ag::Variable& x, const ag::Variable& shift, const ag::Variable& scale);
ag::Variable gated_residual(const ag::Variable& x, const ag::Variable& gate, const ag::Variable& y);

class AdaLN : public Module {
 public:
  AdaLN(int64_t cond_dim, int64_t dim, int64_t chunks, Generator& gen);
  std::vector<ag::Variable> forward(const ag::Variable& c) const;
  void zero_init();  // weight and bias to 0: every chunk starts at 0 (gates closed, identity modulation)

  int64_t cond_dim() const { return cond_dim_; }
  int64_t dim() const { return dim_; }
  int64_t chunks() const { return chunks_; }
  ag::Variable weight, bias;

 private:
  int64_t cond_dim_, dim_, chunks_;
};

}  // namespace t2m::nn
