// gru.cpp — GRU recurrence from autograd ops: one GEMM for the input projections of all steps, then per step one
// GEMM for the hidden projection and the gate arithmetic; padding handled by carrying the state (where()).
#include "nn/gru.h"

#include <cmath>
#include <string>
#include <vector>

#include "autograd/ops_elementwise.h"
#include "autograd/ops_join.h"
#include "autograd/ops_unary.h"
#include "nn/linear.h"

namespace t2m::nn {

namespace {

std::string shape_of(const ag::Variable& v) { return v.defined() ? shape_str(v.shape()) : "undefined"; }

}  // namespace

GRUOutput gru(const ag::Variable& x, const ag::Variable& h0, const ag::Variable& weight_ih,
              const ag::Variable& weight_hh, const ag::Variable& bias_ih, const ag::Variable& bias_hh,
              const Tensor& mask, bool reverse) {
  if (!x.defined() || x.dim() != 3 || x.size(1) < 1 || (x.dtype() != DType::f32 && x.dtype() != DType::f64))
    throw Error("gru: x must be a float (B, T, I) tensor with T >= 1, got " +
                (x.defined() ? std::string(dtype_name(x.dtype())) + " " : std::string()) + shape_of(x));
  const int64_t B = x.size(0), T = x.size(1), I = x.size(2);
  if (!weight_hh.defined() || weight_hh.dim() != 2 || weight_hh.size(0) % 3 != 0 || weight_hh.size(0) < 3 ||
      weight_hh.size(1) * 3 != weight_hh.size(0))
    throw Error("gru: weight_hh must be (3H, H), got " + shape_of(weight_hh));
  const int64_t H = weight_hh.size(1);
  if (!weight_ih.defined() || weight_ih.shape() != Shape{3 * H, I})
    throw Error("gru: weight_ih must be (3H, I) = " + shape_str({3 * H, I}) + " for x " + shape_of(x) +
                " and H = " + std::to_string(H) + ", got " + shape_of(weight_ih));
  for (const ag::Variable* b : {&bias_ih, &bias_hh})
    if (b->defined() && b->shape() != Shape{3 * H})
      throw Error("gru: biases must be (3H) = " + shape_str({3 * H}) + ", got " + shape_of(*b));
  if (h0.defined() && h0.shape() != Shape{B, H})
    throw Error("gru: h0 must be (B, H) = " + shape_str({B, H}) + ", got " + shape_of(h0));
  if (mask.defined() && (mask.shape() != Shape{B, T} || mask.dtype() == DType::i64))
    throw Error("gru: mask must be a float (B, T) = " + shape_str({B, T}) + " tensor, got " +
                std::string(dtype_name(mask.dtype())) + " " + shape_str(mask.shape()));

  // Input projections of every step at once: (B, T, I) -> (B, T, 3H).
  const ag::Variable xw = linear(x, weight_ih, bias_ih);
  const ag::Variable zeros(Tensor::zeros({B, H}, x.dtype()));
  ag::Variable h = h0.defined() ? h0 : zeros;
  std::vector<ag::Variable> outs((size_t)T);
  for (int64_t s = 0; s < T; ++s) {
    const int64_t t = reverse ? T - 1 - s : s;
    std::vector<ag::Variable> gx = ag::chunk(xw.select(1, t), 3, 1);            // 3 x (B, H): r, z, n parts
    std::vector<ag::Variable> gh = ag::chunk(linear(h, weight_hh, bias_hh), 3, 1);
    ag::Variable r = ag::sigmoid(gx[0] + gh[0]);
    ag::Variable z = ag::sigmoid(gx[1] + gh[1]);
    ag::Variable n = ag::tanh(gx[2] + r * gh[2]);
    ag::Variable h_new = n + z * (h - n);                                         // (1 - z) n + z h
    if (mask.defined()) {
      const Tensor m = mask.select(1, t).unsqueeze(1);                            // (B, 1)
      h = ag::where(m, h_new, h);                                                 // padding carries the state
      outs[(size_t)t] = ag::where(m, h, zeros);
    } else {
      h = h_new;
      outs[(size_t)t] = h;
    }
  }
  return {ag::stack(outs, 1), h};
}

GRU::GRU(int64_t input_size, int64_t hidden_size, Generator& gen) : in_(input_size), hidden_(hidden_size) {
  if (in_ < 1 || hidden_ < 1)
    throw Error("gru: input and hidden sizes must be >= 1, got input = " + std::to_string(in_) + ", hidden = " +
                std::to_string(hidden_));
  const double k = 1.0 / std::sqrt((double)hidden_);
  w_ih_ = register_parameter("weight_ih", rand_uniform({3 * hidden_, in_}, gen, -k, k));
  w_hh_ = register_parameter("weight_hh", rand_uniform({3 * hidden_, hidden_}, gen, -k, k));
  b_ih_ = register_parameter("bias_ih", rand_uniform({3 * hidden_}, gen, -k, k));
  b_hh_ = register_parameter("bias_hh", rand_uniform({3 * hidden_}, gen, -k, k));
}

GRUOutput GRU::forward(const ag::Variable& x, const Tensor& mask, const ag::Variable& h0, bool reverse) const {
  return gru(x, h0, w_ih_, w_hh_, b_ih_, b_hh_, mask, reverse);
}

}  // namespace t2m::nn
