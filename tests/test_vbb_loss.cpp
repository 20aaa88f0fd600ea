// test_vbb_loss.cpp — the VBB objective (models/text2bfm/vbb_loss.h) with a linear toy actor standing in for the
// frozen BFM policy: values of Eq 5 and Eq 6 against formulas written out here, float64 finite-difference checks
// of every term (Eq 5 w.r.t. ẑ, Eq 6 w.r.t. mu/logvar, Eq 7–12 w.r.t. the program and every head parameter,
// Eq 13 w.r.t. all model outputs), masks, the no-L_sem ablation, frozen-actor semantics and bad input.
#include <gtest/gtest.h>

#include <cmath>

#include "autograd/gradcheck.h"
#include "autograd/no_grad.h"
#include "autograd/ops_elementwise.h"
#include "autograd/ops_linalg.h"
#include "autograd/ops_reduce.h"
#include "autograd/ops_shape.h"
#include "autograd/ops_unary.h"
#include "models/text2bfm/vbb_loss.h"
#include "nn/linear.h"
#include "nn/loss_frame_token.h"
#include "tensor/ops.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

using namespace t2m;
using namespace t2m::text2bfm;
using t2m::testing::expect_error;
using t2m::testing::raw_get;

namespace {

Tensor randn(const Shape& s, uint64_t seed, DType dt = DType::f64) {
  Generator g(seed);
  return rand_normal(s, g, 0.0, 1.0, dt);
}

// π(a | s, z) = N(s Ws^T + z Wz^T, exp(tanh(z Wl^T) / 2)^2): a frozen linear-Gaussian toy actor (no grad on W).
struct ToyActor {
  int64_t S, d, A;
  Tensor Ws, Wz, Wl;
  ToyActor(int64_t S_, int64_t d_, int64_t A_) : S(S_), d(d_), A(A_) {
    Ws = randn({A, S}, 31);
    Wz = randn({A, d}, 32);
    Wl = randn({A, d}, 33);
  }
  ActorGaussian operator()(const ag::Variable& s, const ag::Variable& z) const {
    ag::Variable mean = ag::add(nn::linear(s, ag::Variable(Ws), {}), nn::linear(z, ag::Variable(Wz), {}));
    return {mean, ag::mul(ag::tanh(nn::linear(z, ag::Variable(Wl), {})), 0.5)};
  }
  // Plain-loop KL(π(·|s, zh) || π(·|s, z)) at one frame (raw element access, no ag ops).
  double kl(const Tensor& s, const Tensor& zh, const Tensor& z, int64_t b, int64_t t) const {
    double k = 0;
    for (int64_t a = 0; a < A; ++a) {
      double m1 = 0, m2 = 0, l1 = 0, l2 = 0;
      for (int64_t i = 0; i < S; ++i) {
        m1 += raw_get(Ws, {a, i}) * raw_get(s, {b, t, i});
      }
      m2 = m1;
      for (int64_t i = 0; i < d; ++i) {
        m1 += raw_get(Wz, {a, i}) * raw_get(zh, {b, t, i});
        m2 += raw_get(Wz, {a, i}) * raw_get(z, {b, t, i});
        l1 += raw_get(Wl, {a, i}) * raw_get(zh, {b, t, i});
        l2 += raw_get(Wl, {a, i}) * raw_get(z, {b, t, i});
      }
      l1 = 0.5 * std::tanh(l1);
      l2 = 0.5 * std::tanh(l2);
      const double v1 = std::exp(2 * l1), v2 = std::exp(2 * l2);
      k += l2 - l1 + (v1 + (m1 - m2) * (m1 - m2)) / (2 * v2) - 0.5;
    }
    return k;
  }
};

Tensor frame_mask_2x4() { return Tensor::from_vector(std::vector<double>{1, 1, 1, 0, 1, 1, 0, 0}, {2, 4}); }

}  // namespace

