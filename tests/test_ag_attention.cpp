// test_ag_attention.cpp — the differentiable attention and RoPE ops: values against naive double loops,
// float64 finite-difference gradchecks (plain, key mask, causal, cross, strided inputs), masked keys and future
// positions have no influence, RoPE scores depend only on the position difference, and bad use throws.
#include <gtest/gtest.h>

#include <cmath>

#include "autograd/gradcheck.h"
#include "autograd/ops_attention.h"
#include "autograd/ops_reduce.h"
#include "autograd/ops_shape.h"
#include "tensor/ops.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

using namespace t2m;
using t2m::testing::randn;
using t2m::testing::expect_error;

namespace {

// Naive softmax(q k^T / sqrt d) v with a key mask and a causal flag, per (b, h, i); all in double.
Tensor naive_attention(const Tensor& q, const Tensor& k, const Tensor& v, const Tensor& mask, bool causal) {
  const int64_t B = q.size(0), H = q.size(1), Tq = q.size(2), Tk = k.size(2), d = q.size(3);
  Tensor out = Tensor::zeros({B, H, Tq, d}, DType::f64);
  for (int64_t b = 0; b < B; ++b)
    for (int64_t h = 0; h < H; ++h)
      for (int64_t i = 0; i < Tq; ++i) {
        std::vector<double> p(Tk, 0.0);
        double mx = -INFINITY;
        for (int64_t j = 0; j < Tk; ++j) {
          const bool vis = (!mask.defined() || mask.at({b, j}) != 0.0) && (!causal || j <= i);
          if (!vis) continue;
          double acc = 0;
          for (int64_t c = 0; c < d; ++c) acc += q.at({b, h, i, c}) * k.at({b, h, j, c});
          p[j] = acc / std::sqrt((double)d);
          mx = std::max(mx, p[j]);
        }
        double z = 0;
        for (int64_t j = 0; j < Tk; ++j) {
          const bool vis = (!mask.defined() || mask.at({b, j}) != 0.0) && (!causal || j <= i);
          p[j] = vis ? std::exp(p[j] - mx) : 0.0;
          z += p[j];
        }
        for (int64_t c = 0; c < d; ++c) {
          double acc = 0;
          for (int64_t j = 0; j < Tk; ++j) acc += (z > 0 ? p[j] / z : 0.0) * v.at({b, h, j, c});
          out.set({b, h, i, c}, acc);
        }
      }
  return out;
}

Tensor naive_rope(const Tensor& x, int64_t pos0) {
  const int64_t T = x.size(-2), d = x.size(-1), N = x.numel() / (T * d);
  Tensor xc = x.contiguous().view({N, T, d});
  Tensor out = Tensor::zeros({N, T, d}, DType::f64);
  for (int64_t n = 0; n < N; ++n)
    for (int64_t t = 0; t < T; ++t)
      for (int64_t i = 0; i < d / 2; ++i) {
        const double ang = (double)(pos0 + t) * std::pow(10000.0, -2.0 * (double)i / (double)d);
        const double a = xc.at({n, t, i}), b = xc.at({n, t, i + d / 2});
        out.set({n, t, i}, a * std::cos(ang) - b * std::sin(ang));
        out.set({n, t, i + d / 2}, a * std::sin(ang) + b * std::cos(ang));
      }
  return out.view(x.shape());
}

Tensor key_mask(int64_t B, int64_t Tk) {  // batch b keeps the first Tk - b keys (at least one)
  Tensor m = Tensor::ones({B, Tk}, DType::f64);
  for (int64_t b = 0; b < B; ++b)
    for (int64_t j = std::max<int64_t>(1, Tk - b); j < Tk; ++j) m.set({b, j}, 0.0);
  return m;
}

void expect_gradcheck(const ag::GradcheckFn& f, const std::vector<Tensor>& in) {
  ag::GradcheckResult r = ag::gradcheck(f, in);
  EXPECT_TRUE(r.ok) << r.message;
}

}  // namespace

