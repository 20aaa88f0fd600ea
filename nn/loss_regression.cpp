// loss_regression.cpp — MSE built from autograd ops: (pred - target)^2, optional sum over the last dim, then the
// weighted mean of nn/loss_reduce.h.
#include "nn/loss_regression.h"

#include <string>

#include "autograd/ops_elementwise.h"
#include "autograd/ops_reduce.h"
#include "autograd/ops_unary.h"
#include "nn/loss_reduce.h"

namespace t2m::nn {

// pred, target (..., D) -> scalar
ag::Variable mse_loss(const ag::Variable& pred, const ag::Variable& target, const MseOptions& opt) {
  if (!pred.defined() || !target.defined()) throw Error("mse_loss: pred or target is undefined");
  if (pred.shape() != target.shape())
    throw Error("mse_loss: pred " + shape_str(pred.shape()) + " and target " + shape_str(target.shape()) +
                " must have the same shape");
  if (pred.dtype() != target.dtype())
    throw Error(std::string("mse_loss: pred is ") + dtype_name(pred.dtype()) + " but target is " +
                dtype_name(target.dtype()));
  ag::Variable sq = ag::square(ag::sub(pred, target));  // (..., D)
  if (!opt.sum_last_dim) return weighted_mean(sq, opt.weights, "mse_loss");
  if (pred.dim() == 0) throw Error("mse_loss: sum_last_dim needs at least 1-D inputs, got a 0-d tensor");
  ag::Variable per_frame = ag::sum(sq, {-1});  // (...)
  Tensor w = opt.weights;
  if (w.defined() && w.dim() > 0) {
    if (w.size(-1) != 1)
      throw Error("mse_loss: with sum_last_dim the weights must be per frame (last dim 1), got " +
                  shape_str(w.shape()) + " for pred " + shape_str(pred.shape()));
    w = w.squeeze(-1);
  }
  return weighted_mean(per_frame, w, "mse_loss");
}

}  // namespace t2m::nn
