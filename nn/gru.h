// gru.h — gated recurrent unit over a padded batch of sequences (PyTorch nn.GRU semantics, one layer, one
// direction per call; the Guo et al. evaluator encoders run it forward and backward and join the two).
//
// Per step, gates in PyTorch's order (r, z, n), W_i* rows of weight_ih (3H, I), W_h* rows of weight_hh (3H, H):
//   r = sigmoid(W_ir x_t + b_ir + W_hr h + b_hr)
//   z = sigmoid(W_iz x_t + b_iz + W_hz h + b_hz)
//   n = tanh(W_in x_t + b_in + r * (W_hn h + b_hn))
//   h' = (1 - z) * n + z * h
// gru(x, h0, weight_ih, weight_hh, bias_ih, bias_hh, mask, reverse): x (B, T, I); h0 (B, H) or undefined (zeros);
//   biases (3H) or undefined; mask (B, T) float (1 = real step, 0 = padding) or undefined (all real).
//   At a padded step the hidden state is carried unchanged and the output is 0, so for right-padded sequences
//   `last` equals the state after the final real step (what pack_padded_sequence gives) in both directions.
//   reverse = true walks t = T-1 .. 0 (output[:, t] is still the state after reading step t).
//   Returns output (B, T, H) and last (B, H). Composed from autograd ops (one input GEMM for all steps, one
//   hidden GEMM per step), so backward is the autograd chain; float32 and float64.
// GRU(input, hidden, gen): parameters weight_ih (3H, I), weight_hh (3H, H), bias_ih (3H), bias_hh (3H), in that
//   order, all drawn from U(-1/sqrt(H), 1/sqrt(H)) (PyTorch's default) from the Generator.
// Errors (t2m::Error, message starts "gru:" and names the shapes): x not 3-D or with T = 0, weight shapes not
//   (3H, I) / (3H, H), bias not (3H), h0 not (B, H), mask not a float (B, T), sizes < 1 in the constructor.
#pragma once
#include <cstdint>

#include "autograd/variable.h"
#include "nn/module.h"
#include "tensor/rng.h"

namespace t2m::nn {

struct GRUOutput {
  ag::Variable output;  // (B, T, H), zero at padded steps
  ag::Variable last;    // (B, H)
};

GRUOutput gru(const ag::Variable& x, const ag::Variable& h0, const ag::Variable& weight_ih,
              const ag::Variable& weight_hh, const ag::Variable& bias_ih, const ag::Variable& bias_hh,
              const Tensor& mask = Tensor(), bool reverse = false);

class GRU : public Module {
 public:
  GRU(int64_t input_size, int64_t hidden_size, Generator& gen);
  GRUOutput forward(const ag::Variable& x, const Tensor& mask = Tensor(), const ag::Variable& h0 = ag::Variable(),
                    bool reverse = false) const;

  int64_t input_size() const { return in_; }
  int64_t hidden_size() const { return hidden_; }
  const ag::Variable& weight_ih() const { return w_ih_; }
  const ag::Variable& weight_hh() const { return w_hh_; }
  const ag::Variable& bias_ih() const { return b_ih_; }
  const ag::Variable& bias_hh() const { return b_hh_; }

 private:
  int64_t in_, hidden_;
  ag::Variable w_ih_, w_hh_, b_ih_, b_hh_;
};

}  // namespace t2m::nn
