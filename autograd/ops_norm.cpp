// ops_norm.cpp — forward/backward pairs of layer_norm, rms_norm and group_norm over the fused kernels. The ops
// check shapes, make operands contiguous (no copy when they already are), dispatch on the dtype and record one
// node whose inputs are x plus whichever of weight/bias are defined.
#include "autograd/ops_norm.h"

#include <string>
#include <vector>

#include "autograd/node.h"
#include "tensor/fused/group_norm.h"
#include "tensor/fused/layer_norm.h"
#include "tensor/fused/rms_norm.h"
#include "tensor/parallel.h"

namespace t2m::ag {

namespace {

bool is_float(DType d) { return d == DType::f32 || d == DType::f64; }

// The recorded inputs are x, then weight and bias when defined; wi/bi are their positions (-1 when absent),
// n the number of recorded inputs. Kept by the backward closure (no Variables: the node must not own them).
struct NormInputs {
  int n = 1, wi = -1, bi = -1;
  Tensor w, b;  // contiguous parameter values (undefined when absent)
};

NormInputs norm_inputs(const char* op, const Variable& x, const Variable& weight, const Variable& bias, int64_t C,
                       std::vector<Variable>& vars) {
  NormInputs in;
  vars = {x};
  const DType dt = x.dtype();
  if (!is_float(dt)) throw Error(std::string(op) + ": x must be f32 or f64, got " + dtype_name(dt));
  auto take = [&](const Variable& p, const char* name, int& idx, Tensor& val) {
    if (!p.defined()) return;
    if (p.dim() != 1 || p.size(0) != C)
      throw Error(std::string(op) + ": " + name + " must be [" + std::to_string(C) + "] for x " +
                  shape_str(x.shape()) + ", got " + shape_str(p.shape()));
    if (p.dtype() != dt)
      throw Error(std::string(op) + ": " + name + " dtype " + dtype_name(p.dtype()) + " differs from x dtype " +
                  dtype_name(dt));
    idx = in.n++;
    vars.push_back(p);
    val = p.data().contiguous();
  };
  take(weight, "weight", in.wi, in.w);
  take(bias, "bias", in.bi, in.b);
  return in;
}

template <typename T>
const T* cptr(const Tensor& t) { return t.defined() ? t.data<T>() : nullptr; }
template <typename T>
T* mptr(Tensor& t) { return t.defined() ? t.data<T>() : nullptr; }

// Parameter-gradient buffers (zeroed: the kernels accumulate) for the defined, needed parameters.
void param_grads(const NormInputs& in, const std::vector<bool>& need, Tensor& dw, Tensor& db) {
  if (in.wi >= 0 && need[in.wi]) dw = Tensor::zeros(in.w.shape(), in.w.dtype());
  if (in.bi >= 0 && need[in.bi]) db = Tensor::zeros(in.b.shape(), in.b.dtype());
}

std::vector<Tensor> pack_grads(const NormInputs& in, Tensor dx, Tensor dw, Tensor db) {
  std::vector<Tensor> out(in.n);
  out[0] = std::move(dx);
  if (in.wi >= 0) out[in.wi] = std::move(dw);
  if (in.bi >= 0) out[in.bi] = std::move(db);
  return out;
}

void check_eps(const char* op, double eps) {
  if (!(eps >= 0.0)) throw Error(std::string(op) + ": eps must be >= 0, got " + std::to_string(eps));
}

}  // namespace

// x (N, C) rows -> out (N, C); mean/rstd (N) saved.  dx, dweight, dbias from the fused backward.
Variable layer_norm(const Variable& x, const Variable& weight, const Variable& bias, double eps) {
  if (x.dim() < 1 || x.size(-1) < 1)
    throw Error("layer_norm: x must have a non-empty last dim, got " + shape_str(x.shape()));
  check_eps("layer_norm", eps);
  const int64_t C = x.size(-1), N = x.numel() / C;
  std::vector<Variable> vars;
  const NormInputs in = norm_inputs("layer_norm", x, weight, bias, C, vars);
  const Tensor xc = x.data().contiguous();
  const DType dt = xc.dtype();
  Tensor out = Tensor::empty(xc.shape(), dt), mean = Tensor::empty({N}, dt), rstd = Tensor::empty({N}, dt);
  if (xc.numel() == 0) {
    // zero rows: nothing to normalise
  } else if (dt == DType::f32)
    fused::layer_norm_forward<float>(out.data<float>(), mean.data<float>(), rstd.data<float>(), xc.data<float>(),
                                     cptr<float>(in.w), cptr<float>(in.b), N, C, (float)eps);
  else
    fused::layer_norm_forward<double>(out.data<double>(), mean.data<double>(), rstd.data<double>(),
                                      xc.data<double>(), cptr<double>(in.w), cptr<double>(in.b), N, C, eps);
  return record("layer_norm", out, vars,
                [in, xc, mean, rstd, N, C](const Tensor& grad, const std::vector<bool>& need) {
                  const Tensor g = grad.contiguous();
                  Tensor dw, db;
                  param_grads(in, need, dw, db);
                  Tensor dx = Tensor::empty(xc.shape(), xc.dtype());  // the kernels always write dinp
                  if (xc.numel() == 0) return pack_grads(in, dx, dw, db);
                  if (g.dtype() == DType::f32)
                    fused::layer_norm_backward<float>(mptr<float>(dx), mptr<float>(dw), mptr<float>(db),
                                                      g.data<float>(), xc.data<float>(), cptr<float>(in.w),
                                                      mean.data<float>(), rstd.data<float>(), N, C);
                  else
                    fused::layer_norm_backward<double>(mptr<double>(dx), mptr<double>(dw), mptr<double>(db),
                                                       g.data<double>(), xc.data<double>(), cptr<double>(in.w),
                                                       mean.data<double>(), rstd.data<double>(), N, C);
                  return pack_grads(in, dx, dw, db);
                });
}

// x (N, C) rows -> out (N, C); rstd (N) saved.
Variable rms_norm(const Variable& x, const Variable& weight, double eps) {
  if (x.dim() < 1 || x.size(-1) < 1)
    throw Error("rms_norm: x must have a non-empty last dim, got " + shape_str(x.shape()));
  check_eps("rms_norm", eps);
  const int64_t C = x.size(-1), N = x.numel() / C;
  std::vector<Variable> vars;
  const NormInputs in = norm_inputs("rms_norm", x, weight, Variable(), C, vars);
  const Tensor xc = x.data().contiguous();
  const DType dt = xc.dtype();
  Tensor out = Tensor::empty(xc.shape(), dt), rstd = Tensor::empty({N}, dt);
  if (xc.numel() == 0) {
    // zero rows: nothing to normalise
  } else if (dt == DType::f32)
    fused::rms_norm_forward<float>(out.data<float>(), rstd.data<float>(), xc.data<float>(), cptr<float>(in.w), N,
                                   C, (float)eps);
  else
    fused::rms_norm_forward<double>(out.data<double>(), rstd.data<double>(), xc.data<double>(), cptr<double>(in.w),
                                    N, C, eps);
  return record("rms_norm", out, vars, [in, xc, rstd, N, C](const Tensor& grad, const std::vector<bool>& need) {
    const Tensor g = grad.contiguous();
    Tensor dw, db;
    param_grads(in, need, dw, db);
    Tensor dx = Tensor::empty(xc.shape(), xc.dtype());  // the kernel always writes dinp
    if (xc.numel() == 0) return pack_grads(in, dx, dw, db);
    if (g.dtype() == DType::f32)
      fused::rms_norm_backward<float>(mptr<float>(dx), mptr<float>(dw), g.data<float>(), xc.data<float>(),
                                      cptr<float>(in.w), rstd.data<float>(), N, C);
    else
      fused::rms_norm_backward<double>(mptr<double>(dx), mptr<double>(dw), g.data<double>(), xc.data<double>(),
                                       cptr<double>(in.w), rstd.data<double>(), N, C);
    return pack_grads(in, dx, dw, db);
  });
}

namespace {

// Shared by group_norm and group_norm_relu. x (B, C, T) -> out (B, C, T); mean/rstd (B, G) saved (with relu the
// backward recomputes the output's sign from them, x, weight and bias).
Variable group_norm_op(const char* op, const Variable& x, int64_t groups, const Variable& weight,
                       const Variable& bias, double eps, bool relu) {
  if ((x.dim() != 3 && x.dim() != 2) || x.size(1) < 1 || (x.dim() == 3 && x.size(2) < 1))
    throw Error(std::string(op) + ": x must be (B, C, T) or (B, C) with C, T >= 1, got " + shape_str(x.shape()));
  const int64_t B = x.size(0), C = x.size(1), Tl = x.dim() == 3 ? x.size(2) : 1;
  if (groups < 1 || C % groups != 0)
    throw Error(std::string(op) + ": C = " + std::to_string(C) + " must be divisible by groups = " +
                std::to_string(groups) + " (x " + shape_str(x.shape()) + ")");
  check_eps(op, eps);
  std::vector<Variable> vars;
  const NormInputs in = norm_inputs(op, x, weight, bias, C, vars);
  const Tensor xc = x.data().contiguous();
  const DType dt = xc.dtype();
  const int64_t G = groups, n = xc.numel();
  Tensor out = Tensor::empty(xc.shape(), dt), mean = Tensor::empty({B, G}, dt), rstd = Tensor::empty({B, G}, dt);
  if (n == 0) {
    // zero batch: nothing to normalise
  } else if (dt == DType::f32) {
    fused::group_norm_forward<float>(out.data<float>(), mean.data<float>(), rstd.data<float>(), xc.data<float>(),
                                     cptr<float>(in.w), cptr<float>(in.b), B, C, Tl, G, (float)eps, relu);
  } else {
    fused::group_norm_forward<double>(out.data<double>(), mean.data<double>(), rstd.data<double>(),
                                      xc.data<double>(), cptr<double>(in.w), cptr<double>(in.b), B, C, Tl, G, eps,
                                      relu);
  }
  return record(op, out, vars,
                [in, xc, mean, rstd, relu, B, C, Tl, G, n](const Tensor& grad, const std::vector<bool>& need) {
                  const Tensor g = grad.contiguous();
                  Tensor dw, db;
                  param_grads(in, need, dw, db);
                  Tensor dx = Tensor::empty(xc.shape(), xc.dtype());  // the kernel always writes dinp
                  if (n == 0) return pack_grads(in, dx, dw, db);
                  if (g.dtype() == DType::f32) {
                    fused::group_norm_backward<float>(mptr<float>(dx), mptr<float>(dw), mptr<float>(db),
                                                      g.data<float>(), xc.data<float>(), cptr<float>(in.w),
                                                      mean.data<float>(), rstd.data<float>(), B, C, Tl, G, relu,
                                                      cptr<float>(in.b));
                  } else {
                    fused::group_norm_backward<double>(mptr<double>(dx), mptr<double>(dw), mptr<double>(db),
                                                       g.data<double>(), xc.data<double>(), cptr<double>(in.w),
                                                       mean.data<double>(), rstd.data<double>(), B, C, Tl, G,
                                                       relu, cptr<double>(in.b));
                  }
                  return pack_grads(in, dx, dw, db);
                });
}

}  // namespace

Variable group_norm(const Variable& x, int64_t groups, const Variable& weight, const Variable& bias, double eps) {
  return group_norm_op("group_norm", x, groups, weight, bias, eps, /*relu=*/false);
}

Variable group_norm_relu(const Variable& x, int64_t groups, const Variable& weight, const Variable& bias,
                         double eps) {
  return group_norm_op("group_norm_relu", x, groups, weight, bias, eps, /*relu=*/true);
}

}  // namespace t2m::ag