TEST(AgAttention, MatchesNaiveWithMaskAndCausal) {
  const Tensor q = randn({2, 3, 5, 4}, 1), k = randn({2, 3, 5, 4}, 2), v = randn({2, 3, 5, 4}, 3);
  const Tensor m = key_mask(2, 5);
  for (bool causal : {false, true})
    for (bool masked : {false, true}) {
      const Tensor mm = masked ? m : Tensor();
      Tensor want = naive_attention(q, k, v, mm, causal);
      Tensor got = ag::attention(ag::Variable(q), ag::Variable(k), ag::Variable(v), mm, causal).data();
      EXPECT_EQ(got.shape(), (Shape{2, 3, 5, 4}));
      EXPECT_LT(max_abs_diff(got, want), 1e-12) << "causal " << causal << " masked " << masked;
      // float32 agrees with the double result to float precision (mask given as int64 works too)
      Tensor m32 = masked ? m.to(DType::f32) : Tensor();
      Tensor got32 = ag::attention(ag::Variable(q.to(DType::f32)), ag::Variable(k.to(DType::f32)),
                                   ag::Variable(v.to(DType::f32)), m32, causal).data();
      EXPECT_LT(max_abs_diff(got32.to(DType::f64), want), 2e-5);
    }
}

TEST(AgAttention, CrossAttentionDifferentLengthsMatchesNaive) {
  const Tensor q = randn({2, 2, 3, 6}, 4), k = randn({2, 2, 7, 6}, 5), v = randn({2, 2, 7, 6}, 6);
  const Tensor m = key_mask(2, 7);
  Tensor got = ag::attention(ag::Variable(q), ag::Variable(k), ag::Variable(v), m).data();
  EXPECT_EQ(got.shape(), (Shape{2, 2, 3, 6}));
  EXPECT_LT(max_abs_diff(got, naive_attention(q, k, v, m, false)), 1e-12);
}

TEST(AgAttention, GradcheckPlainMaskCausalCross) {
  auto f = [](const Tensor& mask, bool causal) {
    return [mask, causal](const std::vector<ag::Variable>& x) { return ag::attention(x[0], x[1], x[2], mask, causal); };
  };
  const Shape s{2, 2, 3, 4};
  expect_gradcheck(f(Tensor(), false), {randn(s, 11), randn(s, 12), randn(s, 13)});
  expect_gradcheck(f(key_mask(2, 3), false), {randn(s, 14), randn(s, 15), randn(s, 16)});
  expect_gradcheck(f(Tensor(), true), {randn(s, 17), randn(s, 18), randn(s, 19)});
  expect_gradcheck(f(key_mask(2, 3), true), {randn(s, 20), randn(s, 21), randn(s, 22)});
  expect_gradcheck(f(key_mask(2, 5), false),
                   {randn({2, 1, 2, 3}, 23), randn({2, 1, 5, 3}, 24), randn({2, 1, 5, 3}, 25)});
}

TEST(AgAttention, GradcheckStridedInputs) {
  // q, k, v arrive as permuted views of one (B, T, 3, H, d) tensor, as a fused qkv projection produces them.
  auto f = [](const std::vector<ag::Variable>& x) {
    ag::Variable qkv = ag::permute(x[0], {2, 0, 3, 1, 4});  // (3, B, H, T, d), not contiguous
    return ag::attention(ag::select(qkv, 0, 0), ag::select(qkv, 0, 1), ag::select(qkv, 0, 2), Tensor(), true);
  };
  expect_gradcheck(f, {randn({1, 3, 3, 2, 2}, 30)});
}

