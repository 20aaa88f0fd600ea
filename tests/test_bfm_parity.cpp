// test_bfm_parity.cpp — the FB agent against PyTorch (the anchor's FBAgent, ../shared/anchor/torch_ref.py) on
// the committed fixture tests/fixtures/bfm/fb_parity.t2mckpt (made by tests/fixtures/make_fb_fixture.py; no
// Python needed here): network outputs, target M, FB + ortho loss and every F/B parameter gradient, the actor
// loss and actor gradients (anchor objective and ours with normalised Q + BC), and all parameters after one full
// update (AdamW + Polyak). Error measure per tensor: max |ours - torch| / max |torch| <= 1e-4 (float32).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "autograd/autograd.h"
#include "models/bfm/fb_agent.h"
#include "models/bfm/fb_networks.h"
#include "nn/checkpoint.h"
#include "tensor/ops.h"

namespace {

using namespace t2m;

const nn::Checkpoint& fixture() {
  static const nn::Checkpoint ck =
      nn::Checkpoint::load(std::string(T2M_SOURCE_DIR) + "/tests/fixtures/bfm/fb_parity.t2mckpt");
  return ck;
}

double rel_err(const Tensor& ours, const Tensor& ref) {
  EXPECT_EQ(ours.numel(), ref.numel());
  const double scale = std::max(t2m::amax(t2m::abs(ref)).item(), 1e-30);
  return t2m::max_abs_diff(ours.reshape(ref.shape()), ref) / scale;
}

void expect_close(const Tensor& ours, const std::string& ref_name, double tol = 1e-4) {
  const Tensor& ref = fixture().get(ref_name);
  EXPECT_LE(rel_err(ours, ref), tol) << ref_name;
}

bfm::FbConfig fixture_config() {
  const auto& m = fixture().meta;
  bfm::FbConfig c;
  c.obs_dim = m.at("obs");
  c.action_dim = m.at("action");
  c.z_dim = m.at("z");
  c.hidden = m.at("hidden");
  c.b_hidden = m.at("b_hidden");
  c.discount = m.at("discount");
  c.tau = m.at("tau");
  c.ortho_coef = m.at("ortho_coef");
  c.pessimism = m.at("pessimism");
  c.lr_fb = c.lr_actor = m.at("lr");
  c.bc_coef = 0;
  c.q_normalize = false;  // the anchor's plain -Q
  return c;
}

std::unique_ptr<bfm::FbAgent> fixture_agent(const bfm::FbConfig& c) {
  auto agent = std::make_unique<bfm::FbAgent>(c, 1);
  agent->load_from(fixture(), "param.");
  return agent;
}

bfm::FbBatch fixture_batch() {
  const auto& ck = fixture();
  bfm::FbBatch b;
  b.obs = ck.get("in.obs");
  b.action = ck.get("in.action");
  b.next_obs = ck.get("in.next_obs");
  b.not_done = ck.get("in.not_done");
  b.z = ck.get("in.z");
  b.next_action_noise = ck.get("in.noise_next");
  b.action_noise = ck.get("in.noise_actor");
  return b;
}

void expect_grads(const nn::Module& m, const std::string& prefix, const std::string& ref_prefix) {
  int n = 0;
  for (const auto& [name, v] : m.named_parameters()) {
    ASSERT_TRUE(v.grad().defined()) << name;
    expect_close(v.grad(), ref_prefix + prefix + name);
    ++n;
  }
  EXPECT_GT(n, 0);
}

TEST(BfmParity, NetworkOutputsAndTargetM) {
  auto agent = fixture_agent(fixture_config());
  const bfm::FbBatch b = fixture_batch();
  ag::NoGradGuard ng;
  const ag::Variable s(b.obs), a(b.action), z(b.z), s2(b.next_obs);
  const Tensor Fs = t2m::stack({agent->forward_map(0).forward(s, a, z).data(),
                                agent->forward_map(1).forward(s, a, z).data()}, 0);
  expect_close(Fs, "out.Fs");
  expect_close(agent->backward_map().forward(s2).data(), "out.B");
  expect_close(agent->embed_backward(b.next_obs), "out.B");
}

TEST(BfmParity, FbLossAndGradients) {
  auto agent = fixture_agent(fixture_config());
  Generator gen(5);
  const bfm::FbUpdateStats st = agent->update_fb(fixture_batch(), gen);
  EXPECT_EQ(gen.offset(), 0u);  // the fixed noise replaced the draw
  const double fb = fixture().get("out.fb_total").item(), orth = fixture().get("out.ortho_loss").item();
  EXPECT_NEAR(st.fb_loss, fb, 1e-4 * std::abs(fb));
  EXPECT_NEAR(st.ortho_loss, orth, 1e-4 * std::abs(orth));
  EXPECT_NEAR(st.fb_diag + st.fb_offdiag, fixture().get("out.fb_loss").item(), 1e-4 * std::abs(fb));
  expect_grads(agent->forward_map(0), "F0.", "grad_fb.");
  expect_grads(agent->forward_map(1), "F1.", "grad_fb.");
  expect_grads(agent->backward_map(), "B.", "grad_fb.");
}

TEST(BfmParity, ActorLossAndGradients) {
  auto agent = fixture_agent(fixture_config());
  Generator gen(5);
  const bfm::FbUpdateStats st = agent->update_actor(fixture_batch(), gen);
  const double l = fixture().get("out.actor_loss").item();
  EXPECT_NEAR(st.actor_loss, l, 1e-4 * std::abs(l));
  EXPECT_NEAR(st.q_mean, fixture().get("out.q_mean").item(), 1e-4 * std::abs(l));
  expect_grads(agent->actor(), "actor.", "grad_actor.");
  for (const auto& p : agent->forward_map(0).parameters()) {
    EXPECT_FALSE(p.grad().defined());  // F is not trained in the actor step
    EXPECT_TRUE(p.requires_grad());    // and is trainable again afterwards
  }
}

TEST(BfmParity, ActorObjectiveWithNormalisedQAndBehaviourCloning) {
  bfm::FbConfig c = fixture_config();
  c.q_normalize = true;
  c.bc_coef = 0.4f;
  auto agent = fixture_agent(c);
  bfm::FbBatch b = fixture_batch();
  b.bc_obs = fixture().get("in.bc_obs");
  b.bc_action = fixture().get("in.bc_action");
  b.bc_z = fixture().get("in.bc_z");
  Generator gen(5);
  const bfm::FbUpdateStats st = agent->update_actor(b, gen);
  const double l = fixture().get("out.actor_full").item();
  EXPECT_NEAR(st.actor_loss, l, 1e-4 * std::abs(l));
  EXPECT_NEAR(st.bc_loss, fixture().get("out.bc_loss").item(), 1e-4 * fixture().get("out.bc_loss").item());
  expect_grads(agent->actor(), "actor.", "grad_actor_full.");
}

TEST(BfmParity, OneFullUpdate) {
  auto agent = fixture_agent(fixture_config());
  Generator gen(5);
  agent->update(fixture_batch(), gen);
  EXPECT_EQ(agent->updates(), 1);
  for (const auto& [name, v] : agent->named_parameters()) {
    expect_close(v.data(), "after." + name);
    // the AdamW step itself (after - before) agrees too (~lr sign(g) on the first step, so loosely). Not for the
    // targets: their Polyak change (~1e-6) is a few float32 ulps of the weight, all rounding.
    if (name.find("_target") != std::string::npos) continue;
    const Tensor ours = t2m::sub(v.data(), fixture().get("param." + name));
    const Tensor ref = t2m::sub(fixture().get("after." + name), fixture().get("param." + name));
    EXPECT_LE(rel_err(ours, ref), 2e-2) << name;
  }
}

}  // namespace
