// test_fused_attention_small.cpp — the two implementations of tensor/fused/attention.h agree: the per-head loop
// path for small heads (attention_small.h, the default for the fm generator's shapes) and the gemm_batched path,
// forced in turn with attention_force_path, on fm-like shapes (self 8x8 and 16x16, cross 8x24, text 24x24), with
// key masks, causal masks, fully masked rows and requested-gradient subsets, at head dims served by the
// register-blocked loops (32, 64, 96, 128; both the AVX-512 and the baseline build) and by the generic ones; the
// small path is bitwise identical at 1 and 2 threads; path selection and bad path names.
#include <gtest/gtest.h>

#include <cmath>

#include "tensor/cpu_features.h"
#include "tensor/fused/attention.h"
#include "tensor/fused/attention_small.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"
#include "test_fused_util.h"

using namespace fused_test;
using namespace t2m::fused;

namespace {

struct AttnRun {
  Vec out, att, dq, dk, dv;
};

template <typename T>
std::vector<T> cast(const Vec& v) {
  return std::vector<T>(v.begin(), v.end());
}

// Forward + backward on the forced path; grads requested per flags (null pointers otherwise).
template <typename T>
AttnRun run(const char* path, const AttentionShape& s, const Vec& q, const Vec& k, const Vec& v, const Vec& g,
        const Vec* mask, bool want_q = true, bool want_k = true, bool want_v = true) {
  attention_force_path(path);
  const int64_t nq = s.B * s.H * s.Tq * s.d, nk = s.B * s.H * s.Tk * s.d;
  auto qt = cast<T>(q), kt = cast<T>(k), vt = cast<T>(v), gt = cast<T>(g);
  std::vector<T> mt = mask ? cast<T>(*mask) : std::vector<T>();
  std::vector<T> out(nq, (T)7), att(s.B * s.H * s.Tq * s.Tk, (T)7), dq(nq, (T)7), dk(nk, (T)7), dv(nk, (T)7);
  attention_forward<T>(out.data(), att.data(), qt.data(), kt.data(), vt.data(), mask ? mt.data() : nullptr, s);
  attention_backward<T>(want_q ? dq.data() : nullptr, want_k ? dk.data() : nullptr, want_v ? dv.data() : nullptr,
                        gt.data(), att.data(), qt.data(), kt.data(), vt.data(), s);
  attention_force_path("auto");
  auto d = [](const std::vector<T>& x) { return Vec(x.begin(), x.end()); };
  return AttnRun{d(out), d(att), d(dq), d(dk), d(dv)};
}

struct Case {  // masked needs B >= 2 (batch 0 hides every key, batch 1 two of them)
  int64_t B, H, Tq, Tk, d;
  bool causal, masked;
};

class AttentionPaths : public ::testing::TestWithParam<Case> {};

}  // namespace

TEST_P(AttentionPaths, SmallAndGemmPathsAgree) {
  const Case c = GetParam();
  AttentionShape s;
  s.B = c.B, s.H = c.H, s.Tq = c.Tq, s.Tk = c.Tk, s.d = c.d, s.causal = c.causal;
  ASSERT_STREQ(attention_path(s), "small");
  const int64_t nq = s.B * s.H * s.Tq * s.d, nk = s.B * s.H * s.Tk * s.d;
  const Vec q = randn(nq, 1), k = randn(nk, 2), v = randn(nk, 3), g = randn(nq, 4);
  Vec mask(s.B * s.Tk, 1.0);
  if (c.masked) {
    for (int64_t j = 0; j < s.Tk; ++j) mask[j] = 0.0;  // batch 0: every key hidden (rows give 0, no gradient)
    mask[s.Tk + 1] = 0.0;
    mask[2 * s.Tk - 1] = 0.0;
  }
  const Vec* mp = c.masked ? &mask : nullptr;
  const AttnRun a = run<double>("small", s, q, k, v, g, mp), b = run<double>("gemm", s, q, k, v, g, mp);
  expect_close(a.out, b.out, 1e-13, 1e-12, "out");
  expect_close(a.att, b.att, 1e-14, 1e-12, "att");
  expect_close(a.dq, b.dq, 1e-13, 1e-12, "dq");
  expect_close(a.dk, b.dk, 1e-13, 1e-12, "dk");
  expect_close(a.dv, b.dv, 1e-13, 1e-12, "dv");
  if (c.masked) {
    for (int64_t i = 0; i < s.H * s.Tq * s.d; ++i) ASSERT_EQ(a.out[i], 0.0);
  }
  // float: the small path against the double result
  const AttnRun f = run<float>("small", s, q, k, v, g, mp);
  expect_close(f.out, b.out, 1e-5, 1e-4, "float out");
  expect_close(f.dq, b.dq, 1e-5, 1e-4, "float dq");
  expect_close(f.dk, b.dk, 1e-5, 1e-4, "float dk");
  expect_close(f.dv, b.dv, 1e-5, 1e-4, "float dv");
  // gradient subsets: the requested ones are unchanged, the others untouched (pointer null)
  const AttnRun only_k = run<double>("small", s, q, k, v, g, mp, false, true, false);
  expect_close(only_k.dk, a.dk, 0, 0, "dk alone");
  for (double x : only_k.dq) ASSERT_EQ(x, 7.0);
  const AttnRun only_v = run<double>("small", s, q, k, v, g, mp, false, false, true);
  expect_close(only_v.dv, a.dv, 0, 0, "dv alone");
  const AttnRun only_q = run<double>("small", s, q, k, v, g, mp, true, false, false);
  expect_close(only_q.dq, a.dq, 0, 0, "dq alone");
  // the baseline (AVX2) build of the same loops: other vector widths, so other padded key counts
  t2m::force_baseline_isa(true);
  const AttnRun base = run<double>("small", s, q, k, v, g, mp);
  const AttnRun base_f = run<float>("small", s, q, k, v, g, mp);
  t2m::force_baseline_isa(false);
  expect_close(base.out, b.out, 1e-13, 1e-12, "baseline out");
  expect_close(base.att, b.att, 1e-14, 1e-12, "baseline att");
  expect_close(base.dq, b.dq, 1e-13, 1e-12, "baseline dq");
  expect_close(base.dk, b.dk, 1e-13, 1e-12, "baseline dk");
  expect_close(base.dv, b.dv, 1e-13, 1e-12, "baseline dv");
  expect_close(base_f.out, b.out, 1e-5, 1e-4, "baseline float out");
  expect_close(base_f.dq, b.dq, 1e-5, 1e-4, "baseline float dq");
  expect_close(base_f.dk, b.dk, 1e-5, 1e-4, "baseline float dk");
  expect_close(base_f.dv, b.dv, 1e-5, 1e-4, "baseline float dv");
}

