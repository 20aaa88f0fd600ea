// test_ag_mha.cpp — the fused multi-head attention core (mha_self / mha_cross): values and gradients against a
// composition of single autograd ops written the way torch_ref.py writes it (view, permute, RMS-norm from
// elementwise ops, rope, attention, transpose, reshape); float64 finite-difference gradchecks with and without
// QK-norm, RoPE, key mask and causal; float32 agreement; bad use throws. Each on both implementations: the fused
// per-head path (tensor/fused/attention_heads.h, what these small shapes get) and, with attention_force_path("gemm"),
// the (B, H, T, d) head copies.
#include <gtest/gtest.h>

#include <cmath>

#include "autograd/gradcheck.h"
#include "autograd/ops_attention.h"
#include "autograd/ops_elementwise.h"
#include "autograd/ops_mha.h"
#include "autograd/ops_reduce.h"
#include "autograd/ops_shape.h"
#include "autograd/ops_unary.h"
#include "tensor/fused/attention.h"
#include "tensor/fused/attention_heads.h"
#include "tensor/ops.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

using namespace t2m;
using t2m::testing::randn;
using t2m::testing::expect_error;

namespace {

ag::Variable rms(const ag::Variable& x, const ag::Variable& w, double eps) {
  return x * ag::rsqrt(ag::mean(ag::square(x), {-1}, true) + eps) * w;
}

// Runs f once per implementation of the op, naming it in the failure trace.
template <typename F>
void on_both_paths(F&& f) {
  for (const char* path : {"auto", "gemm"}) {
    SCOPED_TRACE(std::string("attention path ") + path);
    fused::attention_force_path(path);
    fused::AttentionShape s;
    s.Tq = s.Tk = 4, s.d = 4;
    EXPECT_EQ(fused::attention_heads_eligible(s), std::string(path) == "auto");
    f();
  }
  fused::attention_force_path("auto");
}

// (B, T, n*H*d) -> the n parts as (B, H, T, d) views.
std::vector<ag::Variable> heads(const ag::Variable& x, int64_t n, int64_t H) {
  const int64_t B = x.size(0), T = x.size(1), d = x.size(2) / (n * H);
  ag::Variable p = ag::permute(ag::reshape(x, {B, T, n, H, d}), {2, 0, 3, 1, 4});
  std::vector<ag::Variable> r;
  for (int64_t i = 0; i < n; ++i) r.push_back(ag::select(p, 0, i));
  return r;
}

ag::Variable merge(const ag::Variable& o) {
  return ag::reshape(ag::transpose(o, 1, 2), {o.size(0), o.size(2), o.size(1) * o.size(3)});
}

ag::Variable ref_self(const ag::Variable& qkv, const ag::Variable& qn, const ag::Variable& kn, const Tensor& mask,
                      const ag::MhaOptions& o) {
  auto p = heads(qkv, 3, o.heads);
  ag::Variable q = p[0], k = p[1];
  if (qn.defined()) q = rms(q, qn, o.norm_eps), k = rms(k, kn, o.norm_eps);
  if (o.rope) q = ag::rope(q, o.rope_pos0, o.rope_base), k = ag::rope(k, o.rope_pos0, o.rope_base);
  return merge(ag::attention(q, k, p[2], mask, o.causal));
}

ag::Variable ref_cross(const ag::Variable& qx, const ag::Variable& kv, const ag::Variable& qn, const ag::Variable& kn,
                       const Tensor& mask, const ag::MhaOptions& o) {
  ag::Variable q = heads(qx, 1, o.heads)[0];
  auto p = heads(kv, 2, o.heads);
  ag::Variable k = p[0];
  if (qn.defined()) q = rms(q, qn, o.norm_eps), k = rms(k, kn, o.norm_eps);
  return merge(ag::attention(q, k, p[1], mask, o.causal));
}

Tensor mask_of(int64_t B, int64_t Tk) {  // batch b hides its last b keys (keeps at least one)
  Tensor m = Tensor::ones({B, Tk}, DType::f64);
  for (int64_t b = 0; b < B; ++b)
    for (int64_t j = std::max<int64_t>(1, Tk - b); j < Tk; ++j) m.set({b, j}, 0.0);
  return m;
}

// Fused vs composed: outputs and the gradients of every input under one random output weighting.
void expect_same(const std::function<ag::Variable(const std::vector<ag::Variable>&)>& fused,
                 const std::function<ag::Variable(const std::vector<ag::Variable>&)>& composed,
                 const std::vector<Tensor>& in, double tol) {
  std::vector<ag::Variable> a, b;
  for (const Tensor& t : in) a.emplace_back(t.clone(), true), b.emplace_back(t.clone(), true);
  ag::Variable ya = fused(a), yb = composed(b);
  ASSERT_EQ(ya.shape(), yb.shape());
  EXPECT_LT(max_abs_diff(ya.data(), yb.data()), tol);
  const Tensor w = randn(ya.shape(), 99, ya.dtype());
  ya.backward(w);
  yb.backward(w);
  for (size_t i = 0; i < in.size(); ++i) EXPECT_LT(max_abs_diff(a[i].grad(), b[i].grad()), tol) << "input " << i;
}

}  // namespace

