// bench_tensor_ops.cpp — throughput of the tensor layer's memory-bound kernels: contiguous and broadcast
// elementwise ops, a transcendental, the strided copy behind contiguous(), row and column reductions,
// index_select (embedding lookup) and the RNG. Bytes/s counts bytes read + written once.
// Run: build-*/bench_tensor_ops [--benchmark_filter=...]; thread count from OMP_NUM_THREADS.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <vector>

#include "tensor/ops.h"
#include "tensor/rng.h"

using namespace t2m;

namespace {

Tensor filled(const Shape& s, uint64_t seed) {
  Generator g(seed);
  return rand_uniform(s, g, -1.0, 1.0);
}

void BM_AddContiguous(benchmark::State& st) {
  const int64_t n = st.range(0);
  Tensor a = filled({n}, 1), b = filled({n}, 2);
  for (auto _ : st) benchmark::DoNotOptimize(add(a, b));
  st.SetBytesProcessed(st.iterations() * n * 12);
}
BENCHMARK(BM_AddContiguous)->Arg(1 << 14)->Arg(1 << 20)->Arg(1 << 23);

void BM_AddTiny(benchmark::State& st) {  // per-op overhead: shape checks, allocation from the cache, dispatch
  Tensor a = filled({64}, 1), b = filled({64}, 2);
  for (auto _ : st) benchmark::DoNotOptimize(add(a, b));
}
BENCHMARK(BM_AddTiny);

void BM_SumTiny(benchmark::State& st) {
  Tensor a = filled({8, 64}, 1);
  for (auto _ : st) benchmark::DoNotOptimize(sum(a, {1}));
}
BENCHMARK(BM_SumTiny);

void BM_AddBroadcastRow(benchmark::State& st) {  // [rows, 512] + [512] (bias add)
  const int64_t rows = st.range(0);
  Tensor a = filled({rows, 512}, 1), b = filled({512}, 2);
  for (auto _ : st) benchmark::DoNotOptimize(add(a, b));
  st.SetBytesProcessed(st.iterations() * rows * 512 * 8);
}
BENCHMARK(BM_AddBroadcastRow)->Arg(2048);

void BM_MulTransposed(benchmark::State& st) {  // strided operand
  Tensor a = filled({1024, 1024}, 1), b = filled({1024, 1024}, 2).transpose(0, 1);
  for (auto _ : st) benchmark::DoNotOptimize(mul(a, b));
  st.SetBytesProcessed(st.iterations() * 1024 * 1024 * 12);
}
BENCHMARK(BM_MulTransposed);

void BM_Exp(benchmark::State& st) {
  Tensor a = filled({1 << 20}, 1);
  for (auto _ : st) benchmark::DoNotOptimize(exp(a));
  st.SetItemsProcessed(st.iterations() * (1 << 20));
}
BENCHMARK(BM_Exp);

void BM_ContiguousOfTranspose(benchmark::State& st) {
  Tensor a = filled({2048, 2048}, 1).transpose(0, 1);
  for (auto _ : st) benchmark::DoNotOptimize(a.contiguous());
  st.SetBytesProcessed(st.iterations() * 2048 * 2048 * 8);
}
BENCHMARK(BM_ContiguousOfTranspose);

void BM_SumRows(benchmark::State& st) {  // reduce the contiguous last dim
  Tensor a = filled({4096, 512}, 1);
  for (auto _ : st) benchmark::DoNotOptimize(sum(a, {1}));
  st.SetBytesProcessed(st.iterations() * 4096 * 512 * 4);
}
BENCHMARK(BM_SumRows);

void BM_SumCols(benchmark::State& st) {  // bias gradient: reduce the leading dim (column pass)
  Tensor a = filled({4096, 512}, 1);
  for (auto _ : st) benchmark::DoNotOptimize(sum(a, {0}));
  st.SetBytesProcessed(st.iterations() * 4096 * 512 * 4);
}
BENCHMARK(BM_SumCols);

void BM_SumAll(benchmark::State& st) {
  Tensor a = filled({1 << 22}, 1);
  for (auto _ : st) benchmark::DoNotOptimize(sum(a));
  st.SetBytesProcessed(st.iterations() * (1 << 22) * 4);
}
BENCHMARK(BM_SumAll);

void BM_IndexSelectEmbedding(benchmark::State& st) {  // 8192 tokens from a [32000, 512] table
  Tensor table = filled({32000, 512}, 1);
  Generator g(3);
  Tensor idx = randint({8192}, g, 0, 32000);
  for (auto _ : st) benchmark::DoNotOptimize(index_select(table, 0, idx));
  st.SetBytesProcessed(st.iterations() * 8192 * 512 * 8);
}
BENCHMARK(BM_IndexSelectEmbedding);

void BM_RandNormal(benchmark::State& st) {
  Generator g(4);
  for (auto _ : st) benchmark::DoNotOptimize(rand_normal({1 << 20}, g));
  st.SetItemsProcessed(st.iterations() * (1 << 20));
}
BENCHMARK(BM_RandNormal);

// The Philox words behind every draw (dropout masks, rand_*): 1024 blocks (4096 words, an L1-resident buffer) per
// call, one thread.
void BM_philox_blocks(benchmark::State& st) {
  std::vector<uint32_t> w(4 * 1024);
  uint64_t c = 0;
  for (auto _ : st) {
    philox4x32_blocks(7, c, 1024, w.data());
    c += 1024;
    benchmark::DoNotOptimize(w.data());
  }
  st.SetItemsProcessed(st.iterations() * 4 * 1024);  // words
}
BENCHMARK(BM_philox_blocks);

}  // namespace

BENCHMARK_MAIN();