TEST(AgAttention, OnlyRequestedGradients) {
  const Shape s{1, 2, 3, 4};
  ag::Variable q(randn(s, 40), true), k(randn(s, 41)), v(randn(s, 42), true);
  ag::sum(ag::attention(q, k, v)).backward();
  ASSERT_TRUE(q.grad().defined());
  ASSERT_TRUE(v.grad().defined());
  EXPECT_FALSE(k.grad().defined());
  // each value row receives the total attention mass to it: sum over queries, times 1 for each channel
  EXPECT_NEAR(t2m::sum(v.grad()).item(), 2.0 * 3.0 * 4.0, 1e-12);
}

TEST(AgAttention, MaskedKeysHaveNoInfluence) {
  const Shape s{2, 2, 4, 3};
  const Tensor q = randn(s, 50), k = randn(s, 51), v = randn(s, 52), m = key_mask(2, 4);  // b=1: key 3 masked
  Tensor k2 = k.clone(), v2 = v.clone();
  for (int64_t h = 0; h < 2; ++h)
    for (int64_t c = 0; c < 3; ++c) {
      k2.set({1, h, 3, c}, 100.0 + c);
      v2.set({1, h, 3, c}, -50.0);
    }
  ag::Variable kv(k, true), vv(v, true);
  ag::Variable o1 = ag::attention(ag::Variable(q), kv, vv, m);
  Tensor o2 = ag::attention(ag::Variable(q), ag::Variable(k2), ag::Variable(v2), m).data();
  EXPECT_EQ(max_abs_diff(o1.data(), o2), 0.0);
  ag::sum(o1).backward();
  for (int64_t h = 0; h < 2; ++h)
    for (int64_t c = 0; c < 3; ++c) {
      EXPECT_EQ(kv.grad().at({1, h, 3, c}), 0.0);
      EXPECT_EQ(vv.grad().at({1, h, 3, c}), 0.0);
    }
  // the unmasked batch entry does depend on key 3
  EXPECT_NE(vv.grad().at({0, 0, 3, 0}), 0.0);
}

TEST(AgAttention, FullyMaskedRowIsZeroNotNaN) {
  const Shape s{1, 1, 2, 2};
  Tensor m = Tensor::zeros({1, 2}, DType::f64);
  ag::Variable q(randn(s, 55), true);
  ag::Variable o = ag::attention(q, ag::Variable(randn(s, 56)), ag::Variable(randn(s, 57)), m);
  for (double x : o.data().to_vector<double>()) EXPECT_EQ(x, 0.0);
  ag::sum(o).backward();
  for (double x : q.grad().to_vector<double>()) EXPECT_EQ(x, 0.0);
}

TEST(AgAttention, CausalOutputDoesNotDependOnTheFuture) {
  const int64_t T = 5;
  const Shape s{1, 2, T, 3};
  const Tensor q = randn(s, 60), k = randn(s, 61), v = randn(s, 62);
  Tensor base = ag::attention(ag::Variable(q), ag::Variable(k), ag::Variable(v), Tensor(), true).data();
  for (int64_t t = 0; t < T; ++t) {
    Tensor q2 = q.clone(), k2 = k.clone(), v2 = v.clone();
    for (int64_t u = t + 1; u < T; ++u)  // change everything after t
      for (int64_t h = 0; h < 2; ++h)
        for (int64_t c = 0; c < 3; ++c) {
          q2.set({0, h, u, c}, 7.0);
          k2.set({0, h, u, c}, -3.0 * c);
          v2.set({0, h, u, c}, 11.0);
        }
    Tensor o = ag::attention(ag::Variable(q2), ag::Variable(k2), ag::Variable(v2), Tensor(), true).data();
    for (int64_t u = 0; u <= t; ++u)
      for (int64_t h = 0; h < 2; ++h)
        for (int64_t c = 0; c < 3; ++c) EXPECT_EQ(o.at({0, h, u, c}), base.at({0, h, u, c})) << "t " << t;
    if (t + 1 < T) {
      EXPECT_GT(max_abs_diff(o, base), 1e-3);  // the test does perturb the later outputs
    }
  }
}

