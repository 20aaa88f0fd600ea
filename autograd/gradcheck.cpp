// gradcheck.cpp — central finite differences in float64 versus Variable::backward.
#include "autograd/gradcheck.h"

#include <cmath>
#include <cstdio>

#include "autograd/no_grad.h"

namespace t2m::ag {

namespace {

// Deterministic weights in [-1, 1) from a 64-bit mix of (seed, i); independent of any other RNG state.
double weight(uint64_t seed, uint64_t i) {
  uint64_t z = seed * 0x9E3779B97F4A7C15ull + (i + 1) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return (double)(z >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

Tensor check_output(const Variable& out) {
  if (!out.defined()) throw Error("gradcheck: the function returned an undefined Variable");
  if (out.dtype() != DType::f64)
    throw Error(std::string("gradcheck: the function returned ") + dtype_name(out.dtype()) +
                " for float64 inputs; it must stay in float64");
  return out.data();
}

// L = sum(out * W) in double, in row-major order.
double weighted_sum(const Tensor& out, const std::vector<double>& w) {
  std::vector<double> v = out.to_vector<double>();
  double s = 0.0;
  for (size_t i = 0; i < v.size(); ++i) s += v[i] * w[i];
  return s;
}

}  // namespace

GradcheckResult gradcheck(const GradcheckFn& f, const std::vector<Tensor>& inputs, const GradcheckOptions& opt) {
  if (inputs.empty()) throw Error("gradcheck: no inputs");
  std::vector<Variable> leaves;
  for (size_t i = 0; i < inputs.size(); ++i) {
    if (inputs[i].dtype() == DType::i64)
      throw Error("gradcheck: input " + std::to_string(i) + " is int64; capture index tensors in the function");
    std::string name = "x";
    name += std::to_string(i);  // (not "x" + to_string: GCC 12 -Wrestrict false positive)
    leaves.push_back(Variable(inputs[i].to(DType::f64).clone(), true, name));
  }

  // Analytic: out.backward(W) is the gradient of sum(out * W).
  Variable out = f(leaves);
  Tensor o = check_output(out);
  std::vector<double> w((size_t)o.numel());
  for (size_t i = 0; i < w.size(); ++i) w[i] = weight(opt.seed, i);
  if (out.requires_grad()) out.backward(Tensor::from_vector(w, o.shape()));

  GradcheckResult r;
  double worst_ratio = -1.0;
  NoGradGuard no_grad;
  for (size_t i = 0; i < leaves.size(); ++i) {
    Tensor x = leaves[i].data();  // contiguous float64: perturb in place
    double* px = x.data<double>();
    const Tensor& gi = leaves[i].grad();
    std::vector<double> analytic = gi.defined() ? gi.to_vector<double>() : std::vector<double>((size_t)x.numel(), 0.0);
    for (int64_t j = 0; j < x.numel(); ++j) {
      double x0 = px[j];
      px[j] = x0 + opt.eps;
      double lp = weighted_sum(check_output(f(leaves)), w);
      px[j] = x0 - opt.eps;
      double lm = weighted_sum(check_output(f(leaves)), w);
      px[j] = x0;
      double numeric = (lp - lm) / (2.0 * opt.eps);
      double a = analytic[(size_t)j];
      double err = std::fabs(a - numeric);
      if (std::isnan(a) != std::isnan(numeric)) err = INFINITY;
      double tol = opt.atol + opt.rtol * std::fabs(numeric);
      r.max_abs_err = std::fmax(r.max_abs_err, err);
      r.max_rel_err = std::fmax(r.max_rel_err, err / std::fmax(std::fabs(numeric), 1e-12));
      double ratio = err / tol;
      if (ratio > worst_ratio || std::isnan(ratio)) {
        worst_ratio = std::isnan(ratio) ? INFINITY : ratio;
        r.input = (int64_t)i;
        r.element = j;
        r.analytic = a;
        r.numeric = numeric;
      }
      if (!(err <= tol)) r.ok = false;
    }
  }
  char buf[256];
  std::snprintf(buf, sizeof buf, "gradcheck %s: max abs err %.3g, max rel err %.3g; worst input %lld element %lld "
                "(analytic %.9g, numeric %.9g)", r.ok ? "ok" : "FAILED", r.max_abs_err, r.max_rel_err,
                (long long)r.input, (long long)r.element, r.analytic, r.numeric);
  r.message = buf;
  return r;
}

}  // namespace t2m::ag
