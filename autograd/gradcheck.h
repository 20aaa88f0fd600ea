// gradcheck.h — checks an autograd function's analytic gradients against central finite differences in float64.
//
// For inputs x_0..x_{n-1} (converted to fresh contiguous float64 leaves that require grad) and fixed random
// weights W of out's shape, L(x) = sum(f(x) * W). The analytic gradient is f(x).backward(W); the numeric one is
// (L(x + eps e_j) - L(x - eps e_j)) / (2 eps) for every element j of every input. An element fails when
// |analytic - numeric| > atol + rtol * |numeric|. The result names the worst element (largest error relative to
// its tolerance). Cost: 2 forward passes per input element, so keep inputs small (tens of elements).
// Errors (t2m::Error): no inputs, an int64 input, f returning an undefined or non-float64 Variable.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "autograd/variable.h"

namespace t2m::ag {

struct GradcheckOptions {
  double eps = 1e-6;
  double atol = 1e-6;
  double rtol = 1e-4;
  uint64_t seed = 0x5eed;  // for the weights W
};

struct GradcheckResult {
  bool ok = true;
  double max_abs_err = 0.0;  // over all elements of all inputs
  double max_rel_err = 0.0;  // |a - n| / max(|n|, 1e-12), over all elements
  int64_t input = -1;        // worst element: which input, which flat (row-major) index, both gradients
  int64_t element = -1;
  double analytic = 0.0;
  double numeric = 0.0;
  std::string message;       // one line: "gradcheck ok ..." or "gradcheck FAILED: input 1 element 4 ..."
};

using GradcheckFn = std::function<Variable(const std::vector<Variable>&)>;

GradcheckResult gradcheck(const GradcheckFn& f, const std::vector<Tensor>& inputs, const GradcheckOptions& opt = {});

}  // namespace t2m::ag