TEST(AgAttention, BadUseThrows) {
  ag::Variable q(randn({1, 2, 3, 4}, 70)), k(randn({1, 2, 5, 4}, 71)), v(randn({1, 2, 5, 4}, 72));
  expect_error([&] { ag::attention(ag::Variable(randn({2, 3, 4}, 1)), k, v); }, {"attention", "4-D", "[2, 3, 4]"});
  expect_error([&] { ag::attention(q, k, ag::Variable(randn({1, 2, 4, 4}, 1))); }, {"attention", "same shape"});
  expect_error([&] { ag::attention(q, ag::Variable(randn({1, 3, 5, 4}, 1)), ag::Variable(randn({1, 3, 5, 4}, 2))); },
               {"attention", "B, H and d", "[1, 3, 5, 4]"});
  expect_error([&] { ag::attention(q, k, v, Tensor::ones({1, 3})); }, {"attention", "key_mask", "[1, 3]"});
  expect_error([&] { ag::attention(q, k, v, Tensor(), true); }, {"attention", "causal", "[1, 2, 3, 4]"});
  expect_error([&] { ag::attention(ag::Variable(q.data().to(DType::f32)), k, v); }, {"attention", "f32"});
}

TEST(AgRope, MatchesNaiveAndGradcheck) {
  const Tensor x = randn({2, 3, 5, 6}, 80);
  for (int64_t pos0 : {0, 7}) {
    EXPECT_LT(max_abs_diff(ag::rope(ag::Variable(x), pos0).data(), naive_rope(x, pos0)), 1e-12);
    EXPECT_LT(max_abs_diff(ag::rope(ag::Variable(x.to(DType::f32)), pos0).data().to(DType::f64), naive_rope(x, pos0)),
              1e-5);
    expect_gradcheck([pos0](const std::vector<ag::Variable>& a) { return ag::rope(a[0], pos0); },
                     {randn({1, 2, 3, 4}, 81)});
  }
  // strided input (a transposed view) gives the same as its contiguous copy
  const Tensor xt = randn({2, 5, 3, 6}, 82).transpose(1, 2);
  EXPECT_LT(max_abs_diff(ag::rope(ag::Variable(xt)).data(), naive_rope(xt.contiguous(), 0)), 1e-12);
}

TEST(AgRope, ScoresDependOnlyOnPositionDifference) {
  // q at position m, k at position n: <rope(q, m), rope(k, n)> is a function of m - n only, and rope keeps norms.
  const Tensor q = randn({1, 1, 1, 8}, 90), k = randn({1, 1, 1, 8}, 91);
  auto score = [&](int64_t m, int64_t n) {
    Tensor a = ag::rope(ag::Variable(q), m).data(), b = ag::rope(ag::Variable(k), n).data();
    return t2m::sum(t2m::mul(a, b)).item();
  };
  for (int64_t diff : {-3, 0, 2, 5}) {
    const double s0 = score(10 + diff, 10);
    for (int64_t n : {0, 3, 25}) EXPECT_NEAR(score(n + diff + 10, n + 10), s0, 1e-12) << "diff " << diff;
  }
  EXPECT_GT(std::abs(score(3, 0) - score(0, 0)), 1e-6);  // the score does change with the difference
  const Tensor r = ag::rope(ag::Variable(q), 13).data();
  EXPECT_NEAR(t2m::sum(t2m::mul(r, r)).item(), t2m::sum(t2m::mul(q, q)).item(), 1e-12);
}

TEST(AgRope, BadUseThrows) {
  expect_error([] { ag::rope(ag::Variable(randn({2, 3, 5}, 1))); }, {"rope", "even", "[2, 3, 5]"});
  expect_error([] { ag::rope(ag::Variable(randn({4}, 1))); }, {"rope", "[4]"});
  expect_error([] { ag::rope(ag::Variable(randn({2, 4}, 1)), -1); }, {"rope", "pos0"});
  expect_error([] { ag::rope(ag::Variable(Tensor::zeros({2, 4}, DType::i64))); }, {"rope", "i64"});
}