TEST(AgMha, SelfMatchesComposedOps) {
  on_both_paths([] {
    const int64_t B = 2, T = 5, H = 2, d = 4;
    for (int variant = 0; variant < 4; ++variant) {
      ag::MhaOptions o;
      o.heads = H;
      o.rope = variant >= 1;
      o.rope_pos0 = variant == 3 ? 3 : 0;
      o.causal = variant == 2;
      const bool norm = variant != 1;
      const Tensor mask = variant == 3 ? mask_of(B, T) : Tensor();
      std::vector<Tensor> in{randn({B, T, 3 * H * d}, 1 + variant)};
      if (norm) in.push_back(t2m::add(randn({d}, 10 + variant), 1.0)), in.push_back(randn({d}, 20 + variant));
      auto fused = [&](const std::vector<ag::Variable>& x) {
        return ag::mha_self(x[0], norm ? x[1] : ag::Variable(), norm ? x[2] : ag::Variable(), mask, o);
      };
      auto composed = [&](const std::vector<ag::Variable>& x) {
        return ref_self(x[0], norm ? x[1] : ag::Variable(), norm ? x[2] : ag::Variable(), mask, o);
      };
      SCOPED_TRACE("variant " + std::to_string(variant));
      expect_same(fused, composed, in, 1e-12);
      // float32 forward agrees with float64 to float precision
      std::vector<ag::Variable> x32;
      for (const Tensor& t : in) x32.emplace_back(t.to(DType::f32));
      Tensor y32 = fused(x32).data().to(DType::f64);
      std::vector<ag::Variable> x64;
      for (const Tensor& t : in) x64.emplace_back(t);
      EXPECT_LT(max_abs_diff(y32, fused(x64).data()), 5e-5);
    }
  });
}

TEST(AgMha, CrossMatchesComposedOpsWithOtherContextLength) {
  on_both_paths([] {
    const int64_t B = 2, Tq = 3, Tk = 6, H = 2, d = 3;
    ag::MhaOptions o;
    o.heads = H;
    const Tensor mask = mask_of(B, Tk);
    for (bool norm : {false, true}) {
      std::vector<Tensor> in{randn({B, Tq, H * d}, 30), randn({B, Tk, 2 * H * d}, 31)};
      if (norm) in.push_back(randn({d}, 32)), in.push_back(randn({d}, 33));
      auto fused = [&](const std::vector<ag::Variable>& x) {
        return ag::mha_cross(x[0], x[1], norm ? x[2] : ag::Variable(), norm ? x[3] : ag::Variable(), mask, o);
      };
      auto composed = [&](const std::vector<ag::Variable>& x) {
        return ref_cross(x[0], x[1], norm ? x[2] : ag::Variable(), norm ? x[3] : ag::Variable(), mask, o);
      };
      SCOPED_TRACE(norm ? "qk-norm" : "plain");
      expect_same(fused, composed, in, 1e-12);
    }
  });
}

