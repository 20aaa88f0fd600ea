// test_fused_attention_heads.cpp — attention_heads_forward/backward (attention_heads.h), which read the heads in
// place from the projections' rows, against the unfused composition they replace: gather heads -> rms_norm ->
// rope -> attention -> merge heads and its backward, built here from the separate fused kernels. Same bits for the
// outputs, probabilities, rstd and dq/dk/dv (the same row kernels in the same order); the norm-weight gradients
// to rounding. Self-attention on a packed [q | k | v] projection and cross-attention on q and [k | v], with and
// without QK-norm and RoPE, key and causal masks, register-blocked and generic head dims, both ISA builds, float
// and double; gradient subsets; bad arguments.
#include <gtest/gtest.h>

#include <string>

#include "tensor/cpu_features.h"
#include "tensor/fused/attention.h"
#include "tensor/fused/attention_heads.h"
#include "tensor/fused/attention_small.h"
#include "tensor/fused/rms_norm.h"
#include "tensor/fused/rope.h"
#include "tensor/tensor.h"
#include "test_fused_util.h"

using namespace fused_test;
using namespace t2m::fused;

namespace {

struct Case {
  int64_t B, H, Tq, Tk, d;
  bool causal, masked, norm, rope, self;
};

// Everything one direction produces. q/k/v live in projection rows: self [q | k | v] (ld 3W), cross q (ld W) and
// [k | v] (ld 2W), W = H*d.
template <typename T>
struct HeadsRun {
  std::vector<T> out, att, rq, rk, dqsrc, dkvsrc, dqn, dkn;
};

template <typename T>
struct Problem {
  Case c;
  AttentionShape s;
  std::vector<T> qsrc, kvsrc, g, mask, qn, kn, cos, sin;
  int64_t W() const { return s.H * s.d; }
  int64_t ldq() const { return c.self ? 3 * W() : W(); }
  int64_t ldkv() const { return c.self ? 3 * W() : 2 * W(); }
  const T* kv_base() const { return c.self ? qsrc.data() + W() : kvsrc.data(); }
  const std::vector<T>& kv_vec() const { return c.self ? qsrc : kvsrc; }
};

template <typename T>
std::vector<T> cast(const Vec& v) {
  return std::vector<T>(v.begin(), v.end());
}

template <typename T>
Problem<T> make(const Case& c) {
  Problem<T> p;
  p.c = c;
  p.s.B = c.B, p.s.H = c.H, p.s.Tq = c.Tq, p.s.Tk = c.Tk, p.s.d = c.d, p.s.causal = c.causal;
  const int64_t W = c.H * c.d;
  p.qsrc = cast<T>(randn(c.B * c.Tq * (c.self ? 3 * W : W), 11));
  if (!c.self) p.kvsrc = cast<T>(randn(c.B * c.Tk * 2 * W, 12));
  p.g = cast<T>(randn(c.B * c.Tq * W, 13));
  p.mask.assign(c.B * c.Tk, (T)1);
  if (c.masked) {  // batch 0 hides every key (zero rows), batch 1 two of them
    for (int64_t j = 0; j < c.Tk; ++j) p.mask[j] = 0;
    if (c.B > 1) p.mask[c.Tk] = 0, p.mask[2 * c.Tk - 1] = 0;
  }
  if (c.norm) {
    p.qn = cast<T>(randn(c.d, 14, 0.3));
    p.kn = cast<T>(randn(c.d, 15, 0.3));
    for (int64_t i = 0; i < c.d; ++i) p.qn[i] += 1, p.kn[i] += 1;
  }
  if (c.rope) {
    p.cos.resize(c.Tq * c.d / 2), p.sin.resize(c.Tq * c.d / 2);
    rope_table<T>(p.cos.data(), p.sin.data(), c.Tq, c.d, 10000.0, 3);
  }
  return p;
}

template <typename T>
AttentionHeads<T> args(const Problem<T>& p) {
  AttentionHeads<T> a;
  a.s = p.s;
  a.q = p.qsrc.data(), a.ldq = p.ldq();
  a.k = p.kv_base(), a.ldk = p.ldkv();
  a.v = p.kv_base() + p.W(), a.ldv = p.ldkv();
  a.key_mask = p.c.masked ? p.mask.data() : nullptr;
  if (p.c.norm) a.q_norm = p.qn.data(), a.k_norm = p.kn.data(), a.norm_eps = (T)1e-6;
  if (p.c.rope) a.cos_tab = p.cos.data(), a.sin_tab = p.sin.data();
  return a;
}

// rows (B, T, ld) at column col -> heads (B, H, T, d), and back.
template <typename T>
std::vector<T> gather(const T* src, int64_t ld, const AttentionShape& s, int64_t Tlen) {
  std::vector<T> h(s.B * s.H * Tlen * s.d);
  for (int64_t b = 0; b < s.B; ++b)
    for (int64_t hh = 0; hh < s.H; ++hh)
      for (int64_t t = 0; t < Tlen; ++t)
        for (int64_t c = 0; c < s.d; ++c)
          h[((b * s.H + hh) * Tlen + t) * s.d + c] = src[(b * Tlen + t) * ld + hh * s.d + c];
  return h;
}
template <typename T>
void scatter(T* dst, int64_t ld, const std::vector<T>& h, const AttentionShape& s, int64_t Tlen) {
  for (int64_t b = 0; b < s.B; ++b)
    for (int64_t hh = 0; hh < s.H; ++hh)
      for (int64_t t = 0; t < Tlen; ++t)
        for (int64_t c = 0; c < s.d; ++c)
          dst[(b * Tlen + t) * ld + hh * s.d + c] = h[((b * s.H + hh) * Tlen + t) * s.d + c];
}

// The unfused reference: the (B, H, T, d) kernels one after the other (what autograd/ops_mha.cpp did before).
template <typename T>
HeadsRun<T> reference(const Problem<T>& p) {
  const AttentionShape& s = p.s;
  const int64_t BH = s.B * s.H, d = s.d;
  std::vector<T> qh = gather(p.qsrc.data(), p.ldq(), s, s.Tq), kh = gather(p.kv_base(), p.ldkv(), s, s.Tk);
  std::vector<T> vh = gather(p.kv_base() + p.W(), p.ldkv(), s, s.Tk);
  std::vector<T> q = qh, k = kh;
  HeadsRun<T> r;
  if (p.c.norm) {
    r.rq.resize(BH * s.Tq), r.rk.resize(BH * s.Tk);
    rms_norm_forward<T>(q.data(), r.rq.data(), qh.data(), p.qn.data(), BH * s.Tq, d, (T)1e-6);
    rms_norm_forward<T>(k.data(), r.rk.data(), kh.data(), p.kn.data(), BH * s.Tk, d, (T)1e-6);
  }
  if (p.c.rope) {
    rope_forward<T>(q.data(), q.data(), p.cos.data(), p.sin.data(), BH, s.Tq, d);
    rope_forward<T>(k.data(), k.data(), p.cos.data(), p.sin.data(), BH, s.Tk, d);
  }
  std::vector<T> o(BH * s.Tq * d);
  r.att.resize(BH * s.Tq * s.Tk);
  attention_forward<T>(o.data(), r.att.data(), q.data(), k.data(), vh.data(), p.c.masked ? p.mask.data() : nullptr,
                       s);
  r.out.assign(s.B * s.Tq * p.W(), (T)0);
  scatter(r.out.data(), p.W(), o, s, s.Tq);
  std::vector<T> go = gather(p.g.data(), p.W(), s, s.Tq), dq(o.size()), dk(kh.size()), dv(kh.size());
  attention_backward<T>(dq.data(), dk.data(), dv.data(), go.data(), r.att.data(), q.data(), k.data(), vh.data(), s);
  if (p.c.rope) {
    rope_backward<T>(dq.data(), dq.data(), p.cos.data(), p.sin.data(), BH, s.Tq, d);
    rope_backward<T>(dk.data(), dk.data(), p.cos.data(), p.sin.data(), BH, s.Tk, d);
  }
  if (p.c.norm) {
    std::vector<T> dqx(dq.size()), dkx(dk.size());
    r.dqn.assign(d, (T)0), r.dkn.assign(d, (T)0);
    rms_norm_backward<T>(dqx.data(), r.dqn.data(), dq.data(), qh.data(), p.qn.data(), r.rq.data(), BH * s.Tq, d);
    rms_norm_backward<T>(dkx.data(), r.dkn.data(), dk.data(), kh.data(), p.kn.data(), r.rk.data(), BH * s.Tk, d);
    dq = dqx, dk = dkx;
  }
  r.dqsrc.assign(p.qsrc.size(), (T)7);
  if (p.c.self) {
    scatter(r.dqsrc.data(), p.ldq(), dq, s, s.Tq);
    scatter(r.dqsrc.data() + p.W(), p.ldq(), dk, s, s.Tk);
    scatter(r.dqsrc.data() + 2 * p.W(), p.ldq(), dv, s, s.Tk);
  } else {
    scatter(r.dqsrc.data(), p.ldq(), dq, s, s.Tq);
    r.dkvsrc.assign(p.kvsrc.size(), (T)7);
    scatter(r.dkvsrc.data(), p.ldkv(), dk, s, s.Tk);
    scatter(r.dkvsrc.data() + p.W(), p.ldkv(), dv, s, s.Tk);
  }
  return r;
}

// The fused path; want_q / want_kv select the gradients (null pointers otherwise; the rest keeps its 7s).
template <typename T>
HeadsRun<T> fused_run(const Problem<T>& p, bool want_q = true, bool want_kv = true) {
  const AttentionShape& s = p.s;
  const int64_t BH = s.B * s.H;
  const AttentionHeads<T> a = args(p);
  HeadsRun<T> r;
  r.out.assign(s.B * s.Tq * p.W(), (T)0);
  r.att.assign(BH * s.Tq * s.Tk, (T)7);
  if (p.c.norm) r.rq.assign(BH * s.Tq, (T)7), r.rk.assign(BH * s.Tk, (T)7);
  attention_heads_forward<T>(r.out.data(), p.W(), r.att.data(), p.c.norm ? r.rq.data() : nullptr,
                             p.c.norm ? r.rk.data() : nullptr, a);
  r.dqsrc.assign(p.qsrc.size(), (T)7);
  if (!p.c.self) r.dkvsrc.assign(p.kvsrc.size(), (T)7);
  T* kvg = p.c.self ? r.dqsrc.data() + p.W() : r.dkvsrc.data();
  if (p.c.norm) r.dqn.assign(s.d, (T)0), r.dkn.assign(s.d, (T)0);
  attention_heads_backward<T>(want_q ? r.dqsrc.data() : nullptr, p.ldq(), want_kv ? kvg : nullptr, p.ldkv(),
                              want_kv ? kvg + p.W() : nullptr, p.ldkv(), p.c.norm ? r.dqn.data() : nullptr,
                              p.c.norm ? r.dkn.data() : nullptr, p.g.data(), p.W(), r.att.data(),
                              p.c.norm ? r.rq.data() : nullptr, p.c.norm ? r.rk.data() : nullptr, a);
  return r;
}

template <typename T>
void expect_bits(const std::vector<T>& a, const std::vector<T>& b, const std::string& what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  int bad = 0;
  for (size_t i = 0; i < a.size(); ++i)
    if (std::memcmp(&a[i], &b[i], sizeof(T)) != 0 && ++bad <= 3)
      ADD_FAILURE() << what << "[" << i << "]: " << a[i] << " vs " << b[i];
  EXPECT_EQ(bad, 0) << what;
}

template <typename T>
void expect_matches_reference(const Case& c, const std::string& tag) {
  const Problem<T> p = make<T>(c);
  const HeadsRun<T> ref = reference(p), got = fused_run(p);
  expect_bits(got.out, ref.out, tag + " out");
  expect_bits(got.att, ref.att, tag + " att");
  expect_bits(got.rq, ref.rq, tag + " rstd_q");
  expect_bits(got.rk, ref.rk, tag + " rstd_k");
  expect_bits(got.dqsrc, ref.dqsrc, tag + " d(q source)");
  expect_bits(got.dkvsrc, ref.dkvsrc, tag + " d(kv source)");
  const double tol = sizeof(T) == 4 ? 1e-5 : 1e-12;
  expect_close(Vec(got.dqn.begin(), got.dqn.end()), Vec(ref.dqn.begin(), ref.dqn.end()), tol, tol, tag + " dqn");
  expect_close(Vec(got.dkn.begin(), got.dkn.end()), Vec(ref.dkn.begin(), ref.dkn.end()), tol, tol, tag + " dkn");
}

class AttentionHeadsCases : public ::testing::TestWithParam<Case> {};

}  // namespace