TEST(VbbLoss, ReconstructionValueMatchesEq5) {
  const int64_t B = 2, T = 4, d = 3, S = 5, A = 2;
  ToyActor actor(S, d, A);
  Tensor zh = randn({B, T, d}, 1), z = randn({B, T, d}, 2), s = randn({B, T, S}, 3), w = frame_mask_2x4();
  for (bool masked : {false, true}) {
    VbbReconstruction r =
        vbb_reconstruction_loss(ag::Variable(zh), z, s, std::cref(actor), 0.1, masked ? w : Tensor());
    double mse = 0, kl = 0, n = 0;
    for (int64_t b = 0; b < B; ++b)
      for (int64_t t = 0; t < T; ++t) {
        if (masked && raw_get(w, {b, t}) == 0) continue;
        for (int64_t i = 0; i < d; ++i) mse += std::pow(raw_get(zh, {b, t, i}) - raw_get(z, {b, t, i}), 2);
        kl += actor.kl(s, zh, z, b, t);
        n += 1;
      }
    EXPECT_NEAR(r.latent_mse.item(), mse / n, 1e-12);
    EXPECT_NEAR(r.action_kl.item(), kl / n, 1e-12);
    EXPECT_NEAR(r.loss.item(), mse / n + 0.1 * kl / n, 1e-12);
  }
  // ẑ = z: both terms vanish.
  VbbReconstruction r0 = vbb_reconstruction_loss(ag::Variable(z), z, s, std::cref(actor), 0.1);
  EXPECT_NEAR(r0.loss.item(), 0.0, 1e-14);
  // No actor or λπ = 0: the KL term is skipped.
  EXPECT_FALSE(vbb_reconstruction_loss(ag::Variable(zh), z, s, FrozenActor(), 0.1).action_kl.defined());
  EXPECT_FALSE(vbb_reconstruction_loss(ag::Variable(zh), z, Tensor(), std::cref(actor), 0.0).action_kl.defined());
}

TEST(VbbLoss, ReconstructionGradcheckAndFrozenActor) {
  const int64_t B = 2, T = 4, d = 3, S = 5, A = 2;
  ToyActor actor(S, d, A);
  Tensor z = randn({B, T, d}, 2), s = randn({B, T, S}, 3), w = frame_mask_2x4();
  for (bool masked : {false, true}) {
    ag::GradcheckResult r = ag::gradcheck(
        [&](const std::vector<ag::Variable>& v) {
          return vbb_reconstruction_loss(v[0], z, s, std::cref(actor), 0.1, masked ? w : Tensor()).loss;
        },
        {randn({B, T, d}, 1)});
    EXPECT_TRUE(r.ok) << r.message;
  }
  // The KL term alone (λπ large so the latent MSE does not dominate the check).
  ag::GradcheckResult r = ag::gradcheck(
      [&](const std::vector<ag::Variable>& v) {
        return vbb_reconstruction_loss(v[0], z, s, std::cref(actor), 1.0, w).action_kl;
      },
      {randn({B, T, d}, 4)});
  EXPECT_TRUE(r.ok) << r.message;
  // Padded frames get no gradient; the reference side π(·|s, z) records no graph.
  ag::Variable zh(randn({B, T, d}, 5), true);
  vbb_reconstruction_loss(zh, z, s, std::cref(actor), 0.1, w).loss.backward();
  EXPECT_EQ(max_abs_diff(zh.grad().slice(1, 3, 4).slice(0, 0, 1), Tensor::zeros({1, 1, d}, DType::f64)), 0.0);
  EXPECT_EQ(max_abs_diff(zh.grad().slice(1, 2, 4).slice(0, 1, 2), Tensor::zeros({1, 2, d}, DType::f64)), 0.0);
  EXPECT_GT(max_abs_diff(zh.grad(), Tensor::zeros({B, T, d}, DType::f64)), 0.0);
  bool ref_had_graph = true;
  FrozenActor spy = [&](const ag::Variable& st, const ag::Variable& zz) {
    if (!zz.requires_grad()) ref_had_graph = ag::GradMode::is_enabled();
    return actor(st, zz);
  };
  vbb_reconstruction_loss(zh, z, s, spy, 0.1);
  EXPECT_FALSE(ref_had_graph);
}

