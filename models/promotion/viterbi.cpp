// viterbi.cpp — dynamic programming over the lattice: delta_k(j) = e[k][j] + max_i (delta_{k-1}(i) + a[k-1][i][j]).
#include "models/promotion/viterbi.h"

#include <cmath>
#include <string>

namespace t2m::promotion {

namespace {

bool is_float(const Tensor& t) { return t.dtype() == DType::f32 || t.dtype() == DType::f64; }

// Checks shapes and returns (emission, transition) as contiguous double vectors.
void read_lattice(const Tensor& emission, const Tensor& transition, int* K, int* N, std::vector<double>* e,
                  std::vector<double>* a) {
  if (!emission.defined() || emission.dim() != 2 || !is_float(emission) || emission.size(0) < 1 ||
      emission.size(1) < 1)
    throw Error("viterbi: emission must be a float (K, N) tensor with K, N >= 1, got " +
                (emission.defined() ? shape_str(emission.shape()) + " " + dtype_name(emission.dtype())
                                    : std::string("undefined")));
  *K = (int)emission.size(0);
  *N = (int)emission.size(1);
  const Shape want = {*K - 1, *N, *N};
  if (!transition.defined()) {
    if (*K != 1) throw Error("viterbi: transition is undefined but K = " + std::to_string(*K) + " > 1");
  } else if (!is_float(transition) || transition.shape() != want) {
    throw Error("viterbi: transition must be a float " + shape_str(want) + " tensor for emission " +
                shape_str(emission.shape()) + ", got " + shape_str(transition.shape()) + " " +
                dtype_name(transition.dtype()));
  }
  *e = emission.to(DType::f64).contiguous().to_vector<double>();
  if (transition.defined() && transition.numel() > 0) *a = transition.to(DType::f64).contiguous().to_vector<double>();
  else a->clear();
  for (double v : *e)
    if (!std::isfinite(v)) throw Error("viterbi: non-finite emission score " + std::to_string(v));
  for (double v : *a)
    if (!std::isfinite(v)) throw Error("viterbi: non-finite transition score " + std::to_string(v));
}

}  // namespace

// PRO-Motion Sec 3.3: argmax_G E^1_{g_1} prod_i E^i_{g_i} A^i_{g_{i-1} g_i}, in log space.
ViterbiPath viterbi_decode(const Tensor& emission, const Tensor& transition) {
  int K = 0, N = 0;
  std::vector<double> e, a;
  read_lattice(emission, transition, &K, &N, &e, &a);
  std::vector<double> delta(e.begin(), e.begin() + N), next(N);
  std::vector<int> back((size_t)K * N, 0);
  for (int k = 1; k < K; ++k) {
    const double* ak = a.data() + (size_t)(k - 1) * N * N;
    for (int j = 0; j < N; ++j) {
      int best = 0;
      double bv = delta[0] + ak[j];
      for (int i = 1; i < N; ++i) {
        const double v = delta[i] + ak[(size_t)i * N + j];
        if (v > bv) bv = v, best = i;  // strict: the smallest index wins ties
      }
      back[(size_t)k * N + j] = best;
      next[j] = bv + e[(size_t)k * N + j];
    }
    delta.swap(next);
  }
  ViterbiPath r;
  r.path.assign(K, 0);
  int last = 0;
  for (int j = 1; j < N; ++j)
    if (delta[j] > delta[last]) last = j;
  r.path[K - 1] = last;
  for (int k = K - 1; k > 0; --k) r.path[k - 1] = back[(size_t)k * N + r.path[k]];
  r.score = viterbi_path_score(emission, transition, r.path);
  return r;
}

double viterbi_path_score(const Tensor& emission, const Tensor& transition, const std::vector<int>& path) {
  int K = 0, N = 0;
  std::vector<double> e, a;
  read_lattice(emission, transition, &K, &N, &e, &a);
  if ((int)path.size() != K) throw Error("viterbi: path of length " + std::to_string(path.size()) + " for K = " +
                                         std::to_string(K));
  for (int g : path)
    if (g < 0 || g >= N) throw Error("viterbi: path index " + std::to_string(g) + " outside [0, " +
                                     std::to_string(N) + ")");
  double s = e[path[0]];
  for (int k = 1; k < K; ++k)
    s += a[(size_t)(k - 1) * N * N + (size_t)path[k - 1] * N + path[k]] + e[(size_t)k * N + path[k]];
  return s;
}

}  // namespace t2m::promotion
