// train_step.cpp — backward, clip, NaN guard, step in the trainers' order; the plot behind an existence check.
#include "nn/train_step.h"

#include <cmath>
#include <filesystem>
#include <utility>

#include "nn/grad_utils.h"
#include "nn/train_log.h"
#include "tensor/tensor.h"

namespace t2m::nn {

StepStats backward_clip_step(const ag::Variable& loss, const NamedParams& params, Optimizer& opt, double max_norm) {
  loss.backward();
  StepStats s;
  s.loss = loss.item();
  s.grad_norm = clip_grad_norm(params, max_norm);
  if (!std::isfinite(s.grad_norm)) check_finite_grads(params);  // throws naming the parameter
  opt.step();
  return s;
}

void write_loss_plot_if_logged(const std::string& log, const std::string& svg, const std::string& title,
                               std::vector<std::string> keys, bool log_y) {
  if (svg.empty() || !std::filesystem::exists(log)) return;
  SvgPlotOptions so;
  so.keys = std::move(keys);
  so.log_y = log_y;
  so.title = title;
  try {
    write_loss_svg(log, svg, so);
  } catch (const Error&) {  // an empty log (nothing trained in this call) has nothing to plot
  }
}

}  // namespace t2m::nn