TEST(VbbLoss, PriorKlValueAndGradcheck) {
  const int64_t B = 2, C = 3, Tm = 2;
  Tensor mu = randn({B, C, Tm}, 6), lv = randn({B, C, Tm}, 7);
  Tensor pm = Tensor::from_vector(std::vector<double>{1, 1, 1, 0}, {B, Tm});
  for (bool masked : {false, true}) {
    double k = 0, n = 0;
    for (int64_t b = 0; b < B; ++b)
      for (int64_t c = 0; c < C; ++c)
        for (int64_t t = 0; t < Tm; ++t) {
          if (masked && raw_get(pm, {b, t}) == 0) continue;
          const double m = raw_get(mu, {b, c, t}), l = raw_get(lv, {b, c, t});
          k += 0.5 * (m * m + std::exp(l) - 1 - l);
          n += 1;
        }
    EXPECT_NEAR(vbb_prior_kl(ag::Variable(mu), ag::Variable(lv), masked ? pm : Tensor()).item(), k / n, 1e-12);
    ag::GradcheckResult r = ag::gradcheck(
        [&](const std::vector<ag::Variable>& v) { return vbb_prior_kl(v[0], v[1], masked ? pm : Tensor()); },
        {mu, lv});
    EXPECT_TRUE(r.ok) << r.message;
  }
}

TEST(VbbLoss, SemanticLossGradcheckEveryHeadParameter) {
  const int64_t B = 3, latent = 2, Tm = 2, K = 3, Dy = 4, D = 3;
  Generator g(8);
  VbbSemanticHead head(latent, Dy, D, g);
  head.to(DType::f64);
  Tensor tok = randn({B, K, Dy}, 9);
  Tensor tmask = Tensor::from_vector(std::vector<double>{1, 1, 1, 1, 1, 0, 1, 0, 0}, {B, K});
  Tensor pmask = Tensor::from_vector(std::vector<double>{1, 1, 1, 0, 1, 1}, {B, Tm});
  nn::FrameTokenOptions fo;
  fo.lambda_tok = 0.5;
  fo.lambda_frm = 0.5;
  // Value: the same as the projections written out, fed to the nn loss.
  Tensor m = randn({B, latent, Tm}, 10);
  auto P = [&](const std::string& n) {
    for (auto& [k, v] : head.named_parameters())
      if (k == n) return v;
    return ag::Variable();
  };
  ag::Variable pm = ag::add(ag::matmul(ag::transpose(ag::Variable(m), 1, 2), ag::transpose(P("pm.weight"), 0, 1)),
                            P("pm.bias"));
  ag::Variable py = ag::add(ag::matmul(ag::Variable(tok), ag::transpose(P("py.weight"), 0, 1)), P("py.bias"));
  const double want = nn::frame_token_contrastive_loss(pm, pmask, py, tmask, P("alpha"), fo).loss.item();
  EXPECT_NEAR(vbb_semantic_loss(head, ag::Variable(m), pmask, tok, tmask, fo).loss.item(), want, 1e-12);
  EXPECT_NEAR(head.alpha().item(), std::log(1 / 0.07), 1e-6);

  std::vector<ag::Variable> params = head.parameters();
  std::vector<Tensor> inputs{m};
  for (auto& p : params) {
    if (p.numel() == 1) p.data().fill_(1.3);  // alpha inside the clamp range [0, ln 100] with a non-trivial γ
    inputs.push_back(p.data().clone());
  }
  ag::GradcheckResult r = ag::gradcheck(
      [&](const std::vector<ag::Variable>& v) {
        for (size_t i = 0; i < params.size(); ++i) {
          ag::Variable alias = ag::mul(v[i + 1], 1.0);
          params[i].impl()->data = alias.data();
          params[i].impl()->grad_fn = alias.grad_fn();
        }
        return vbb_semantic_loss(head, v[0], pmask, tok, tmask, fo).loss;
      },
      inputs);
  for (auto& p : params) p.impl()->grad_fn = nullptr;
  EXPECT_TRUE(r.ok) << r.message;
}

