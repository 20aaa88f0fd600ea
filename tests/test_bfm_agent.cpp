// test_bfm_agent.cpp — FbAgent behaviour: B on the sphere, Eq 2 latents on a toy embedding with a known answer
// and through the agent, Polyak targets, acting, Eq 21 action KL, determinism for a seed, save/load resume
// bit-identical, config JSON and bad input, and small convergence runs (FB loss on a fixed toy MDP batch; BC).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "autograd/autograd.h"
#include "models/bfm/fb_agent.h"
#include "models/bfm/fb_networks.h"
#include "models/bfm/fb_optimizer.h"
#include "models/bfm/latent_inference.h"
#include "models/bfm/polyak.h"
#include "tensor/ops.h"
#include "test_tensor_util.h"

namespace {

using namespace t2m;
using t2m::testing::expect_error;
using t2m::testing::random_tensor;

bfm::FbConfig tiny_config() {
  bfm::FbConfig c;
  c.obs_dim = 6;
  c.action_dim = 3;
  c.z_dim = 4;
  c.hidden = 16;
  c.b_hidden = 16;
  return c;
}

bfm::FbBatch random_batch(const bfm::FbConfig& c, int64_t n, uint32_t seed, bfm::FbAgent& agent, Generator& gen) {
  bfm::FbBatch b;
  b.obs = random_tensor({n, c.obs_dim}, DType::f32, seed);
  b.action = random_tensor({n, c.action_dim}, DType::f32, seed + 1, -1, 1);
  b.next_obs = random_tensor({n, c.obs_dim}, DType::f32, seed + 2);
  b.not_done = Tensor::ones({n, 1});
  b.z = agent.sample_sphere_z((int)n, gen);
  return b;
}

std::string tmp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("t2m_test_bfm_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

bool same_params(const bfm::FbAgent& a, const bfm::FbAgent& b) {
  const auto pa = a.named_parameters(), pb = b.named_parameters();
  if (pa.size() != pb.size()) return false;
  for (size_t i = 0; i < pa.size(); ++i)
    if (pa[i].first != pb[i].first || t2m::max_abs_diff(pa[i].second.data(), pb[i].second.data()) != 0) return false;
  return true;
}

// ---- Eq 2 ------------------------------------------------------------------------------------------------

TEST(BfmLatents, TrackingLatentsKnownAnswer) {
  // b_t = e_{t mod 2} * 2 (d = 2, already of norm sqrt(d)... scaled: the projection fixes the norm anyway).
  // n = 5 rows: e0, e1, e0, e1, e0. L = 2: windows {0,1},{1,2},{2,3},{3,4},{4}: means (1,1)/.. -> Proj.
  const Tensor b = Tensor::from_vector(std::vector<float>{1, 0, 0, 1, 1, 0, 0, 1, 3, 0}, {5, 2});
  const Tensor z = bfm::tracking_latents(b, 2);
  ASSERT_EQ(z.shape(), (Shape{5, 2}));
  const double r = std::sqrt(2.0);
  for (int t = 0; t < 4; ++t) {  // mean of e0 and e1 (or e1 and e0/3e0 for t = 3)
    const double x = (t == 3) ? 3.0 : 1.0, y = 1.0, n = std::hypot(x, y);
    EXPECT_NEAR(z.at({t, 0}), r * x / n, 1e-6) << t;
    EXPECT_NEAR(z.at({t, 1}), r * y / n, 1e-6) << t;
  }
  EXPECT_NEAR(z.at({4, 0}), r, 1e-6);  // H = 1 at the end: Proj(b_4)
  EXPECT_NEAR(z.at({4, 1}), 0.0, 1e-6);
  // L = 1: z_t = Proj(b_t); L >= n: z_t = Proj(mean of the tail)
  const Tensor z1 = bfm::tracking_latents(b, 1);
  EXPECT_NEAR(z1.at({2, 0}), r, 1e-6);
  const Tensor zn = bfm::tracking_latents(b, 100);
  const double x0 = 1 + 1 + 3, y0 = 2, n0 = std::hypot(x0, y0);
  EXPECT_NEAR(zn.at({0, 0}), r * x0 / n0, 1e-6);
  EXPECT_NEAR(zn.at({0, 1}), r * y0 / n0, 1e-6);
  expect_error([&] { bfm::tracking_latents(b, 0); }, {"tracking_latents", "L"});
  expect_error([] { bfm::tracking_latents(Tensor::zeros({0, 3}), 2); }, {"tracking_latents"});
}

TEST(BfmLatents, TrackingLatentsMatchNaiveWindows) {
  const Tensor b = random_tensor({11, 3}, DType::f64, 3);
  for (int L : {1, 3, 8, 20}) {
    const Tensor z = bfm::tracking_latents(b, L);
    for (int64_t t = 0; t < 11; ++t) {
      const int64_t H = std::min<int64_t>(L, 11 - t);
      double m[3] = {0, 0, 0}, n = 0;
      for (int64_t k = 0; k < H; ++k)
        for (int j = 0; j < 3; ++j) m[j] += b.at({t + k, j}) / H;
      for (double v : m) n += v * v;
      for (int j = 0; j < 3; ++j) EXPECT_NEAR(z.at({t, j}), std::sqrt(3.0) * m[j] / std::sqrt(n), 1e-12);
    }
  }
}

TEST(BfmLatents, AgentEq2UsesTheStatesAfterTheFirst) {
  bfm::FbAgent agent(tiny_config(), 3);
  const Tensor states = random_tensor({9, 6}, DType::f32, 4);
  const Tensor z = agent.infer_tracking_z(states);
  ASSERT_EQ(z.shape(), (Shape{8, 4}));  // T_z = T - 1
  const Tensor want = bfm::tracking_latents(agent.embed_backward(states.slice(0, 1, 9)), 8);
  EXPECT_EQ(t2m::max_abs_diff(z, want), 0.0);
  // the last latent only sees the last state: Proj(B(s_T)) = B(s_T)
  const Tensor last = agent.embed_backward(states.slice(0, 8, 9));
  EXPECT_LE(t2m::max_abs_diff(z.slice(0, 7, 8), last), 1e-5);
  expect_error([&] { agent.infer_tracking_z(states.slice(0, 0, 1)); }, {"FbAgent", "at least 2 states"});
  expect_error([&] { agent.infer_tracking_z(random_tensor({4, 5}, DType::f32, 1)); }, {"FbAgent", "[4, 5]"});
}

// ---- networks, acting ------------------------------------------------------------------------------------

TEST(BfmAgent, BackwardMapAndSphereSamplesHaveRadiusSqrtD) {
  bfm::FbAgent agent(tiny_config(), 1);
  Generator gen(2);
  for (const Tensor& z : {agent.embed_backward(random_tensor({7, 6}, DType::f32, 5)), agent.sample_sphere_z(9, gen)}) {
    const Tensor n = t2m::sqrt(t2m::sum(t2m::square(z), {1}));
    EXPECT_LE(t2m::max_abs_diff(n, Tensor::full(n.shape(), 2.0)), 1e-5);
  }
}

TEST(BfmAgent, ActIsTheClippedNoisyMean) {
  bfm::FbAgent agent(tiny_config(), 1);
  Generator gen(2);
  const Tensor s = random_tensor({5, 6}, DType::f32, 6);
  const Tensor z = agent.sample_sphere_z(5, gen);
  const Tensor mu = agent.actor_mean(s, z);
  Tensor a;
  const uint64_t off = gen.offset();
  agent.act(s, z, 0.f, gen, a);
  EXPECT_EQ(t2m::max_abs_diff(a, mu), 0.0);
  EXPECT_EQ(gen.offset(), off);
  Tensor b = Tensor::zeros({5, 3});
  const float* storage = b.data<float>();
  agent.act(s, z, 0.5f, gen, b);
  EXPECT_EQ(b.data<float>(), storage);  // written in place
  const double dev = t2m::amax(t2m::abs(t2m::sub(b, mu))).item();
  EXPECT_GT(dev, 0.0);
  EXPECT_LE(dev, 0.3 + 1e-6);  // actor_clip
  EXPECT_LE(t2m::amax(t2m::abs(b)).item(), 1.0);
}

TEST(BfmAgent, ActionKlEq21) {
  bfm::FbAgent agent(tiny_config(), 1);
  Generator gen(2);
  const Tensor s = random_tensor({6, 6}, DType::f32, 7);
  const Tensor z1 = agent.sample_sphere_z(6, gen), z2 = agent.sample_sphere_z(6, gen);
  EXPECT_EQ(agent.action_kl(s, z1, z1), 0.0);
  const Tensor d = t2m::sub(agent.actor_mean(s, z1), agent.actor_mean(s, z2));
  const double want = t2m::sum(t2m::square(d)).item() / 6 / (2 * 0.2 * 0.2);
  EXPECT_NEAR(agent.action_kl(s, z1, z2), want, 1e-5 * want);
}

// ---- update mechanics ------------------------------------------------------------------------------------

TEST(BfmAgent, TargetsStartEqualAndFollowPolyak) {
  bfm::FbAgent agent(tiny_config(), 4);
  const auto online = agent.backward_map().parameters(), target = agent.backward_target().parameters();
  for (size_t i = 0; i < online.size(); ++i) {
    EXPECT_EQ(t2m::max_abs_diff(online[i].data(), target[i].data()), 0.0);
    EXPECT_FALSE(target[i].requires_grad());
  }
  std::vector<Tensor> before;
  for (const auto& t : target) before.push_back(t.data().clone());
  Generator gen(5);
  agent.update(random_batch(agent.config(), 8, 10, agent, gen), gen);
  for (size_t i = 0; i < online.size(); ++i) {
    // t' = 0.99 t + 0.01 p'
    const Tensor want = t2m::add(t2m::mul(before[i], 0.99), t2m::mul(online[i].data(), 0.01));
    EXPECT_LE(t2m::max_abs_diff(target[i].data(), want), 1e-7);
    EXPECT_GT(t2m::max_abs_diff(target[i].data(), before[i]), 0.0);
  }
}

TEST(BfmAgent, PolyakUpdateValuesAndErrors) {
  ag::Variable t(Tensor::from_vector(std::vector<float>{1, 2}, {2})), p(Tensor::from_vector(std::vector<float>{3, 6}, {2}));
  bfm::polyak_update({t}, {p}, 0.25);
  EXPECT_FLOAT_EQ(t.data().at({0}), 1.5f);
  EXPECT_FLOAT_EQ(t.data().at({1}), 3.0f);
  expect_error([&] { bfm::polyak_update({t}, {p}, 1.5); }, {"polyak_update", "tau"});
  expect_error([&] { bfm::polyak_update({t}, {ag::Variable(Tensor::zeros({3}))}, 0.5); }, {"polyak_update", "[3]"});
}

TEST(BfmAgent, DeterministicForASeed) {
  const bfm::FbConfig c = tiny_config();
  bfm::FbAgent a(c, 11), b(c, 11), other(c, 12);
  EXPECT_TRUE(same_params(a, b));
  EXPECT_FALSE(same_params(a, other));
  Generator ga(1), gb(1);
  for (int i = 0; i < 3; ++i) {
    const bfm::FbUpdateStats sa = a.update(random_batch(c, 8, 20 + i, a, ga), ga);
    const bfm::FbUpdateStats sb = b.update(random_batch(c, 8, 20 + i, b, gb), gb);
    EXPECT_EQ(sa.fb_loss, sb.fb_loss);
    EXPECT_EQ(sa.actor_loss, sb.actor_loss);
  }
  EXPECT_TRUE(same_params(a, b));
  EXPECT_EQ(ga.offset(), gb.offset());
}

TEST(BfmAgent, SaveLoadResumesBitIdentically) {
  const bfm::FbConfig c = tiny_config();
  const std::string path = tmp_path("resume.t2mckpt");
  bfm::FbAgent a(c, 21);
  Generator ga(3);
  auto batch = [&](bfm::FbAgent& ag, Generator& g, int i) {
    bfm::FbBatch b = random_batch(c, 8, 40 + i, ag, g);
    b.bc_obs = b.obs;
    b.bc_action = b.action;
    b.bc_z = b.z;
    return b;
  };
  for (int i = 0; i < 3; ++i) a.update(batch(a, ga, i), ga);
  {
    nn::TrainState ts = a.train_state({{"run", "test"}});
    ts.generator("data", ga);
    ts.save(path);
  }
  for (int i = 3; i < 6; ++i) a.update(batch(a, ga, i), ga);

  bfm::FbAgent b(c, 99);  // other weights: everything must come from the file
  Generator gb(777);
  nn::TrainState ts = b.train_state({{"run", "test"}});
  ts.generator("data", gb);
  ts.load(path);
  EXPECT_EQ(ts.step, 3);
  EXPECT_EQ(b.updates(), 3);
  for (int i = 3; i < 6; ++i) b.update(batch(b, gb, i), gb);
  EXPECT_TRUE(same_params(a, b));
  EXPECT_EQ(b.updates(), 6);
  for (size_t i = 0; i < a.optimizer().params().size(); ++i)
    EXPECT_EQ(t2m::max_abs_diff(a.optimizer().state("exp_avg_sq", i), b.optimizer().state("exp_avg_sq", i)), 0.0);

  // agent-only shorthand and a config mismatch (nothing changes on failure)
  a.save(path);
  bfm::FbAgent c2(c, 5);
  c2.load(path);
  EXPECT_TRUE(same_params(a, c2));
  bfm::FbConfig wider = c;
  wider.hidden = 32;
  bfm::FbAgent w(wider, 5), w0(wider, 5);
  expect_error([&] { w.load(path); }, {"FbAgent", "config mismatch", "hidden"});
  EXPECT_TRUE(same_params(w, w0));
  expect_error([&] { w.load(path + ".missing"); }, {"FbAgent"});
  // a truncated file and a flipped byte are refused (checksum), and the agent is unchanged
  const auto size = std::filesystem::file_size(path);
  std::filesystem::resize_file(path, size / 2);
  bfm::FbAgent c3(c, 5), c3ref(c, 5);
  expect_error([&] { c3.load(path); }, {"FbAgent", path});
  a.save(path);
  {
    std::FILE* f = std::fopen(path.c_str(), "r+b");
    ASSERT_NE(f, nullptr);
    std::fseek(f, (long)(size * 3 / 4), SEEK_SET);
    const int ch = std::fgetc(f);
    std::fseek(f, (long)(size * 3 / 4), SEEK_SET);
    std::fputc(ch ^ 0x5a, f);
    std::fclose(f);
  }
  expect_error([&] { c3.load(path); }, {"FbAgent", "checksum"});
  EXPECT_TRUE(same_params(c3, c3ref));
  std::filesystem::remove(path);
}

TEST(BfmAgent, ConfigJsonAndBadInput) {
  bfm::FbConfig c = tiny_config();
  c.bc_coef = 0.25f;
  c.q_normalize = false;
  const bfm::FbConfig r = bfm::FbConfig::from_json(c.to_json());
  EXPECT_EQ(r.to_json(), c.to_json());
  expect_error([] { bfm::FbConfig::from_json({{"z_dimm", 3}}); }, {"unknown config key 'z_dimm'"});
  expect_error([] { bfm::FbConfig::from_json({{"z_dim", "x"}}); }, {"z_dim", "bad value"});
  expect_error([] { bfm::FbConfig::from_json({{"tau", 2.0}}); }, {"tau"});
  bfm::FbConfig bad = c;
  bad.ensemble = 0;
  expect_error([&] { bfm::FbAgent x(bad, 1); }, {"FbAgent", "ensemble"});
  bfm::FbAgent agent(c, 1);
  Generator gen(1);
  bfm::FbBatch b = random_batch(c, 8, 50, agent, gen);
  bfm::FbBatch wrong = b;
  wrong.action = Tensor::zeros({8, 4});
  expect_error([&] { agent.update(wrong, gen); }, {"FbAgent", "action", "[8, 4]"});
  wrong = b;
  wrong.not_done = Tensor::ones({7});
  expect_error([&] { agent.update(wrong, gen); }, {"FbAgent", "not_done"});
  wrong = b;
  wrong.bc_obs = b.obs;
  expect_error([&] { agent.update_actor(wrong, gen); }, {"FbAgent", "bc_action"});
  wrong = b;
  wrong.obs = b.obs.slice(0, 0, 1);
  expect_error([&] { agent.update_fb(wrong, gen); }, {"FbAgent", "at least 2"});
  Tensor a;
  expect_error([&] { agent.act(b.obs, b.z.slice(0, 0, 3), 0.f, gen, a); }, {"FbAgent", "z"});
}

// ---- convergence -----------------------------------------------------------------------------------------

TEST(BfmAgent, FbLossDecreasesOnAFixedToyMdpBatch) {
  // Toy MDP: 8 discrete states (one-hot observations), s' = s + 1 mod 8 whatever the action. On a fixed batch of
  // all 8 transitions with fixed z the FB TD loss (+ ortho) must go down a lot with a larger learning rate.
  bfm::FbConfig c = tiny_config();
  c.obs_dim = 8;
  c.lr_fb = c.lr_actor = 3e-3f;
  bfm::FbAgent agent(c, 7);
  Generator gen(8);
  bfm::FbBatch b;
  b.obs = Tensor::zeros({8, 8});
  b.next_obs = Tensor::zeros({8, 8});
  for (int i = 0; i < 8; ++i) {
    b.obs.data<float>()[i * 8 + i] = 1;
    b.next_obs.data<float>()[i * 8 + (i + 1) % 8] = 1;
  }
  b.action = random_tensor({8, 3}, DType::f32, 60, -1, 1);
  b.not_done = Tensor::ones({8});
  b.z = agent.sample_sphere_z(8, gen);
  b.next_action_noise = Tensor::zeros({8, 3});
  b.action_noise = Tensor::zeros({8, 3});
  float first = 0, last = 0, first_orth = 0, last_orth = 0;
  for (int i = 0; i < 300; ++i) {
    const bfm::FbUpdateStats st = agent.update(b, gen);
    if (i == 0) first = st.fb_loss, first_orth = st.ortho_loss;
    last = st.fb_loss, last_orth = st.ortho_loss;
  }
  EXPECT_LT(last, first - 1.0f) << first << " -> " << last;
  EXPECT_LT(last_orth, first_orth) << first_orth << " -> " << last_orth;
}

TEST(BfmAgent, BehaviourCloningFitsDataActions) {
  bfm::FbConfig c = tiny_config();
  c.lr_fb = c.lr_actor = 3e-3f;
  c.bc_coef = 10.f;
  bfm::FbAgent agent(c, 9);
  Generator gen(10);
  bfm::FbBatch b = random_batch(c, 16, 70, agent, gen);
  b.bc_obs = b.obs;
  b.bc_action = random_tensor({16, 3}, DType::f32, 71, -0.8, 0.8);
  b.bc_z = b.z;
  float first = 0, last = 0;
  for (int i = 0; i < 300; ++i) {
    const bfm::FbUpdateStats st = agent.update(b, gen);
    if (i == 0) first = st.bc_loss;
    last = st.bc_loss;
  }
  EXPECT_LT(last, 0.2f * first) << first << " -> " << last;
}

}  // namespace