TEST(AgMha, GradcheckSelfAndCross) {
  on_both_paths([] {
    ag::MhaOptions o;
    o.heads = 2;
    o.rope = true;
    o.rope_pos0 = 2;
    o.causal = true;
    const Tensor mask = mask_of(2, 3);
    auto self = [&](const std::vector<ag::Variable>& x) { return ag::mha_self(x[0], x[1], x[2], mask, o); };
    ag::GradcheckResult r = ag::gradcheck(self, {randn({2, 3, 12}, 40), randn({2}, 41), randn({2}, 42)});
    EXPECT_TRUE(r.ok) << r.message;
    ag::MhaOptions oc;
    oc.heads = 2;
    auto cross = [&](const std::vector<ag::Variable>& x) {
      return ag::mha_cross(x[0], x[1], x[2], x[3], Tensor(), oc);
    };
    r = ag::gradcheck(cross, {randn({1, 2, 4}, 43), randn({1, 5, 8}, 44), randn({2}, 45), randn({2}, 46)});
    EXPECT_TRUE(r.ok) << r.message;
  });
}

TEST(AgMha, StridedInputAndPartialGradients) {
  // a transposed (non-contiguous) qkv gives the same result; with only the norm weights requiring grad the
  // backward still delivers their gradients.
  ag::MhaOptions o;
  o.heads = 2;
  const Tensor x = randn({2, 12, 4}, 50);  // (B, 3D, T) storage, used as (B, T, 3D)
  ag::Variable qn(t2m::add(randn({2}, 51), 1.0), true), kn(randn({2}, 52), true);
  ag::Variable y = ag::mha_self(ag::Variable(x.transpose(1, 2)), qn, kn, Tensor(), o);
  Tensor want = ag::mha_self(ag::Variable(x.transpose(1, 2).contiguous()), qn, kn, Tensor(), o).data();
  EXPECT_EQ(max_abs_diff(y.data(), want), 0.0);
  ag::sum(ag::square(y)).backward();
  ASSERT_TRUE(qn.grad().defined());
  ASSERT_TRUE(kn.grad().defined());
  EXPECT_GT(t2m::sum(t2m::abs(qn.grad())).item(), 0.0);
}

TEST(AgMha, BadUseThrows) {
  ag::MhaOptions o;
  o.heads = 2;
  ag::Variable x(randn({1, 3, 12}, 60));
  ag::Variable w2(randn({2}, 61)), w3(randn({3}, 62));
  expect_error([&] { ag::mha_self(ag::Variable(randn({1, 3, 10}, 1)), {}, {}, Tensor(), o); },
               {"mha_self", "3 * heads * d", "[1, 3, 10]"});
  expect_error([&] { ag::mha_self(ag::Variable(randn({3, 12}, 1)), {}, {}, Tensor(), o); }, {"mha_self", "3-D"});
  expect_error([&] { ag::mha_self(x, w2, {}, Tensor(), o); }, {"mha_self", "both"});
  expect_error([&] { ag::mha_self(x, w3, w3, Tensor(), o); }, {"mha_self", "(d) = [2]", "[3]"});
  expect_error([&] { ag::mha_self(x, {}, {}, Tensor::ones({1, 4}), o); }, {"mha_self", "key_mask", "[1, 3]"});
  ag::MhaOptions odd = o;
  odd.heads = 4;  // d = 12 / (3 * 4) = 1
  odd.rope = true;
  expect_error([&] { ag::mha_self(x, {}, {}, Tensor(), odd); }, {"mha_self", "even"});
  ag::MhaOptions causal = o;
  causal.causal = true;
  expect_error([&] { ag::mha_cross(ag::Variable(randn({1, 3, 4}, 1)), ag::Variable(randn({1, 5, 8}, 2)), {}, {},
                                   Tensor(), causal); },
               {"mha_cross", "causal", "[1, 5, 8]"});
  expect_error([&] { ag::mha_cross(ag::Variable(randn({1, 3, 4}, 1)), ag::Variable(randn({2, 5, 8}, 2)), {}, {},
                                   Tensor(), o); },
               {"mha_cross", "batch"});
  expect_error([&] { ag::mha_cross(ag::Variable(randn({1, 3, 4}, 1)), ag::Variable(randn({1, 5, 6}, 2)), {}, {},
                                   Tensor(), o); },
               {"mha_cross", "2 * heads * d"});
}
