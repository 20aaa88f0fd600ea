// gemm_bench.cpp — shapes, operands and the timing loop behind `t2m bench` and bench_gemm.
#include "bench/lib/gemm_bench.h"
#include "bench/lib/fma_peak.h"
#include "bench/lib/step_timer.h"

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <ctime>
#include <random>
#include <sstream>

#include "tensor/gemm.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"

namespace t2m::bench {

double peak_gflops_per_core() {
  static const double peak = fma_peak_gflops(1);
  return peak;
}

namespace {

using RowMatF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

const int64_t kMicro[5][3] = {{256, 256, 256}, {1024, 1024, 1024}, {1000, 1000, 1000}, {4096, 512, 512},
                              {4096, 2048, 512}};

const char* variant_name(bool ta, bool tb) { return ta ? (tb ? "tt" : "tn") : (tb ? "nt" : "nn"); }

}  // namespace

std::string GemmShape::name() const {
  std::string s = std::to_string(M) + "x" + std::to_string(N) + "x" + std::to_string(K);
  if (trans_a || trans_b) s += std::string(":") + variant_name(trans_a, trans_b);
  return s;
}

std::vector<GemmShape> gemm_micro_shapes() {
  std::vector<GemmShape> v;
  for (const auto& s : kMicro) v.push_back({s[0], s[1], s[2], false, false});
  return v;
}

std::vector<GemmShape> gemm_all_shapes() {
  std::vector<GemmShape> v;
  for (const auto& s : kMicro)
    for (auto [ta, tb] : {std::pair{false, false}, std::pair{true, false}, std::pair{false, true}})
      v.push_back({s[0], s[1], s[2], ta, tb});
  return v;
}

std::vector<GemmShape> parse_gemm_shapes(const std::string& spec) {
  if (spec == "micro") return gemm_micro_shapes();
  if (spec == "all") return gemm_all_shapes();
  std::vector<GemmShape> v;
  std::stringstream ss(spec);
  std::string item;
  while (std::getline(ss, item, ',')) {
    GemmShape s;
    std::string dims = item, var = "nn";
    if (const auto colon = item.find(':'); colon != std::string::npos) {
      dims = item.substr(0, colon);
      var = item.substr(colon + 1);
    }
    long long m = 0, n = 0, k = 0;
    char x1 = 0, x2 = 0;
    std::istringstream is(dims);
    if (!(is >> m >> x1 >> n >> x2 >> k) || x1 != 'x' || x2 != 'x' || !is.eof() || m <= 0 || n <= 0 || k <= 0)
      throw Error("bench: bad shape '" + item + "' (expected MxNxK[:nn|tn|nt|tt] with positive sizes, or micro/all)");
    if (var != "nn" && var != "tn" && var != "nt" && var != "tt")
      throw Error("bench: bad transpose variant '" + var + "' in '" + item + "' (expected nn, tn, nt or tt)");
    s.M = m, s.N = n, s.K = k;
    s.trans_a = var[0] == 't';
    s.trans_b = var[1] == 't';
    v.push_back(s);
  }
  if (v.empty()) throw Error("bench: empty shape list '" + spec + "'");
  return v;
}

GemmOperands::GemmOperands(const GemmShape& s)
    : shape(s), A(size_t(s.M * s.K)), B(size_t(s.K * s.N)), C(size_t(s.M * s.N), 0.0f) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (auto& x : A) x = u(rng);
  for (auto& x : B) x = u(rng);
}

void GemmOperands::run() {
  const auto& s = shape;
  gemm(s.trans_a, s.trans_b, s.M, s.N, s.K, 1.0f, A.data(), s.trans_a ? s.M : s.K, B.data(), s.trans_b ? s.K : s.N,
       0.0f, C.data(), s.N);
}

void GemmOperands::run_eigen() {
  const auto& s = shape;
  Eigen::Map<const RowMatF> a(A.data(), s.trans_a ? s.K : s.M, s.trans_a ? s.M : s.K);
  Eigen::Map<const RowMatF> b(B.data(), s.trans_b ? s.N : s.K, s.trans_b ? s.K : s.N);
  Eigen::Map<RowMatF> c(C.data(), s.M, s.N);
  if (!s.trans_a && !s.trans_b) c.noalias() = a * b;
  else if (s.trans_a && !s.trans_b) c.noalias() = a.transpose() * b;
  else if (!s.trans_a && s.trans_b) c.noalias() = a * b.transpose();
  else c.noalias() = a.transpose() * b.transpose();
}

void set_eigen_threads(int n) { Eigen::setNbThreads(n); }

namespace {

template <typename F>
GemmTiming time_loop(const GemmShape& s, int threads, int reps, int warmup, F&& fn) {
  if (reps < 1) throw Error("bench: reps must be >= 1, got " + std::to_string(reps));
  for (int i = 0; i < warmup; ++i) fn();
  std::vector<double> ms;
  ms.reserve(size_t(reps));
  double best_cpu_s = 1e300;
  for (int i = 0; i < reps; ++i) {
    const double c0 = process_cpu_seconds();
    const auto t0 = std::chrono::steady_clock::now();
    fn();
    const auto t1 = std::chrono::steady_clock::now();
    best_cpu_s = std::min(best_cpu_s, process_cpu_seconds() - c0);
    ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  GemmTiming t;
  const size_t n = ms.size();
  t.median_ms = n % 2 ? ms[n / 2] : 0.5 * (ms[n / 2 - 1] + ms[n / 2]);
  t.best_ms = ms.front();
  t.gflops = s.flops() / (t.median_ms * 1e6);
  t.pct_peak = 100.0 * t.gflops / (peak_gflops_per_core() * threads);
  t.cpu_gflops = best_cpu_s > 0 ? s.flops() / best_cpu_s * 1e-9 * threads : 0.0;
  return t;
}

}  // namespace

GemmTiming time_gemm(GemmOperands& ops, int threads, int reps, int warmup) {
  set_num_threads(threads);
  return time_loop(ops.shape, threads, reps, warmup, [&] { ops.run(); });
}

GemmTiming time_eigen(GemmOperands& ops, int threads, int reps, int warmup) {
  set_eigen_threads(threads);
  return time_loop(ops.shape, threads, reps, warmup, [&] { ops.run_eigen(); });
}

}  // namespace t2m::bench
