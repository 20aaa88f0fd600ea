// loss_diffusion.cpp — VP interpolation, its v target and MSE, and the training draw.
#include "nn/loss_diffusion.h"

#include <string>

#include "autograd/no_grad.h"
#include "autograd/ops_elementwise.h"
#include "tensor/ops.h"

namespace t2m::nn {

namespace {

// (B,) or one element -> (B, 1, ..., 1) broadcasting against x
ag::Variable per_sample(const ag::Variable& a, const ag::Variable& x, const char* op, const char* name) {
  if (!a.defined()) throw Error(std::string(op) + ": " + name + " is undefined");
  if (a.dtype() != x.dtype())
    throw Error(std::string(op) + ": " + name + " is " + dtype_name(a.dtype()) + " but x is " + dtype_name(x.dtype()));
  Shape s(x.dim(), 1);
  if (a.numel() == 1 && a.dim() <= 1) return a.reshape(s);
  if (a.dim() != 1 || a.size(0) != x.size(0))
    throw Error(std::string(op) + ": " + name + " must be (B,) = " + shape_str({x.size(0)}) + " or one element, got " +
                shape_str(a.shape()));
  s[0] = x.size(0);
  return a.reshape(s);
}

void check_pair(const ag::Variable& x, const ag::Variable& eps, const char* op) {
  if (!x.defined() || !eps.defined()) throw Error(std::string(op) + ": x or eps is undefined");
  if (x.shape() != eps.shape() || x.dim() == 0)
    throw Error(std::string(op) + ": x " + shape_str(x.shape()) + " and eps " + shape_str(eps.shape()) +
                " must have one shape (B, ...)");
  if (x.dtype() != eps.dtype())
    throw Error(std::string(op) + ": x is " + dtype_name(x.dtype()) + " but eps is " + dtype_name(eps.dtype()));
}

}  // namespace

// x_t = alpha x + sigma eps, v = alpha eps − sigma x (v-prediction, Salimans & Ho 2022)
DiffusionPoint diffusion_interpolate(const ag::Variable& x, const ag::Variable& eps, const ag::Variable& alpha,
                                     const ag::Variable& sigma) {
  const char* op = "diffusion_interpolate";
  check_pair(x, eps, op);
  const ag::Variable a = per_sample(alpha, x, op, "alpha"), s = per_sample(sigma, x, op, "sigma");
  return {ag::add(ag::mul(a, x), ag::mul(s, eps)), ag::sub(ag::mul(a, eps), ag::mul(s, x))};
}

// || v_pred − (alpha eps − sigma x) ||² with mse_loss's reduction
ag::Variable diffusion_v_loss(const ag::Variable& v_pred, const ag::Variable& x, const ag::Variable& eps,
                              const ag::Variable& alpha, const ag::Variable& sigma, const MseOptions& opt) {
  const char* op = "diffusion_v_loss";
  check_pair(x, eps, op);
  const ag::Variable a = per_sample(alpha, x, op, "alpha"), s = per_sample(sigma, x, op, "sigma");
  return mse_loss(v_pred, ag::sub(ag::mul(a, eps), ag::mul(s, x)), opt);
}

DiffusionSample sample_diffusion_pair(const Tensor& x, Generator& gen, NoiseSchedule schedule) {
  if (!x.defined() || x.dim() == 0)
    throw Error("sample_diffusion_pair: x must be (B, ...), got a 0-d/undefined tensor");
  if (x.dtype() != DType::f32 && x.dtype() != DType::f64)
    throw Error(std::string("sample_diffusion_pair: x must be float, got ") + dtype_name(x.dtype()));
  DiffusionSample s;
  s.t = rand_uniform({x.size(0)}, gen, 0.0, 1.0, x.dtype());
  s.eps = rand_normal(x.shape(), gen, 0.0, 1.0, x.dtype());
  s.alpha = schedule_alphas(schedule, s.t);
  s.sigma = schedule_sigmas(schedule, s.t);
  ag::NoGradGuard guard;
  const DiffusionPoint p =
      diffusion_interpolate(ag::Variable(x), ag::Variable(s.eps), ag::Variable(s.alpha), ag::Variable(s.sigma));
  s.x_t = p.x_t.data();
  s.v = p.v.data();
  return s;
}

}  // namespace t2m::nn
