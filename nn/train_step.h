// train_step.h — the optimizer step and the end-of-run loss plot that the trainers share.
//
// backward_clip_step: loss.backward(); reads loss.item(); clip_grad_norm(params, max_norm) (nn/grad_utils.h);
//   when the norm is not finite, check_finite_grads(params) throws t2m::Error naming the first parameter with a
//   NaN/Inf grad; otherwise opt.step(). Returns the loss and the global grad norm BEFORE clipping. The caller
//   sets the learning rate and zeroes the grads beforehand, and logs the returned values afterwards.
// write_loss_plot_if_logged: write_loss_svg(log, svg) with the given title, keys and log-y axis (nn/train_log.h).
//   Does nothing when svg is empty or the log file does not exist; a t2m::Error from plotting (an empty log:
//   nothing trained in this call) is swallowed, so the plot never fails a run.
#pragma once
#include <string>
#include <vector>

#include "autograd/variable.h"
#include "nn/optim.h"

namespace t2m::nn {

struct StepStats {
  double loss = 0.0;       // loss.item()
  double grad_norm = 0.0;  // global L2 norm of the grads before clipping
};

StepStats backward_clip_step(const ag::Variable& loss, const NamedParams& params, Optimizer& opt,
                             double max_norm = 1.0);

void write_loss_plot_if_logged(const std::string& log, const std::string& svg, const std::string& title,
                               std::vector<std::string> keys = {"loss"}, bool log_y = true);

}  // namespace t2m::nn
