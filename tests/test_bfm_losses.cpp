// test_bfm_losses.cpp — the FB agent's losses (models/bfm/fb_loss.h, actor_loss.h) and the sphere projection:
// values against naive loops and closed forms, float64 finite-difference gradchecks (alone and through tiny
// networks, i.e. the FB loss, ortho loss and actor loss as the agent evaluates them), error messages.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "autograd/autograd.h"
#include "models/bfm/actor_loss.h"
#include "models/bfm/fb_loss.h"
#include "models/bfm/fb_networks.h"
#include "models/bfm/sphere_projection.h"
#include "tensor/ops.h"
#include "test_tensor_util.h"

namespace {

using namespace t2m;
using ag::Variable;
using VV = std::vector<Variable>;
using t2m::testing::expect_error;
using t2m::testing::random_tensor;

void expect_gradcheck(const ag::GradcheckFn& f, const std::vector<Tensor>& in) {
  ag::GradcheckResult r = ag::gradcheck(f, in);
  EXPECT_TRUE(r.ok) << r.message;
}

// Naive: sum_e [0.5 sum_{i!=j} d^2 / (B(B-1)) - sum_i d_ii / B], d = X - g_i T_ij.
double naive_odl(const Tensor& X, const Tensor& T, const Tensor& g) {
  const int64_t E = X.size(0), B = X.size(1);
  double off = 0, dg = 0;
  for (int64_t e = 0; e < E; ++e)
    for (int64_t i = 0; i < B; ++i)
      for (int64_t j = 0; j < B; ++j) {
        const double d = X.at({e, i, j}) - (T.defined() ? g.at({i}) * T.at({i, j}) : 0.0);
        if (i == j) dg += d;
        else off += d * d;
      }
  return 0.5 * off / (double)(B * (B - 1)) - dg / (double)B;
}

TEST(BfmFbLoss, OffdiagDiagMatchesNaiveAndParts) {
  const Tensor X = random_tensor({2, 5, 5}, DType::f64, 1), T = random_tensor({5, 5}, DType::f64, 2);
  const Tensor g = random_tensor({5}, DType::f64, 3, 0, 1);
  bfm::FbLossParts parts;
  const double got = bfm::offdiag_diag_loss(Variable(X), T, g, &parts).item();
  EXPECT_NEAR(got, naive_odl(X, T, g), 1e-12);
  EXPECT_NEAR(parts.offdiag + parts.diag, got, 1e-12);
  EXPECT_NEAR(bfm::offdiag_diag_loss(Variable(X), Tensor(), Tensor()).item(), naive_odl(X, Tensor(), Tensor()), 1e-12);
  // float32 agrees with float64
  EXPECT_NEAR(bfm::offdiag_diag_loss(Variable(X.to(DType::f32)), T.to(DType::f32), g.to(DType::f32)).item(), got,
              1e-5 * std::abs(got) + 1e-6);
}

TEST(BfmFbLoss, OffdiagDiagGradcheck) {
  const Tensor T = random_tensor({4, 4}, DType::f64, 5), g = random_tensor({4}, DType::f64, 6, 0, 1);
  expect_gradcheck([&](const VV& v) { return bfm::offdiag_diag_loss(v[0], T, g); },
                   {random_tensor({2, 4, 4}, DType::f64, 4)});
}

TEST(BfmFbLoss, FbTdAndOrthoGradcheck) {
  const Tensor tM = random_tensor({4, 4}, DType::f64, 7), g = random_tensor({4}, DType::f64, 8, 0.5, 1);
  expect_gradcheck([&](const VV& v) { return bfm::fb_td_loss(v[0], v[1], tM, g); },
                   {random_tensor({2, 4, 3}, DType::f64, 9), random_tensor({4, 3}, DType::f64, 10)});
  expect_gradcheck([&](const VV& v) { return bfm::ortho_loss(v[0]); }, {random_tensor({4, 3}, DType::f64, 11)});
}

TEST(BfmFbLoss, OrthoOfOrthonormalRowsIsMinusOne) {
  // B(s) rows = the unit vectors: Cov = I, off-diagonal 0, diagonal mean 1.
  Tensor e = Tensor::zeros({3, 3}, DType::f64);
  for (int64_t i = 0; i < 3; ++i) e.data<double>()[i * 3 + i] = 1.0;
  EXPECT_NEAR(bfm::ortho_loss(Variable(e)).item(), -1.0, 1e-15);
}

TEST(BfmFbLoss, PessimisticValuesAndGradcheck) {
  const Tensor x = Tensor::from_vector(std::vector<double>{1, -2, 3, 0.5, 2, 3}, {2, 3});
  // mean - 0.5 |x0 - x1| / 2
  const std::vector<double> want = {0.75 - 0.125, 0 - 1.0, 3 - 0.0};
  const Tensor got = bfm::pessimistic(Variable(x), 0.5).data();
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(got.at({i}), want[i], 1e-15);
  // 3 members: mean - p * mean pairwise |diff| / 2
  const Tensor x3 = Tensor::from_vector(std::vector<double>{1, 2, 4}, {3, 1});
  EXPECT_NEAR(bfm::pessimistic(Variable(x3), 0.5).data().at({0}), 7.0 / 3 - 0.5 * (1 + 3 + 2) / 3.0 / 2, 1e-14);
  EXPECT_NEAR(bfm::pessimistic(Variable(x3.slice(0, 0, 1)), 0.5).data().at({0}), 1.0, 0);
  expect_gradcheck([](const VV& v) { return bfm::pessimistic(v[0], 0.5); }, {random_tensor({2, 5}, DType::f64, 12)});
  expect_gradcheck([](const VV& v) { return bfm::pessimistic(v[0], 0.7); }, {random_tensor({3, 4}, DType::f64, 13)});
}

TEST(BfmActorLoss, QLossBcAndGradchecks) {
  const Tensor Q = random_tensor({2, 6}, DType::f64, 14);
  double qm = 0;
  const double l = bfm::actor_q_loss(Variable(Q), 0.5, false, &qm).item();
  EXPECT_NEAR(l, -qm, 1e-15);
  EXPECT_NEAR(qm, t2m::mean(bfm::pessimistic(Variable(Q), 0.5).data()).item(), 1e-15);
  const Tensor pq = bfm::pessimistic(Variable(Q), 0.5).data();
  EXPECT_NEAR(bfm::actor_q_loss(Variable(Q), 0.5, true).item(), -qm / t2m::mean(t2m::abs(pq)).item(), 1e-14);
  expect_gradcheck([](const VV& v) { return bfm::actor_q_loss(v[0], 0.5, false); }, {Q});
  // Normalised: the scale is a constant (no gradient through it): grad = unnormalised grad / mean|Q|.
  Variable qv(Q, true);
  bfm::actor_q_loss(qv, 0.5, true).backward();
  Variable qu(Q, true);
  bfm::actor_q_loss(qu, 0.5, false).backward();
  const double scale = t2m::mean(t2m::abs(pq)).item();
  for (int64_t i = 0; i < Q.numel(); ++i)
    EXPECT_NEAR(qv.grad().data<double>()[i], qu.grad().data<double>()[i] / scale, 1e-14);
  const Tensor a = random_tensor({3, 2}, DType::f64, 15, -1, 1);
  const Tensor mu = random_tensor({3, 2}, DType::f64, 16, -1, 1);
  EXPECT_NEAR(bfm::bc_loss(Variable(mu), a).item(), t2m::mean(t2m::square(t2m::sub(mu, a))).item(), 1e-15);
  expect_gradcheck([&](const VV& v) { return bfm::bc_loss(v[0], a); }, {mu});
  expect_gradcheck([](const VV& v) { return bfm::q_values(v[0], v[1]); },
                   {random_tensor({2, 3, 4}, DType::f64, 17), random_tensor({3, 4}, DType::f64, 18)});
}

TEST(BfmActorLoss, NoiseIsClippedAndActionsClamped) {
  Generator gen(3);
  const Tensor n = bfm::policy_noise({64, 8}, 0.2, 0.3, gen);
  EXPECT_LE(t2m::amax(t2m::abs(n)).item(), 0.3 + 1e-7);
  EXPECT_GT(t2m::amax(t2m::abs(n)).item(), 0.25);  // 512 draws of N(0, 0.04): some reach the clip
  Generator g0(3);
  EXPECT_EQ(t2m::amax(t2m::abs(bfm::policy_noise({2, 2}, 0.0, 0.3, g0))).item(), 0.0);
  EXPECT_EQ(g0.offset(), 0u);
  const Tensor mu = Tensor::from_vector(std::vector<float>{0.9f, -0.95f, 0.1f}, {1, 3});
  const Tensor noise = Tensor::from_vector(std::vector<float>{0.2f, -0.2f, 0.2f}, {1, 3});
  const Tensor a = bfm::noisy_action(Variable(mu), noise).data();
  EXPECT_FLOAT_EQ(a.at({0, 0}), 1.f);
  EXPECT_FLOAT_EQ(a.at({0, 1}), -1.f);
  EXPECT_NEAR(a.at({0, 2}), 0.3, 1e-7);
  expect_error([] { Generator g; bfm::policy_noise({2}, -1, 0, g); }, {"policy_noise", "std"});
}

TEST(BfmSphere, ProjectionRadiusAndGradcheck) {
  const Tensor u = random_tensor({5, 7}, DType::f64, 19);
  const Tensor y = bfm::sphere_project(Variable(u), 3.0).data();
  for (int64_t i = 0; i < 5; ++i) {
    double n = 0;
    for (int64_t k = 0; k < 7; ++k) n += y.at({i, k}) * y.at({i, k});
    EXPECT_NEAR(std::sqrt(n), 3.0, 1e-12);
    EXPECT_NEAR(y.at({i, 0}) / y.at({i, 1}), u.at({i, 0}) / u.at({i, 1}), 1e-12);  // same direction
  }
  EXPECT_EQ(t2m::max_abs_diff(bfm::project_rows(u, 3.0), y), 0.0);
  expect_gradcheck([](const VV& v) { return bfm::sphere_project(v[0], 8.0); }, {random_tensor({3, 4}, DType::f64, 20)});
  // a zero row stays zero (no NaN)
  const Tensor z = bfm::project_rows(Tensor::zeros({1, 4}), 2.0);
  EXPECT_EQ(t2m::amax(t2m::abs(z)).item(), 0.0);
  expect_error([] { bfm::sphere_project(Variable(Tensor::scalar(1.0)), 1.0); }, {"sphere_project", "1 dim"});
  expect_error([] { bfm::project_rows(Tensor::ones({2, 2}), 0.0); }, {"sphere_project", "radius"});
}

TEST(BfmFbLoss, BadShapes) {
  expect_error([] { bfm::offdiag_diag_loss(Variable(Tensor::zeros({2, 3, 4})), Tensor(), Tensor()); },
               {"offdiag_diag_loss", "[2, 3, 4]"});
  expect_error([] { bfm::offdiag_diag_loss(Variable(Tensor::zeros({1, 1, 1})), Tensor(), Tensor()); },
               {"offdiag_diag_loss", "batch"});
  expect_error([] { bfm::offdiag_diag_loss(Variable(Tensor::zeros({1, 3, 3})), Tensor::zeros({3, 2}), Tensor()); },
               {"target", "[3, 2]"});
  expect_error([] { bfm::fb_td_loss(Variable(Tensor::zeros({2, 3, 4})), Variable(Tensor::zeros({3, 5})), Tensor(),
                                    Tensor()); },
               {"fb_td_loss", "[3, 5]"});
  expect_error([] { bfm::q_values(Variable(Tensor::zeros({2, 3, 4})), Variable(Tensor::zeros({2, 4}))); },
               {"q_values"});
  expect_error([] { bfm::bc_loss(Variable(Tensor::zeros({2, 3})), Tensor::zeros({3, 2})); }, {"bc_loss"});
}

// ---- the losses through tiny networks, float64 (what FbAgent::update_fb / update_actor differentiate) -------

constexpr int64_t kD = 3, kA = 2, kZ = 3, kH = 4, kN = 4;

struct TinyNets {
  Generator gen{77};
  bfm::ForwardMap F0{kD, kA, kZ, kH, gen}, F1{kD, kA, kZ, kH, gen};
  bfm::BackwardMap Bm{kD, kZ, kH, gen};
  bfm::Actor actor{kD, kA, kZ, kH, gen};
  TinyNets() {
    for (nn::Module* m : std::vector<nn::Module*>{&F0, &F1, &Bm, &actor}) m->to(DType::f64);
  }
};

TEST(BfmLossesThroughNetworks, FbLossGradcheck) {
  TinyNets n;
  const Tensor tM = random_tensor({kN, kN}, DType::f64, 21), g = random_tensor({kN}, DType::f64, 22, 0.5, 1);
  const Tensor z = bfm::project_rows(random_tensor({kN, kZ}, DType::f64, 23), std::sqrt((double)kZ));
  // inputs: s, a, s'
  expect_gradcheck(
      [&](const VV& v) {
        const Variable zv(z);
        const Variable F = ag::stack({n.F0.forward(v[0], v[1], zv), n.F1.forward(v[0], v[1], zv)}, 0);
        const Variable Bv = n.Bm.forward(v[2]);
        return bfm::fb_td_loss(F, Bv, tM, g) + bfm::ortho_loss(Bv);
      },
      {random_tensor({kN, kD}, DType::f64, 24), random_tensor({kN, kA}, DType::f64, 25, -0.9, 0.9),
       random_tensor({kN, kD}, DType::f64, 26)});
}

TEST(BfmLossesThroughNetworks, ActorLossGradcheck) {
  TinyNets n;
  const Tensor noise = random_tensor({kN, kA}, DType::f64, 27, -0.05, 0.05);
  const Tensor a_data = random_tensor({kN, kA}, DType::f64, 28, -0.9, 0.9);
  // inputs: s, z (the latent is differentiable through F, the actor and Q = F^T z)
  expect_gradcheck(
      [&](const VV& v) {
        const Variable a = bfm::noisy_action(n.actor.forward(v[0], v[1]), noise);
        const Variable F = ag::stack({n.F0.forward(v[0], a, v[1]), n.F1.forward(v[0], a, v[1])}, 0);
        return bfm::actor_q_loss(bfm::q_values(F, v[1]), 0.5, false) +
               bfm::bc_loss(n.actor.forward(v[0], v[1]), a_data) * 0.4;
      },
      {random_tensor({kN, kD}, DType::f64, 29), random_tensor({kN, kZ}, DType::f64, 30)});
}

}  // namespace
