// test_rng.cpp — Philox4x32-10 known answers (Random123 kat_vectors), the documented counter layout, determinism
// across thread counts and chunkings, statistical sanity on 1e5 samples, randperm, errors.
#include <algorithm>
#include <cmath>

#include "test_tensor_util.h"
#include "tensor/parallel.h"
#include "tensor/rng.h"

using namespace t2m;
using namespace t2m::testing;

TEST(Rng, PhiloxKnownAnswers) {
  struct Kat {
    uint32_t ctr[4], key[2], out[4];
  };
  const Kat kats[] = {
      {{0, 0, 0, 0}, {0, 0}, {0x6627e8d5, 0xe169c58d, 0xbc57ac4c, 0x9b00dbd8}},
      {{0xffffffff, 0xffffffff, 0xffffffff, 0xffffffff},
       {0xffffffff, 0xffffffff},
       {0x408f276d, 0x41c83b0e, 0xa20bc7c6, 0x6d5451fd}},
      {{0x243f6a88, 0x85a308d3, 0x13198a2e, 0x03707344},
       {0xa4093822, 0x299f31d0},
       {0xd16cfe09, 0x94fdcceb, 0x5001e420, 0x24126ea1}},
  };
  for (const Kat& k : kats) {
    uint32_t out[4];
    philox4x32_block(k.ctr, k.key, out);
    for (int i = 0; i < 4; ++i) EXPECT_EQ(out[i], k.out[i]) << i;
  }
  // The 64-bit wrapper maps (seed, counter) onto key / counter words as documented.
  uint32_t a[4], b[4];
  philox4x32(0, 0, a);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(a[i], kats[0].out[i]);
  philox4x32(0x299f31d0a4093822ull, 0x85a308d3243f6a88ull, a);
  const uint32_t ctr[4] = {0x243f6a88, 0x85a308d3, 0, 0}, key[2] = {0xa4093822, 0x299f31d0};
  philox4x32_block(ctr, key, b);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(a[i], b[i]);
}

TEST(Rng, CounterLayoutAndAdvance) {
  Generator g(1234);
  g.advance(10);
  Tensor u = rand_uniform({9}, g, 0.0, 1.0, DType::f32);
  EXPECT_EQ(g.offset(), 10u + 3u);  // ceil(9 / 4) counters
  for (int64_t i = 0; i < 9; ++i) {
    uint32_t w[4];
    philox4x32(1234, 10 + i / 4, w);
    EXPECT_EQ(u.at({i}), (double)(w[i % 4] >> 8) / 16777216.0) << i;
  }
  Tensor d = rand_uniform({3}, g, 0.0, 1.0, DType::f64);
  EXPECT_EQ(g.offset(), 13u + 2u);
  Tensor r = randint({5}, g, 0, 100);
  EXPECT_EQ(g.offset(), 15u + 3u);
  randperm(6, g);  // 5 swaps -> 3 counters
  EXPECT_EQ(g.offset(), 18u + 3u);
  // Same state, same numbers; a different seed, different numbers.
  Generator h(1234);
  h.set_state(1234, 10);
  expect_values(rand_uniform({9}, h), {9}, raw_values(u), 0);
  Generator k(1235);
  k.advance(10);
  EXPECT_NE(raw_values(rand_uniform({9}, k)), raw_values(u));
}

TEST(Rng, ChunkingAndThreadCountInvariant) {
  const int saved = get_num_threads();
  const Shape big = {300, 400};  // 120000 values: above kParallelGrain, so draws run multi-threaded
  std::vector<double> res[2][5];
  for (int t : {1, 2}) {
    set_num_threads(t);
    Generator g(77);
    res[t - 1][0] = raw_values(rand_uniform(big, g));
    res[t - 1][1] = raw_values(rand_normal(big, g, 0, 1, DType::f64));
    res[t - 1][2] = raw_values(rand_bernoulli(big, g, 0.25));
    res[t - 1][3] = raw_values(randint(big, g, -5, 5));
    res[t - 1][4] = raw_values(rand_normal(big, g));
  }
  set_num_threads(saved);
  for (int k = 0; k < 5; ++k) EXPECT_EQ(res[0][k], res[1][k]) << k;
  // Two draws of 8 (counter aligned) equal one draw of 16.
  Generator g1(5), g2(5);
  const auto whole = raw_values(rand_normal({16}, g1));
  auto first = raw_values(rand_normal({8}, g2));
  const auto second = raw_values(rand_normal({8}, g2));
  first.insert(first.end(), second.begin(), second.end());
  EXPECT_EQ(whole, first);
}