TEST(VbbLoss, TotalIsEq13AndGradcheck) {
  const int64_t B = 3, Tz = 4, d = 3, S = 2, A = 2, latent = 2, Tm = 2, K = 2, Dy = 3;
  ToyActor actor(S, d, A);
  Generator g(11);
  VbbSemanticHead head(latent, Dy, 4, g);
  head.to(DType::f64);
  VbbTargets tg;
  tg.z = randn({B, Tz, d}, 12);
  tg.states = randn({B, Tz, S}, 13);
  tg.frame_mask = Tensor::from_vector(std::vector<double>{1, 1, 1, 1, 1, 1, 1, 0, 1, 1, 0, 0}, {B, Tz});
  tg.program_mask = program_mask_from_frames(tg.frame_mask, 2);
  EXPECT_EQ(tg.program_mask.to_vector<float>(), (std::vector<float>{1, 1, 1, 1, 1, 0}));
  tg.tokens = randn({B, K, Dy}, 14);
  VbbLossOptions opt;
  EXPECT_EQ(opt.lambda_pi, 0.1);
  EXPECT_EQ(opt.beta, 1e-4);
  EXPECT_EQ(opt.lambda_sem, 0.35);
  opt.beta = 0.3;  // larger than the paper's 1e-4 so that the KL term is visible in the check
  auto out_of = [&](const std::vector<ag::Variable>& v) { return VbbOutput{v[0], v[1], v[2], v[3]}; };
  std::vector<Tensor> in{randn({B, Tz, d}, 15), randn({B, latent, Tm}, 16), randn({B, latent, Tm}, 17),
                         randn({B, latent, Tm}, 18)};
  std::vector<ag::Variable> vin;
  for (auto& t : in) vin.emplace_back(t);
  VbbLossTerms t = vbb_loss(out_of(vin), tg, std::cref(actor), &head, opt);
  EXPECT_NEAR(t.total.item(), t.rec.loss.item() + 0.3 * t.kl.item() + 0.35 * t.sem.item(), 1e-12);
  EXPECT_NEAR(t.rec.loss.item(), t.rec.latent_mse.item() + 0.1 * t.rec.action_kl.item(), 1e-12);
  // Ablation "VBB without L_sem": no head (or λsem = 0) drops the term.
  VbbLossTerms t2 = vbb_loss(out_of(vin), tg, std::cref(actor), nullptr, opt);
  EXPECT_FALSE(t2.sem.defined());
  EXPECT_NEAR(t2.total.item(), t.rec.loss.item() + 0.3 * t.kl.item(), 1e-12);
  ag::GradcheckResult r = ag::gradcheck(
      [&](const std::vector<ag::Variable>& v) { return vbb_loss(out_of(v), tg, std::cref(actor), &head, opt).total; },
      in);
  EXPECT_TRUE(r.ok) << r.message;
}

TEST(VbbLoss, BadInput) {
  ToyActor actor(2, 3, 2);
  Tensor z = randn({2, 4, 3}, 1), s = randn({2, 4, 2}, 2);
  ag::Variable zh(randn({2, 4, 3}, 3));
  expect_error([&] { vbb_reconstruction_loss(zh, randn({2, 5, 3}, 1), s, std::cref(actor), 0.1); },
               {"vbb_loss:", "[2, 5, 3]", "[2, 4, 3]"});
  expect_error([&] { vbb_reconstruction_loss(zh, z, randn({2, 3, 2}, 1), std::cref(actor), 0.1); },
               {"vbb_loss:", "states", "[2, 3, 2]"});
  expect_error([&] { vbb_reconstruction_loss(zh, z, s, std::cref(actor), -1.0); }, {"vbb_loss:", "lambda_pi"});
  FrozenActor bad = [](const ag::Variable& st, const ag::Variable&) { return ActorGaussian{st.flatten(0, 1), st}; };
  expect_error([&] { vbb_reconstruction_loss(zh, z, s, bad, 0.1); }, {"vbb_loss:", "actor"});
  expect_error([&] { vbb_reconstruction_loss(zh, z, s, std::cref(actor), 0.1, Tensor::ones({2, 5})); },
               {"frame_mask"});
  expect_error([&] { vbb_prior_kl(ag::Variable(randn({2, 3}, 1)), ag::Variable(randn({2, 3}, 1))); },
               {"vbb_loss:", "mu"});
  expect_error([&] { program_mask_from_frames(Tensor::ones({2, 6}), 4); }, {"vbb_loss:", "Tz = 6", "4"});
  Generator g(1);
  VbbSemanticHead head(2, 3, 4, g);
  expect_error([&] { vbb_semantic_loss(head, ag::Variable(randn({2, 2, 2}, 1, DType::f32)), {}, Tensor(), {}); },
               {"vbb_loss:", "token"});
  expect_error([&] { head.project_tokens(ag::Variable(randn({2, 2, 5}, 1, DType::f32))); },
               {"vbb_semantic_head:", "[2, 2, 5]"});
  expect_error([&] { VbbSemanticHead h(0, 3, 4, g); }, {"vbb_semantic_head:"});
}