TEST_P(AttentionHeadsCases, SameBitsAsTheUnfusedKernels) {
  const Case c = GetParam();
  ASSERT_TRUE(attention_heads_eligible(make<float>(c).s));
  expect_matches_reference<float>(c, "float");
  expect_matches_reference<double>(c, "double");
  t2m::force_baseline_isa(true);  // the AVX2 build of the same loops
  expect_matches_reference<float>(c, "baseline float");
  t2m::force_baseline_isa(false);
}

TEST_P(AttentionHeadsCases, GradientSubsets) {
  const Case c = GetParam();
  const Problem<double> p = make<double>(c);
  const HeadsRun<double> all = fused_run(p), only_q = fused_run(p, true, false), only_kv = fused_run(p, false, true);
  expect_bits(only_kv.dqn, all.dqn, "dqn without dq");  // the norm-weight gradients need no dq target
  expect_bits(only_q.dkn, all.dkn, "dkn without dk");
  if (c.self) {  // packed [q | k | v]: the unrequested columns keep their 7s
    for (int64_t r = 0; r < c.B * c.Tq; ++r)
      for (int64_t j = 0; j < 3 * p.W(); ++j) {
        const double v = all.dqsrc[r * 3 * p.W() + j];
        const bool q_col = j < p.W();
        ASSERT_EQ(only_q.dqsrc[r * 3 * p.W() + j], q_col ? v : 7.0);
        ASSERT_EQ(only_kv.dqsrc[r * 3 * p.W() + j], q_col ? 7.0 : v);
      }
  } else {
    expect_bits(only_q.dqsrc, all.dqsrc, "dq alone");
    expect_bits(only_kv.dkvsrc, all.dkvsrc, "dkv alone");
    for (double x : only_kv.dqsrc) ASSERT_EQ(x, 7.0);
    for (double x : only_q.dkvsrc) ASSERT_EQ(x, 7.0);
  }
}