namespace {
void mean_var(const Tensor& t, double& m, double& v) {
  const auto x = raw_values(t);
  m = 0;
  for (double a : x) m += a;
  m /= (double)x.size();
  v = 0;
  for (double a : x) v += (a - m) * (a - m);
  v /= (double)(x.size() - 1);
}
}  // namespace

TEST(Rng, Statistics) {
  Generator g(2024);
  double m, v;
  for (DType dt : {DType::f32, DType::f64}) {
    Tensor u = rand_uniform({100000}, g, -1.0, 3.0, dt);
    mean_var(u, m, v);
    EXPECT_NEAR(m, 1.0, 0.02);
    EXPECT_NEAR(v, 16.0 / 12.0, 0.02);
    const auto x = raw_values(u);
    EXPECT_GE(*std::min_element(x.begin(), x.end()), -1.0);
    EXPECT_LT(*std::max_element(x.begin(), x.end()), 3.0);
    Tensor n = rand_normal({100000}, g, 2.0, 0.5, dt);
    mean_var(n, m, v);
    EXPECT_NEAR(m, 2.0, 0.01);
    EXPECT_NEAR(v, 0.25, 0.006);
    // Tails: about 4.55% beyond 2 sigma.
    int64_t tail = 0;
    for (double a : raw_values(n)) tail += std::abs(a - 2.0) > 1.0;
    EXPECT_NEAR((double)tail / 1e5, 0.0455, 0.004);
    Tensor b = rand_bernoulli({100000}, g, 0.3, dt);
    mean_var(b, m, v);
    EXPECT_NEAR(m, 0.3, 0.007);
    for (double a : raw_values(b)) ASSERT_TRUE(a == 0.0 || a == 1.0);
  }
  // Neighbouring normals are uncorrelated (the two Box-Muller outputs of a pair).
  const auto z = raw_values(rand_normal({100000}, g));
  double c = 0;
  for (size_t i = 0; i + 1 < z.size(); i += 2) c += z[i] * z[i + 1];
  EXPECT_NEAR(c / 50000.0, 0.0, 0.02);
  Tensor r = randint({100000}, g, -3, 7);
  std::vector<int64_t> hist(10, 0);
  for (double a : raw_values(r)) {
    ASSERT_GE(a, -3);
    ASSERT_LT(a, 7);
    ++hist[(int)a + 3];
  }
  for (int64_t h : hist) EXPECT_NEAR((double)h, 10000.0, 500.0);
  EXPECT_EQ(rand_bernoulli({1000}, g, 0.0).to_vector<float>(), std::vector<float>(1000, 0.0f));
  EXPECT_EQ(rand_bernoulli({1000}, g, 1.0).to_vector<float>(), std::vector<float>(1000, 1.0f));
}

TEST(Rng, Randperm) {
  Generator g(9);
  for (int64_t n : {0, 1, 2, 7, 1000}) {
    auto p = randperm(n, g);
    ASSERT_EQ((int64_t)p.size(), n);
    auto s = p;
    std::sort(s.begin(), s.end());
    for (int64_t i = 0; i < n; ++i) ASSERT_EQ(s[i], i);
  }
  Generator a(1), b(1), c(2);
  const auto pa = randperm(50, a);
  EXPECT_EQ(pa, randperm(50, b));
  EXPECT_NE(pa, randperm(50, c));
  // Each position is roughly uniform: position 0 of randperm(4) over 8000 draws.
  std::vector<int> cnt(4, 0);
  Generator d(3);
  for (int i = 0; i < 8000; ++i) ++cnt[randperm(4, d)[0]];
  for (int x : cnt) EXPECT_NEAR(x, 2000, 200);
}

TEST(Rng, Errors) {
  Generator g(0);
  expect_error([&] { rand_uniform({2}, g, 1.0, 0.0); }, {"rand_uniform", "lo"});
  expect_error([&] { rand_normal({2}, g, 0.0, -1.0); }, {"rand_normal", "std"});
  expect_error([&] { rand_bernoulli({2}, g, 1.5); }, {"rand_bernoulli", "1.5"});
  expect_error([&] { randint({2}, g, 3, 3); }, {"randint", "3"});
  expect_error([&] { randperm(-1, g); }, {"randperm", "-1"});
  expect_error([&] { rand_uniform({2}, g, 0, 1, DType::i64); }, {"rand_uniform", "i64"});
  expect_error([&] { rand_normal({-1}, g); }, {"empty", "[-1]"});
  EXPECT_EQ(rand_uniform({0, 3}, g).numel(), 0);
}
