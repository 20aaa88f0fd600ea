// grad_utils.cpp — fixed-block double accumulation (parallel, deterministic); scan for non-finite values.
#include "nn/grad_utils.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "tensor/ops.h"
#include "tensor/parallel.h"

namespace t2m::nn {

namespace {

const Tensor* grad_ptr(const std::pair<std::string, ag::Variable>& kv, const char* op) {
  const auto& impl = kv.second.impl();
  if (!impl || !impl->grad.defined()) return nullptr;
  const Tensor& g = impl->current_grad();
  if (g.dtype() != DType::f32 && g.dtype() != DType::f64)
    throw Error(std::string(op) + ": grad of '" + kv.first + "' has dtype " + dtype_name(g.dtype()));
  return &g;
}

// Sum of squares, 16 interleaved double accumulators (four AVX2 vectors: enough independent chains to hide the
// add latency), combined in a fixed order, so deterministic.
template <typename T>
double sum_sq(const T* x, int64_t n) {
  double a[16] = {};
  int64_t i = 0;
  for (; i + 16 <= n; i += 16)
    for (int k = 0; k < 16; ++k) a[k] += (double)x[i + k] * (double)x[i + k];
  for (; i < n; ++i) a[i % 16] += (double)x[i] * (double)x[i];
  for (int w = 8; w >= 1; w /= 2)
    for (int k = 0; k < w; ++k) a[k] += a[k + w];
  return a[0];
}

template <typename T>
void count_nonfinite(const T* x, int64_t n, int64_t& count, int64_t& first, double& first_val) {
  for (int64_t i = 0; i < n; ++i)
    if (!std::isfinite(x[i])) {
      if (count == 0) { first = i; first_val = (double)x[i]; }
      ++count;
    }
}

}  // namespace

double grad_norm(const NamedParams& params) {
  // Fixed blocks of kBlock elements per tensor; block sums in parallel, then added in (tensor, block) order, so the
  // result depends neither on the thread count nor on scheduling.
  constexpr int64_t kBlock = 1 << 15;
  struct Block { const void* p; bool f64; int64_t n; };
  std::vector<Tensor> keep;
  std::vector<Block> blocks;
  for (const auto& kv : params) {
    const Tensor* g = grad_ptr(kv, "grad_norm");
    if (!g) continue;
    keep.push_back(g->contiguous());
    const Tensor& c = keep.back();
    const bool f64 = c.dtype() == DType::f64;
    for (int64_t o = 0; o < c.numel(); o += kBlock) {
      const void* p = f64 ? (const void*)(c.data<double>() + o) : (const void*)(c.data<float>() + o);
      blocks.push_back({p, f64, std::min(kBlock, c.numel() - o)});
    }
  }
  std::vector<double> part(blocks.size());
  const int64_t nb = (int64_t)blocks.size();
  const int nt = nb > 1 ? get_num_threads() : 1;
#pragma omp parallel for schedule(static) num_threads(nt) if (nt > 1)
  for (int64_t b = 0; b < nb; ++b)
    part[b] = blocks[b].f64 ? sum_sq((const double*)blocks[b].p, blocks[b].n) : sum_sq((const float*)blocks[b].p, blocks[b].n);
  double total = 0.0;
  for (double x : part) total += x;
  return std::sqrt(total);
}

double clip_grad_norm(const NamedParams& params, double max_norm) {
  if (!(max_norm > 0) || !std::isfinite(max_norm))
    throw Error("clip_grad_norm: max_norm must be finite and > 0, got " + std::to_string(max_norm));
  const double norm = grad_norm(params);
  if (!std::isfinite(norm) || norm <= max_norm) return norm;
  const double scale = max_norm / (norm + 1e-6);
  for (const auto& kv : params) {
    const Tensor* g = grad_ptr(kv, "clip_grad_norm");
    if (!g) continue;
    Tensor gt = *g;
    mul_(gt, scale);
  }
  return norm;
}

void check_finite_grads(const NamedParams& params) {
  int64_t affected = 0;
  std::string first_msg;
  for (const auto& kv : params) {
    const Tensor* g = grad_ptr(kv, "check_finite_grads");
    if (!g) continue;
    const Tensor c = g->contiguous();
    int64_t count = 0, first = -1;
    double val = 0.0;
    if (c.dtype() == DType::f64)
      count_nonfinite(c.data<double>(), c.numel(), count, first, val);
    else
      count_nonfinite(c.data<float>(), c.numel(), count, first, val);
    if (count == 0) continue;
    if (affected++ == 0) {
      std::ostringstream o;
      o << "check_finite_grads: parameter '" << kv.first << "' " << shape_str(c.shape()) << " has " << count
        << " non-finite gradient values of " << c.numel() << " (first at flat index " << first << ": " << val << ")";
      first_msg = o.str();
    }
  }
  if (affected) throw Error(first_msg + "; " + std::to_string(affected) + " parameter(s) affected");
}

}  // namespace t2m::nn