INSTANTIATE_TEST_SUITE_P(
    FmShapes, AttentionHeadsCases,
    //                       B  H  Tq  Tk   d  causal masked norm  rope   self
    ::testing::Values(Case{2, 2, 8, 8, 64, false, false, true, true, true},     // fm self-attention, Tm 8
                      Case{3, 2, 16, 16, 8, false, true, true, true, true},     // Tm 16, generic head dim
                      Case{2, 3, 8, 24, 32, false, true, true, false, false},   // fm cross-attention
                      Case{2, 2, 24, 24, 12, false, true, false, false, true},  // text adapter: no norm, no rope
                      Case{2, 2, 9, 9, 64, true, true, true, true, true},       // causal, odd sizes
                      Case{3, 1, 7, 7, 6, false, false, false, true, true},     // rope without norm, odd B*H
                      Case{1, 1, 3, 70, 64, false, false, true, false, false},  // too many keys: generic loops
                      Case{2, 1, 24, 24, 96, false, true, false, false, true}));  // register-blocked, no norm

TEST(AttentionHeads, BadArgumentsThrow) {
  const Problem<float> p = make<float>(Case{2, 2, 8, 8, 16, false, false, true, true, true});
  std::vector<float> out(p.s.B * p.s.Tq * p.W()), att(p.s.B * p.s.H * 64), rq(64), rk(64);
  auto expect_throw = [&](AttentionHeads<float> a, int64_t ldo, const std::string& part) {
    try {
      attention_heads_forward<float>(out.data(), ldo, att.data(), rq.data(), rk.data(), a);
      ADD_FAILURE() << "no error for " << part;
    } catch (const t2m::Error& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  AttentionHeads<float> a = args(p);
  a.ldk = p.W() - 1;
  expect_throw(a, p.W(), "leading dimensions");
  expect_throw(args(p), p.W() - 1, "ldo");
  a = args(p);
  a.k_norm = nullptr;
  expect_throw(a, p.W(), "both norm weights");
  a = args(p);
  a.sin_tab = nullptr;
  expect_throw(a, p.W(), "both RoPE tables");
  a = args(p);
  a.s.Tk = 4;
  expect_throw(a, p.W(), "RoPE needs Tq == Tk");
  a = args(p);
  a.s.d = 512, a.s.H = 1;
  expect_throw(a, 512 * 3, "not served");
  a = args(p);
  a.v = nullptr;
  expect_throw(a, p.W(), "v is null");
  attention_force_path("gemm");  // the forced gemm path is not served either: callers fall back
  EXPECT_FALSE(attention_heads_eligible(p.s));
  attention_force_path("auto");
  EXPECT_TRUE(attention_heads_eligible(p.s));
}
