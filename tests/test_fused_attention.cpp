// test_fused_attention.cpp — scaled dot-product attention against a naive double reference (per query: scores,
// mask, softmax, weighted sum), backward against central finite differences for q, k and v, with key-padding
// masks, causal masking, fully masked rows, float vs double, determinism at 2 threads and bad shapes.
#include <gtest/gtest.h>

#include <cmath>

#include "tensor/fused/attention.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"
#include "test_fused_util.h"

using namespace fused_test;
using namespace t2m::fused;

namespace {

// Returns out; fills probs (B,H,Tq,Tk).
Vec ref_attention(const Vec& q, const Vec& k, const Vec& v, const Vec* mask, const AttentionShape& s, Vec* probs) {
  const int64_t Tq = s.Tq, Tk = s.Tk, d = s.d;
  Vec out(s.B * s.H * Tq * d, 0.0);
  if (probs) probs->assign(s.B * s.H * Tq * Tk, 0.0);
  for (int64_t b = 0; b < s.B; ++b)
    for (int64_t h = 0; h < s.H; ++h)
      for (int64_t i = 0; i < Tq; ++i) {
        const int64_t bh = b * s.H + h;
        std::vector<double> sc(Tk);
        std::vector<bool> vis(Tk);
        double mx = -INFINITY;
        for (int64_t j = 0; j < Tk; ++j) {
          vis[j] = (!mask || (*mask)[b * Tk + j] != 0.0) && (!s.causal || j <= i);
          double acc = 0;
          for (int64_t c = 0; c < d; ++c) acc += q[(bh * Tq + i) * d + c] * k[(bh * Tk + j) * d + c];
          sc[j] = acc / std::sqrt((double)d);
          if (vis[j]) mx = std::max(mx, sc[j]);
        }
        double z = 0;
        for (int64_t j = 0; j < Tk; ++j) z += vis[j] ? std::exp(sc[j] - mx) : 0.0;
        for (int64_t j = 0; j < Tk; ++j) {
          const double p = vis[j] ? std::exp(sc[j] - mx) / z : 0.0;
          if (probs) (*probs)[(bh * Tq + i) * Tk + j] = p;
          for (int64_t c = 0; c < d; ++c) out[(bh * Tq + i) * d + c] += p * v[(bh * Tk + j) * d + c];
        }
      }
  return out;
}

struct AttnCase {
  int64_t B, H, Tq, Tk, d;
  bool causal, masked;
};

class AttentionTest : public ::testing::TestWithParam<AttnCase> {};

TEST_P(AttentionTest, ForwardBackwardMatchReferenceAndFiniteDifferences) {
  const AttnCase c = GetParam();
  AttentionShape s;
  s.B = c.B;
  s.H = c.H;
  s.Tq = c.Tq;
  s.Tk = c.Tk;
  s.d = c.d;
  s.causal = c.causal;
  const int64_t nq = s.B * s.H * s.Tq * s.d, nk = s.B * s.H * s.Tk * s.d;
  Vec q = randn(nq, 71), k = randn(nk, 72), v = randn(nk, 73), R = randn(nq, 74);
  // mask: batch 0 hides key 0 (with causal this leaves query 0 with no key at all), batch 1 hides the last key
  Vec mask(s.B * s.Tk, 1.0);
  if (c.masked) {
    mask[0] = 0.0;
    if (s.B > 1) mask[1 * s.Tk + s.Tk - 1] = 0.0;
  }
  const Vec* mp = c.masked ? &mask : nullptr;
  Vec out(nq), att(s.B * s.H * s.Tq * s.Tk);
  auto fwd = [&]() {
    attention_forward<double>(out.data(), att.data(), q.data(), k.data(), v.data(), mp ? mask.data() : nullptr, s);
  };
  fwd();
  Vec probs;
  expect_close(out, ref_attention(q, k, v, mp, s, &probs), 1e-12, 1e-10, "attention out");
  expect_close(att, probs, 1e-14, 1e-10, "attention probabilities");
  for (double x : out) ASSERT_TRUE(std::isfinite(x));
  Vec dq(nq, 9.0), dk(nk, 9.0), dv(nk, 9.0);  // written, not accumulated
  attention_backward<double>(dq.data(), dk.data(), dv.data(), R.data(), att.data(), q.data(), k.data(), v.data(),
                             s);
  auto loss = [&]() {
    fwd();
    return dot(out, R);
  };
  expect_close(dq, numeric_grad(q, loss), 1e-6, 1e-6, "attention dq");
  expect_close(dk, numeric_grad(k, loss), 1e-6, 1e-6, "attention dk");
  expect_close(dv, numeric_grad(v, loss), 1e-6, 1e-6, "attention dv");

  auto qf = to_float(q), kf = to_float(k), vf = to_float(v), Rf = to_float(R), mf = to_float(mask);
  std::vector<float> of(nq), af(att.size()), dqf(nq), dkf(nk), dvf(nk);
  attention_forward<float>(of.data(), af.data(), qf.data(), kf.data(), vf.data(), mp ? mf.data() : nullptr, s);
  attention_backward<float>(dqf.data(), dkf.data(), dvf.data(), Rf.data(), af.data(), qf.data(), kf.data(),
                            vf.data(), s);
  fwd();
  expect_float_matches(of, out, 1e-5, "attention float out");
  expect_float_matches(dqf, dq, 1e-5, "attention float dq");
  expect_float_matches(dkf, dk, 1e-5, "attention float dk");
  expect_float_matches(dvf, dv, 1e-5, "attention float dv");
}

INSTANTIATE_TEST_SUITE_P(Shapes, AttentionTest,
                         ::testing::Values(AttnCase{1, 1, 1, 1, 1, false, false},
                                           AttnCase{2, 3, 7, 5, 4, false, false},
                                           AttnCase{2, 3, 7, 5, 4, false, true},
                                           AttnCase{2, 2, 7, 7, 3, true, false},
                                           AttnCase{2, 2, 7, 7, 3, true, true},
                                           AttnCase{1, 2, 3, 33, 8, false, true},
                                           AttnCase{3, 1, 1, 3, 7, false, true}));

TEST(Attention, FullyMaskedRowGivesZerosNotNaN) {
  AttentionShape s;
  s.B = 1;
  s.H = 2;
  s.Tq = 3;
  s.Tk = 4;
  s.d = 5;
  Vec q = randn(30, 81), k = randn(40, 82), v = randn(40, 83), mask(4, 0.0), out(30, 7.0), att(24, 7.0);
  attention_forward<double>(out.data(), att.data(), q.data(), k.data(), v.data(), mask.data(), s);
  for (double x : out) EXPECT_EQ(x, 0.0);
  for (double x : att) EXPECT_EQ(x, 0.0);
  Vec dq(30, 1.0), dk(40, 1.0), dv(40, 1.0), R = randn(30, 84);
  attention_backward<double>(dq.data(), dk.data(), dv.data(), R.data(), att.data(), q.data(), k.data(), v.data(),
                             s);
  for (double x : dq) EXPECT_EQ(x, 0.0);
  for (double x : dk) EXPECT_EQ(x, 0.0);
  for (double x : dv) EXPECT_EQ(x, 0.0);
}

TEST(Attention, RepeatedRunsAtTwoThreadsAreBitwiseEqual) {
  const int saved = t2m::get_num_threads();
  AttentionShape s;
  s.B = 4;
  s.H = 4;
  s.Tq = 33;
  s.Tk = 33;
  s.d = 16;
  s.causal = true;
  const int64_t n = s.B * s.H * s.Tq * s.d;
  const auto q = to_float(randn(n, 91)), k = to_float(randn(n, 92)), v = to_float(randn(n, 93));
  const auto R = to_float(randn(n, 94));
  auto run = [&](int threads) {
    t2m::set_num_threads(threads);
    std::vector<float> out(n), att(s.B * s.H * s.Tq * s.Tk), dq(n), dk(n), dv(n);
    attention_forward<float>(out.data(), att.data(), q.data(), k.data(), v.data(), nullptr, s);
    attention_backward<float>(dq.data(), dk.data(), dv.data(), R.data(), att.data(), q.data(), k.data(), v.data(),
                              s);
    std::vector<float> all;
    for (auto* x : {&out, &att, &dq, &dk, &dv}) all.insert(all.end(), x->begin(), x->end());
    return all;
  };
  const auto a = run(2), a2 = run(2), one = run(1);
  t2m::set_num_threads(saved);
  EXPECT_TRUE(bitwise_equal(a, a2));
  expect_float_matches(a, to_double(one), 1e-5, "1 vs 2 threads");
}

TEST(Attention, BadShapesThrow) {
  std::vector<float> buf(4096);
  float* p = buf.data();
  AttentionShape s;
  s.Tq = 3;
  s.Tk = 4;
  s.d = 2;
  s.causal = true;
  try {
    attention_forward<float>(p, p, p, p, p, nullptr, s);
    FAIL();
  } catch (const t2m::Error& e) {
    EXPECT_NE(std::string(e.what()).find("Tq=3 Tk=4"), std::string::npos) << e.what();
  }
  s.causal = false;
  s.d = 0;
  EXPECT_THROW(attention_forward<float>(p, p, p, p, p, nullptr, s), t2m::Error);
  s.d = 2;
  EXPECT_THROW(attention_forward<float>(p, nullptr, p, p, p, nullptr, s), t2m::Error);
  EXPECT_THROW(attention_backward<float>(p, p, p, nullptr, p, p, p, p, s), t2m::Error);
}

}  // namespace
