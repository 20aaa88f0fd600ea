// loss_flow.cpp — linear-path interpolation (Eq 14), its velocity target and MSE (Eq 15), and time sampling.
#include "nn/loss_flow.h"

#include <string>

#include "autograd/no_grad.h"
#include "autograd/ops_elementwise.h"
#include "tensor/ops.h"

namespace t2m::nn {
namespace {

// t (B,) or one element -> a shape broadcasting against (B, ...): (B, 1, ..., 1)
Shape time_shape(const ag::Variable& t, const Shape& x, const char* op) {
  if (!t.defined()) throw Error(std::string(op) + ": t is undefined");
  if (t.numel() == 1 && t.dim() <= 1) return Shape(x.size(), 1);
  if (t.dim() != 1 || t.size(0) != x[0])
    throw Error(std::string(op) + ": t must be (B,) = " + shape_str({x[0]}) + " or one element, got " +
                shape_str(t.shape()) + " for x " + shape_str(x));
  Shape s(x.size(), 1);
  s[0] = x[0];
  return s;
}

void check_pair(const ag::Variable& x0, const ag::Variable& x1, const char* op) {
  if (!x0.defined() || !x1.defined()) throw Error(std::string(op) + ": x0 or x1 is undefined");
  if (x0.shape() != x1.shape() || x0.dim() == 0)
    throw Error(std::string(op) + ": x0 " + shape_str(x0.shape()) + " and x1 " + shape_str(x1.shape()) +
                " must have one shape (B, ...)");
  if (x0.dtype() != x1.dtype())
    throw Error(std::string(op) + ": x0 is " + dtype_name(x0.dtype()) + " but x1 is " + dtype_name(x1.dtype()));
}

}  // namespace

// x0, x1 (B, ...), t (B,) -> x_t = x0 + t (x1 − x0) (Eq 14), velocity = x1 − x0
FlowPoint flow_interpolate(const ag::Variable& x0, const ag::Variable& x1, const ag::Variable& t) {
  const char* op = "flow_interpolate";
  check_pair(x0, x1, op);
  if (t.defined() && t.dtype() != x0.dtype())
    throw Error(std::string(op) + ": t is " + dtype_name(t.dtype()) + " but x is " + dtype_name(x0.dtype()));
  ag::Variable tb = t.reshape(time_shape(t, x0.shape(), op));
  FlowPoint p;
  p.velocity = ag::sub(x1, x0);
  p.x_t = ag::add(ag::mul(ag::rsub(1.0, tb), x0), ag::mul(tb, x1));  // (1 − t) x0 + t x1
  return p;
}

// Eq 15: || v − (x1 − x0) ||² with mse_loss's reduction
ag::Variable flow_matching_loss(const ag::Variable& v_pred, const ag::Variable& x0, const ag::Variable& x1,
                                const MseOptions& opt) {
  check_pair(x0, x1, "flow_matching_loss");
  return mse_loss(v_pred, ag::sub(x1, x0), opt);
}

Tensor sample_flow_time(int64_t batch, Generator& gen, const FlowTimeOptions& opt, DType dtype) {
  if (batch < 0) throw Error("sample_flow_time: batch must be >= 0, got " + std::to_string(batch));
  if (dtype != DType::f32 && dtype != DType::f64)
    throw Error(std::string("sample_flow_time: dtype must be float, got ") + dtype_name(dtype));
  if (opt.kind == FlowTimeSampling::uniform) return rand_uniform({batch}, gen, 0.0, 1.0, dtype);
  if (!(opt.std >= 0.0)) throw Error("sample_flow_time: logit_normal std must be >= 0, got " + std::to_string(opt.std));
  return t2m::sigmoid(rand_normal({batch}, gen, opt.mean, opt.std, dtype));
}

FlowSample sample_flow_pair(const Tensor& x1, Generator& gen, const FlowTimeOptions& opt) {
  if (!x1.defined() || x1.dim() == 0) throw Error("sample_flow_pair: x1 must be (B, ...), got a 0-d/undefined tensor");
  FlowSample s;
  s.t = sample_flow_time(x1.size(0), gen, opt, x1.dtype());
  s.x0 = rand_normal(x1.shape(), gen, 0.0, 1.0, x1.dtype());
  ag::NoGradGuard guard;
  FlowPoint p = flow_interpolate(ag::Variable(s.x0), ag::Variable(x1), ag::Variable(s.t));
  s.x_t = p.x_t.data();
  s.velocity = p.velocity.data();
  return s;
}

}  // namespace t2m::nn
