// linear.cpp — forward/backward of y = x W^T + b on raw GEMMs over the flattened leading dims.
#include "nn/linear.h"

#include <omp.h>

#include <cmath>
#include <string>

#include "autograd/node.h"
#include "autograd/ops_unary.h"
#include "tensor/gemm.h"
#include "tensor/parallel.h"

namespace t2m::nn {

namespace {

bool is_float(DType d) { return d == DType::f32 || d == DType::f64; }

// x (N, in), w (out, in), b (out) or null -> y (N, out) = x w^T + b (the bias added in the GEMM's final store),
// or relu(x w^T + b) with the ReLU on each output tile as the GEMM stores it.
template <typename T>
void linear_fwd(T* y, const T* x, const T* w, const T* b, int64_t N, int64_t in, int64_t out, bool relu) {
  if (relu)
    gemm_bias_relu(false, true, N, out, in, (T)1, x, in, w, in, b, y, out);
  else
    gemm_bias(false, true, N, out, in, (T)1, x, in, w, in, b, y, out);
}

// g (N, out), x (N, in), w (out, in). dx (N, in) = g w; dw (out, in) = g^T x (streamed to memory when large: the
// optimizer reads it next, after the rest of the backward pass); db (out) = sum_n g[n]. Null skips.
template <typename T>
void linear_bwd(T* dx, T* dw, T* db, const T* g, const T* x, const T* w, int64_t N, int64_t in, int64_t out) {
  if (dx != nullptr) gemm(false, false, N, in, out, (T)1, g, out, w, in, (T)0, dx, in);
  if (dw != nullptr) gemm_stream(true, false, out, in, N, (T)1, g, out, x, in, dw, in);
  if (db != nullptr) {
    // Columns split across threads; each column summed over rows in order (same result for any thread count), a
    // block of kCols columns at a time in registers (summing into db row after row was bound by its stores).
    constexpr int64_t kCols = 64;
    const int nt = N * out < kParallelGrain || out < 64 ? 1 : get_num_threads();
#pragma omp parallel num_threads(nt)
    {
      const int tid = omp_get_thread_num(), nth = omp_get_num_threads();
      const int64_t j0 = out * tid / nth, j1 = out * (tid + 1) / nth;
      int64_t j = j0;
      for (; j + kCols <= j1; j += kCols) {
        T acc[kCols] = {};
        for (int64_t n = 0; n < N; ++n) {
          const T* gr = g + n * out + j;
#pragma omp simd
          for (int64_t c = 0; c < kCols; ++c) acc[c] += gr[c];
        }
        for (int64_t c = 0; c < kCols; ++c) db[j + c] = acc[c];
      }
      for (int64_t c = j; c < j1; ++c) db[c] = 0;
      for (int64_t n = 0; n < N && j < j1; ++n) {
        const T* gr = g + n * out;
        for (int64_t c = j; c < j1; ++c) db[c] += gr[c];
      }
    }
  }
}

template <typename T>
T* ptr(Tensor& t) { return t.defined() ? t.data<T>() : nullptr; }
template <typename T>
const T* cptr(const Tensor& t) { return t.defined() ? t.data<T>() : nullptr; }

// x (..., in), w (out, in), b (out) -> y (..., out) = x w^T + b, or its ReLU (`op` names it in errors).
ag::Variable linear_op(const char* op, const ag::Variable& x, const ag::Variable& weight, const ag::Variable& bias,
                       bool relu) {
  auto fail = [&](const std::string& what) {
    throw Error(std::string(op) + ": " + what + " (x " + shape_str(x.shape()) + ", weight " +
                shape_str(weight.shape()) + (bias.defined() ? ", bias " + shape_str(bias.shape()) : "") + ")");
  };
  if (weight.dim() != 2) fail("weight must be 2-D (out, in)");
  const int64_t out = weight.size(0), in = weight.size(1);
  if (x.dim() < 1 || x.size(-1) != in) fail("x's last dim must equal in = " + std::to_string(in));
  if (bias.defined() && (bias.dim() != 1 || bias.size(0) != out)) fail("bias must be (out)");
  const DType dt = x.dtype();
  if (!is_float(dt) || weight.dtype() != dt || (bias.defined() && bias.dtype() != dt))
    fail(std::string("x, weight, bias must share a float dtype, got ") + dtype_name(dt) + " and " +
         dtype_name(weight.dtype()));
  const int64_t N = x.numel() / in;
  const Tensor xc = x.data().contiguous(), wc = weight.data().contiguous();
  const Tensor bc = bias.defined() ? bias.data().contiguous() : Tensor();
  Shape oshape = x.shape();
  oshape.back() = out;
  Tensor y = Tensor::empty(oshape, dt);
  if (N > 0) {
    if (dt == DType::f32)
      linear_fwd<float>(y.data<float>(), xc.data<float>(), wc.data<float>(), cptr<float>(bc), N, in, out, relu);
    else
      linear_fwd<double>(y.data<double>(), xc.data<double>(), wc.data<double>(), cptr<double>(bc), N, in, out,
                         relu);
  }
  std::vector<ag::Variable> vars{x, weight};
  if (bias.defined()) vars.push_back(bias);
  // Save x only when W needs a gradient and W only when x does.
  const Tensor sx = weight.requires_grad() ? xc : Tensor(), sw = x.requires_grad() ? wc : Tensor();
  const bool has_bias = bias.defined();
  const Tensor sy = relu ? y : Tensor();  // the ReLU's mask comes from its output
  return ag::record(op, y, vars,
                    [sx, sw, sy, has_bias, N, in, out, dt, xshape = x.shape()](const Tensor& grad,
                                                                               const std::vector<bool>& need) {
                      // the ReLU's mask from its output: the same bits as ag::relu's from its input
                      const Tensor g = sy.defined() ? ag::relu_grad(grad, sy) : grad.contiguous();
                      Tensor dx, dw, db;
                      if (need[0]) dx = Tensor::empty(xshape, dt);
                      if (need[1]) dw = Tensor::empty({out, in}, dt);
                      if (has_bias && need[2]) db = Tensor::empty({out}, dt);
                      if (N == 0) {
                        if (dw.defined()) dw.zero_();
                        if (db.defined()) db.zero_();
                      } else if (dt == DType::f32) {
                        linear_bwd<float>(ptr<float>(dx), ptr<float>(dw), ptr<float>(db), g.data<float>(),
                                          cptr<float>(sx), cptr<float>(sw), N, in, out);
                      } else {
                        linear_bwd<double>(ptr<double>(dx), ptr<double>(dw), ptr<double>(db), g.data<double>(),
                                           cptr<double>(sx), cptr<double>(sw), N, in, out);
                      }
                      std::vector<Tensor> r{dx, dw};
                      if (has_bias) r.push_back(db);
                      return r;
                    });
}

}  // namespace

ag::Variable linear(const ag::Variable& x, const ag::Variable& weight, const ag::Variable& bias) {
  return linear_op("linear", x, weight, bias, false);
}

ag::Variable linear_relu(const ag::Variable& x, const ag::Variable& weight, const ag::Variable& bias) {
  return linear_op("linear_relu", x, weight, bias, true);
}

Linear::Linear(int64_t in_features, int64_t out_features, bool bias, Generator& gen)
    : in_(in_features), out_(out_features) {
  if (in_ < 1 || out_ < 1)
    throw Error("Linear: in and out must be >= 1, got in = " + std::to_string(in_) + ", out = " +
                std::to_string(out_));
  const double bound = 1.0 / std::sqrt((double)in_);
  weight_ = register_parameter("weight", rand_uniform({out_, in_}, gen, -bound, bound));
  if (bias) bias_ = register_parameter("bias", rand_uniform({out_}, gen, -bound, bound));
}

ag::Variable Linear::forward(const ag::Variable& x) const { return linear(x, weight_, bias_); }
ag::Variable Linear::forward_relu(const ag::Variable& x) const { return linear_relu(x, weight_, bias_); }

}  // namespace t2m::nn