INSTANTIATE_TEST_SUITE_P(FmShapes, AttentionPaths,
                         ::testing::Values(Case{2, 2, 8, 8, 16, false, false},    // self, Tm 8
                                           Case{3, 2, 16, 16, 8, false, true},    // self, Tm 16, padded frames
                                           Case{2, 3, 8, 24, 16, false, true},    // cross to 24 text tokens
                                           Case{2, 2, 24, 24, 12, false, true},   // text adapter
                                           Case{2, 2, 9, 9, 5, true, true},       // causal, odd sizes
                                           Case{1, 1, 1, 70, 3, false, false},    // one query, many keys
                                           // head dims of the register-blocked loops
                                           Case{2, 2, 16, 16, 64, false, false},  // fm self-attention
                                           Case{2, 3, 8, 24, 32, false, true},    // fm cross-attention
                                           Case{2, 2, 9, 9, 64, true, true},      // causal, odd sizes
                                           Case{2, 2, 5, 50, 96, false, true},    // 4 float vectors of keys
                                           Case{1, 1, 3, 70, 128, false, false},  // too many keys: generic loops
                                           Case{2, 1, 24, 24, 128, false, true}));  // text adapter width

TEST(AttentionPaths, SmallPathIsBitwiseEqualAtOneAndTwoThreads) {
  const int saved = t2m::get_num_threads();
  AttentionShape s;
  s.B = 32, s.H = 4, s.Tq = 8, s.Tk = 24, s.d = 64;
  const int64_t nq = s.B * s.H * s.Tq * s.d, nk = s.B * s.H * s.Tk * s.d;
  const Vec q = randn(nq, 5), k = randn(nk, 6), v = randn(nk, 7), g = randn(nq, 8);
  t2m::set_num_threads(1);
  const AttnRun one = run<float>("auto", s, q, k, v, g, nullptr);
  t2m::set_num_threads(2);
  const AttnRun two = run<float>("auto", s, q, k, v, g, nullptr);
  t2m::set_num_threads(saved);
  expect_close(one.out, two.out, 0, 0, "out");
  expect_close(one.dq, two.dq, 0, 0, "dq");
  expect_close(one.dk, two.dk, 0, 0, "dk");
  expect_close(one.dv, two.dv, 0, 0, "dv");
}

TEST(AttentionPaths, SelectionAndBadNames) {
  AttentionShape s;
  s.Tq = 64, s.Tk = 64, s.d = 64;
  EXPECT_STREQ(attention_path(s), "small");
  s.Tk = 65;
  EXPECT_STREQ(attention_path(s), "gemm");
  s.Tk = 8, s.d = 512;
  EXPECT_STREQ(attention_path(s), "gemm");
  s.d = 64;
  attention_force_path("gemm");
  EXPECT_STREQ(attention_path(s), "gemm");
  attention_force_path("auto");
  EXPECT_STREQ(attention_path(s), "small");
  try {
    attention_force_path("fast");
    FAIL();
  } catch (const t2m::Error& e) {
    EXPECT_NE(std::string(e.what()).find("'fast'"), std::string::npos) << e.what();
  }
}
