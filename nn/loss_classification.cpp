// loss_classification.cpp — cross-entropy from log_softmax + gather (ignored targets routed to class 0 and
// weighted 0), label smoothing through the mean log-probability; accuracy by counting strictly larger logits.
#include "nn/loss_classification.h"

#include <string>
#include <vector>

#include "autograd/ops_elementwise.h"
#include "autograd/ops_index.h"
#include "autograd/ops_reduce.h"
#include "autograd/ops_softmax.h"
#include "autograd/ops_unary.h"
#include "nn/loss_reduce.h"

namespace t2m::nn {
namespace {

struct CheckedTargets {
  Tensor index;  // int64 (..., 1): target, or 0 where ignored
  Tensor valid;  // f64 (...): 1 where not ignored
  int64_t n_valid = 0;
};

CheckedTargets check_targets(const Tensor& logits, const Tensor& targets, int64_t ignore_index, const char* op) {
  if (!logits.defined() || !targets.defined()) throw Error(std::string(op) + ": logits or targets are undefined");
  if (logits.dim() == 0 || logits.size(-1) == 0)
    throw Error(std::string(op) + ": logits must be (..., C) with C >= 1, got " + shape_str(logits.shape()));
  if (logits.dtype() != DType::f32 && logits.dtype() != DType::f64)
    throw Error(std::string(op) + ": logits must be float, got " + dtype_name(logits.dtype()));
  Shape want(logits.shape().begin(), logits.shape().end() - 1);
  if (targets.dtype() != DType::i64 || targets.shape() != want)
    throw Error(std::string(op) + ": targets must be int64 " + shape_str(want) + " for logits " +
                shape_str(logits.shape()) + ", got " + dtype_name(targets.dtype()) + " " + shape_str(targets.shape()));
  const int64_t C = logits.size(-1);
  std::vector<int64_t> y = targets.to_vector<int64_t>();
  std::vector<double> valid(y.size(), 0.0);
  CheckedTargets r;
  for (size_t n = 0; n < y.size(); ++n) {
    if (y[n] == ignore_index) {
      y[n] = 0;
      continue;
    }
    if (y[n] < 0 || y[n] >= C)
      throw Error(std::string(op) + ": target " + std::to_string(y[n]) + " at flat position " + std::to_string(n) +
                  " is outside [0, " + std::to_string(C) + ") and is not ignore_index " + std::to_string(ignore_index));
    valid[n] = 1.0;
    ++r.n_valid;
  }
  Shape ishape = want;
  ishape.push_back(1);
  r.index = Tensor::from_vector(y, ishape);
  r.valid = Tensor::from_vector(valid, want);
  return r;
}

}  // namespace

// logits (..., C), targets (...) -> scalar
ag::Variable cross_entropy(const ag::Variable& logits, const Tensor& targets, const CrossEntropyOptions& opt) {
  const char* op = "cross_entropy";
  if (!(opt.label_smoothing >= 0.0 && opt.label_smoothing <= 1.0))
    throw Error(std::string(op) + ": label_smoothing must be in [0, 1], got " + std::to_string(opt.label_smoothing));
  if (!logits.defined()) throw Error(std::string(op) + ": logits are undefined");
  const CheckedTargets ct = check_targets(logits.data(), targets, opt.ignore_index, op);
  ag::Variable logp = ag::log_softmax(logits, -1);                 // (..., C)
  ag::Variable nll = ag::neg(ag::gather(logp, -1, ct.index).squeeze(-1));  // (...)
  ag::Variable per = nll;
  if (opt.label_smoothing > 0.0) {
    ag::Variable smooth = ag::neg(ag::mean(logp, {-1}));  // (1/C) Σ_c −log p_c
    per = ag::add(ag::mul(nll, 1.0 - opt.label_smoothing), ag::mul(smooth, opt.label_smoothing));
  }
  return weighted_mean(per, ct.valid, op);  // mean over non-ignored positions; all ignored -> 0
}

double accuracy(const Tensor& logits, const Tensor& targets, int64_t ignore_index, int64_t k) {
  const char* op = "accuracy";
  if (k < 1) throw Error(std::string(op) + ": k must be >= 1, got " + std::to_string(k));
  const CheckedTargets ct = check_targets(logits, targets, ignore_index, op);
  if (ct.n_valid == 0) return 0.0;
  const int64_t C = logits.size(-1);
  const std::vector<double> z = logits.to(DType::f64).contiguous().to_vector<double>();
  const std::vector<int64_t> y = ct.index.to_vector<int64_t>();
  const std::vector<double> valid = ct.valid.to_vector<double>();
  int64_t correct = 0;
  for (size_t n = 0; n < y.size(); ++n) {
    if (valid[n] == 0.0) continue;
    const double* row = z.data() + n * C;
    int64_t greater = 0;
    for (int64_t c = 0; c < C; ++c) greater += row[c] > row[y[n]] ? 1 : 0;
    correct += greater < k ? 1 : 0;
  }
  return (double)correct / (double)ct.n_valid;
}

}  // namespace t2m::nn
