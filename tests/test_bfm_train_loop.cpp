// test_bfm_train_loop.cpp — the BFM training loop on a tiny config: bit-identical resume, config mismatch and
// missing files on resume; Eq 2 window latents vs FbAgent::infer_tracking_z; the training z mix; the policy
// checkpoint (round trip, bad files); BFM tracking evaluation with the PD baseline's scorer; the hips-only seed
// expert.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "models/bfm/policy_checkpoint.h"
#include "models/bfm/track_eval.h"
#include "models/bfm/trainer.h"
#include "nn/checkpoint.h"
#include "tensor/ops.h"
#include "test_bfm_sway.h"
#include "test_scratch_dir.h"

using namespace t2m;
using namespace t2m::bfm;
namespace fs = std::filesystem;

using t2m::test::humanoid;
using t2m::test::swaying;

namespace {
std::string tmp_dir(const std::string& name) {
  return t2m::test::scratch_dir(name).string();
}

const RefMotions& toy_refs() {
  static const RefMotions r = [] {
    RefMotions x;
    x.add(*humanoid(), "a", swaying(*humanoid(), 14, 0.05));
    x.add(*humanoid(), "b", swaying(*humanoid(), 20, 0.1));
    return x;
  }();
  return r;
}

BfmTrainConfig tiny_config() {
  BfmTrainConfig c;
  c.fb.hidden = 16;
  c.fb.b_hidden = 16;
  c.fb.z_dim = 6;
  c.fb.track_window = 3;
  c.seed = 5;
  c.seed_transitions = 120;
  c.envs = 2;
  c.max_episode_steps = 10;
  c.total_updates = 100;
  c.offline_updates = 2;
  c.collect_every = 2;
  c.collect_transitions = 12;
  c.online_capacity = 40;
  c.batch = 16;
  c.bc_batch = 8;
  return c;
}

std::vector<std::vector<float>> params_of(FbAgent& a) {
  std::vector<std::vector<float>> out;
  for (const auto& [n, v] : a.named_parameters()) out.push_back(v.data().to_vector<float>());
  return out;
}
}  // namespace

TEST(BfmTrainLoop, ResumeIsBitIdentical) {
  const std::string d1 = tmp_dir("straight"), d2 = tmp_dir("chunks");
  std::vector<std::vector<float>> straight;
  std::vector<float> straight_online;
  {
    BfmTrainer t(tiny_config(), humanoid(), toy_refs(), d1);
    EXPECT_FALSE(t.resumed());
    t.prepare_seed();
    EXPECT_EQ(t.seed_buffer().size(), 120);
    for (int i = 0; i < 7; ++i) {
      const BfmStepStats s = t.train_step();
      EXPECT_TRUE(std::isfinite(s.fb.fb_loss));
      EXPECT_EQ(s.collected, i >= 2 && i % 2 == 0);
    }
    EXPECT_EQ(t.online_buffer().size(), 36);
    straight = params_of(t.agent());
    for (int64_t r = 0; r < t.online_buffer().size(); ++r)
      straight_online.insert(straight_online.end(), t.online_buffer().obs_row(r),
                             t.online_buffer().obs_row(r) + 313);
  }
  {
    BfmTrainer t(tiny_config(), humanoid(), toy_refs(), d2);
    t.prepare_seed();
    for (int i = 0; i < 3; ++i) t.train_step();
    t.save();
  }
  {
    BfmTrainer t(tiny_config(), humanoid(), toy_refs(), d2);  // resumes at step 3
    EXPECT_TRUE(t.resumed());
    EXPECT_EQ(t.step(), 3);
    t.prepare_seed();  // loads the same seed buffer
    for (int i = 0; i < 4; ++i) t.train_step();
    const auto p = params_of(t.agent());
    ASSERT_EQ(p.size(), straight.size());
    for (size_t k = 0; k < p.size(); ++k) EXPECT_EQ(p[k], straight[k]) << "parameter " << k;
    std::vector<float> online;
    for (int64_t r = 0; r < t.online_buffer().size(); ++r)
      online.insert(online.end(), t.online_buffer().obs_row(r), t.online_buffer().obs_row(r) + 313);
    EXPECT_EQ(online, straight_online);
  }
  // A seed buffer recollected from scratch is the same (pure function of the config).
  EXPECT_EQ(ReplayBuffer::load(d1 + "/seed_buffer.t2mckpt").sample(64, *std::make_unique<Generator>(1)).obs
                .to_vector<float>(),
            ReplayBuffer::load(d2 + "/seed_buffer.t2mckpt").sample(64, *std::make_unique<Generator>(1)).obs
                .to_vector<float>());
}

TEST(BfmTrainLoop, ResumeRejectsOtherConfigAndMissingFiles) {
  const std::string d = tmp_dir("reject");
  {
    BfmTrainer t(tiny_config(), humanoid(), toy_refs(), d);
    t.prepare_seed();
    for (int i = 0; i < 3; ++i) t.train_step();
    t.save();
  }
  BfmTrainConfig other = tiny_config();
  other.batch = 12;
  EXPECT_THROW(BfmTrainer(other, humanoid(), toy_refs(), d), Error);
  other = tiny_config();
  other.total_updates = 500;  // extending a run is allowed
  EXPECT_NO_THROW(BfmTrainer(other, humanoid(), toy_refs(), d));
  // The seed buffer is required on resume.
  fs::rename(d + "/seed_buffer.t2mckpt", d + "/seed.bak");
  {
    BfmTrainer t(tiny_config(), humanoid(), toy_refs(), d);
    EXPECT_THROW(t.prepare_seed(), Error);
  }
  fs::rename(d + "/seed.bak", d + "/seed_buffer.t2mckpt");
  // The online buffer named by the state is required.
  for (const auto& e : fs::directory_iterator(d))
    if (e.path().filename().string().rfind("online-", 0) == 0) fs::remove(e.path());
  EXPECT_THROW(BfmTrainer(tiny_config(), humanoid(), toy_refs(), d), Error);
  BfmTrainConfig bad = tiny_config();
  bad.z_track = 0.9;
  bad.z_goal = 0.3;
  EXPECT_THROW(BfmTrainer(bad, humanoid(), toy_refs(), tmp_dir("bad")), Error);
  EXPECT_THROW(BfmTrainConfig::from_json({{"no_such_key", 1}}), Error);
  EXPECT_EQ(BfmTrainConfig::from_json(tiny_config().to_json()).to_json(), tiny_config().to_json());
}

// --seed-expert balance-hips: the balance expert with its root torque through the stance hips only labels the seed
// rows (and the DAgger rows); same start states, other expert actions. Unknown experts are rejected.
TEST(BfmTrainLoop, HipsOnlyBalanceExpertLabelsTheSeedData) {
  BfmTrainConfig plain = tiny_config(), hips = tiny_config();
  hips.seed_expert = "balance-hips";
  BfmTrainer a(plain, humanoid(), toy_refs(), tmp_dir("expert_plain"));
  BfmTrainer b(hips, humanoid(), toy_refs(), tmp_dir("expert_hips"));
  a.prepare_seed();
  b.prepare_seed();
  const ReplayBuffer &sa = a.seed_buffer(), &sb = b.seed_buffer();
  ASSERT_EQ(sa.size(), sb.size());
  const int A = sa.action_dim();
  EXPECT_EQ(std::vector<float>(sa.obs_row(0), sa.obs_row(0) + sa.obs_dim()),
            std::vector<float>(sb.obs_row(0), sb.obs_row(0) + sb.obs_dim()));
  double diff = 0;
  for (int64_t i = 0; i < sa.size(); ++i)
    for (int k = 0; k < A; ++k) diff += std::fabs(sa.expert_action_row(i)[k] - sb.expert_action_row(i)[k]);
  EXPECT_GT(diff, 0.0);
  EXPECT_EQ(BfmTrainConfig::from_json(hips.to_json()).seed_expert, "balance-hips");
  BfmTrainConfig bad = tiny_config();
  bad.seed_expert = "balance-knees";
  EXPECT_THROW(BfmTrainer(bad, humanoid(), toy_refs(), tmp_dir("expert_bad")), Error);
}

TEST(BfmTrainLoop, WindowLatentsMatchAgentEq2) {
  FbAgent agent(tiny_config().fb, 3);
  const RefMotions& r = toy_refs();
  const int c = 1, T = r.frames(c);
  Tensor s = Tensor::empty({T, 313});
  std::copy(r.obs_at(c, 0), r.obs_at(c, 0) + T * 313, s.data<float>());
  const Tensor z = agent.infer_tracking_z(s);  // [T-1, d]
  std::vector<int64_t> clip(T - 1, c), frame(T - 1);
  for (int t = 0; t < T - 1; ++t) frame[t] = t;
  const Tensor w = window_latents(r, clip.data(), frame.data(), T - 1, 3, agent_encoder(agent));
  ASSERT_EQ(w.shape(), z.shape());
  for (int t = 0; t < T - 1; ++t)
    for (int j = 0; j < 6; ++j) EXPECT_NEAR(w.at({t, j}), z.at({t, j}), 1e-5) << t << " " << j;
  std::vector<int64_t> last = {T - 1};
  EXPECT_THROW(window_latents(r, clip.data(), last.data(), 1, 3, agent_encoder(agent)), Error);
}

TEST(BfmTrainLoop, TrainingZMix) {
  FbAgent agent(tiny_config().fb, 3);
  const RefMotions& r = toy_refs();
  const EncodeFn enc = agent_encoder(agent);
  const Tensor next = rand_normal({10, 313}, *std::make_unique<Generator>(9));
  Generator g1(4), g2(4);
  const Tensor a = sample_training_z(10, ZMix{0.3, 0.3}, r, 3, next, enc, 6, g1);
  const Tensor b = sample_training_z(10, ZMix{0.3, 0.3}, r, 3, next, enc, 6, g2);
  EXPECT_EQ(a.to_vector<float>(), b.to_vector<float>());
  for (int i = 0; i < 10; ++i) {
    double n2 = 0;
    for (int j = 0; j < 6; ++j) n2 += a.at({i, j}) * a.at({i, j});
    EXPECT_NEAR(std::sqrt(n2), std::sqrt(6.0), 1e-4);
  }
  // All-goal: row i is B(next_obs[(i + 5) % 10]).
  Generator g3(1);
  const Tensor goal = sample_training_z(10, ZMix{0.0, 1.0}, r, 3, next, enc, 6, g3);
  const Tensor bn = agent.embed_backward(next);
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 6; ++j) EXPECT_NEAR(goal.at({i, j}), bn.at({(i + 5) % 10, j}), 1e-5);
  // All-tracking: every row is an Eq 2 latent of some reference window.
  Generator g4(2);
  const Tensor tr = sample_training_z(8, ZMix{1.0, 0.0}, r, 3, Tensor(), enc, 6, g4);
  std::vector<int64_t> clip, frame;
  for (int c = 0; c < r.clips(); ++c)
    for (int t = 0; t + 1 < r.frames(c); ++t) clip.push_back(c), frame.push_back(t);
  const Tensor all = window_latents(r, clip.data(), frame.data(), (int64_t)clip.size(), 3, enc);
  for (int i = 0; i < 8; ++i) {
    double best = 1e9;
    for (int64_t k = 0; k < all.size(0); ++k) {
      double e = 0;
      for (int j = 0; j < 6; ++j) e += std::fabs(tr.at({i, j}) - all.at({k, j}));
      best = std::min(best, e);
    }
    EXPECT_LT(best, 1e-4) << "row " << i;
  }
  EXPECT_THROW(sample_training_z(10, ZMix{0.8, 0.3}, r, 3, next, enc, 6, g1), Error);
  EXPECT_THROW(sample_training_z(4, ZMix{0.0, 0.5}, r, 3, next, enc, 6, g1), Error);  // next_obs rows != n
}

TEST(BfmPolicyCheckpoint, RoundTripAndBadFiles) {
  FbAgent agent(tiny_config().fb, 11);
  const std::string d = tmp_dir("policy");
  save_policy(agent, d + "/p.t2mckpt", {{"updates", 7}});
  nlohmann::json info;
  auto back = load_policy(d + "/p.t2mckpt", &info);
  EXPECT_EQ(info["updates"], 7);
  const Tensor s = rand_normal({5, 313}, *std::make_unique<Generator>(2));
  const Tensor z = agent.sample_sphere_z(5, *std::make_unique<Generator>(3));
  EXPECT_EQ(back->actor_mean(s, z).to_vector<float>(), agent.actor_mean(s, z).to_vector<float>());
  EXPECT_EQ(back->embed_backward(s).to_vector<float>(), agent.embed_backward(s).to_vector<float>());
  nn::Checkpoint ck = nn::Checkpoint::load(d + "/p.t2mckpt");
  for (const auto& n : ck.names()) EXPECT_TRUE(is_policy_parameter(n)) << n;
  EXPECT_THROW(load_policy(d + "/missing.t2mckpt"), Error);
  const auto edited = [&](const std::function<void(nn::Checkpoint&)>& f) {
    nn::Checkpoint c = nn::Checkpoint::load(d + "/p.t2mckpt");
    f(c);
    c.save(d + "/e.t2mckpt");
    return d + "/e.t2mckpt";
  };
  EXPECT_THROW(load_policy(edited([](nn::Checkpoint& c) { c.meta["format"] = "t2m-replay-1"; })), Error);
  EXPECT_THROW(load_policy(edited([](nn::Checkpoint& c) { c.meta["fb"]["z_dim"] = 7; })), Error);  // shapes
  EXPECT_THROW(load_policy(edited([](nn::Checkpoint& c) { c.meta["fb"]["hidden"] = -2; })), Error);
  EXPECT_THROW(load_policy(edited([](nn::Checkpoint& c) { c.put("extra", Tensor::zeros({1})); })), Error);
  EXPECT_THROW(load_policy(edited([&](nn::Checkpoint& c) {
                 nn::Checkpoint fresh;
                 fresh.meta = c.meta;
                 for (const auto& n : c.names())
                   if (n.rfind("B.", 0) != 0) fresh.put(n, c.get(n));
                 c = fresh;
               })),
               Error);
}

TEST(BfmPolicyCheckpoint, LatentSpaceChecksumFollowsBOnly) {
  FbAgent agent(tiny_config().fb, 11);
  const std::string sum = latent_space_checksum(agent);
  EXPECT_EQ(sum.size(), 16u);
  const std::string d = tmp_dir("latent_sum");
  save_policy(agent, d + "/p.t2mckpt");
  EXPECT_EQ(latent_space_checksum(*load_policy(d + "/p.t2mckpt")), sum);  // survives the file
  const auto bump = [&](const std::string& prefix) {  // +1e-3 on the first parameter under prefix
    for (auto& [name, v] : agent.named_parameters())
      if (name.rfind(prefix, 0) == 0) {
        v.data().data<float>()[0] += 1e-3f;
        return;
      }
    FAIL() << "no parameter " << prefix;
  };
  bump("actor.");  // a fine-tuned actor: same latent space
  EXPECT_EQ(latent_space_checksum(agent), sum);
  bump("B.");  // another B: another latent space
  EXPECT_NE(latent_space_checksum(agent), sum);
  FbConfig other = tiny_config().fb;
  other.track_window += 1;  // same weights, another Eq 2 window
  FbAgent a2(other, 11), a3(tiny_config().fb, 11);
  EXPECT_NE(latent_space_checksum(a2), latent_space_checksum(a3));
}

TEST(BfmTrackEval, UsesThePdScorerOnEveryFrame) {
  FbAgent agent(tiny_config().fb, 1);
  const RefMotions& r = toy_refs();
  const auto bfm = track_bfm(agent, humanoid(), r);
  const auto pd = track_pd_all(humanoid(), r);
  ASSERT_EQ(bfm.size(), 2u);
  for (int c = 0; c < 2; ++c) {
    EXPECT_EQ(bfm[c].frames, r.frames(c));
    EXPECT_EQ(pd[c].frames, r.frames(c));
    EXPECT_GE(bfm[c].frames_ok, 1);  // frame 0 is the reference state
    EXPECT_TRUE(std::isfinite(bfm[c].mpjpe_m));
    // PD follows a slow sway for <1 s; its result equals sim::track_pd's.
    sim::Env env(humanoid());
    const sim::PdResult direct = sim::track_pd(env, r.trajectory(c));
    EXPECT_EQ(pd[c].mpjpe_m, direct.mpjpe_m);
    EXPECT_EQ(pd[c].success, direct.success);
  }
  // An untrained policy (random actions around mid-range targets) tracks worse than PD.
  EXPECT_GT(bfm[1].mpjpe_m, pd[1].mpjpe_m);
  const nlohmann::json s = summarize_tracking(pd);
  EXPECT_EQ(s["clips"], 2);
  EXPECT_NEAR(s["mpjpe_m"].get<double>(), (pd[0].mpjpe_m + pd[1].mpjpe_m) / 2, 1e-12);
  const auto kl = window_action_kl(agent, r, 1);
  ASSERT_EQ(kl.size(), 2u);
  EXPECT_GT(kl[0], 0.0);
  const auto kl_same = window_action_kl(agent, r, 3);  // z_hat = z
  EXPECT_NEAR(kl_same[0], 0.0, 1e-9);
  // The Eq 2 window of the tracking latents: the agent's own (3) by default or when given; another one changes z.
  ASSERT_EQ(agent.config().track_window, 3);
  const auto own = track_bfm(agent, humanoid(), r, {}, 3), one = track_bfm(agent, humanoid(), r, {}, 1);
  EXPECT_EQ(own[1].mpjpe_m, bfm[1].mpjpe_m);
  EXPECT_EQ(own[1].frames_ok, bfm[1].frames_ok);
  EXPECT_NE(one[1].mpjpe_m, bfm[1].mpjpe_m);
  EXPECT_THROW(track_bfm(agent, humanoid(), r, {}, -1), Error);
  // A latent map: the identity changes nothing; other latents change the rollout; another shape is refused.
  const TrackLatentMap identity = [](const Tensor& z) { return z.clone(); };
  const auto same = track_bfm(agent, humanoid(), r, {}, 0, identity);
  EXPECT_EQ(same[1].simulated.qpos, bfm[1].simulated.qpos);
  const TrackLatentMap negate = [](const Tensor& z) { return t2m::mul(z, -1.0); };
  EXPECT_NE(track_bfm(agent, humanoid(), r, {}, 0, negate)[1].simulated.qpos, bfm[1].simulated.qpos);
  const TrackLatentMap shorter = [](const Tensor& z) { return z.narrow(0, 0, 1).contiguous(); };
  EXPECT_THROW(track_bfm(agent, humanoid(), r, {}, 0, shorter), Error);
  // A standing start: frame 0 is the humanoid's qpos0 at rest, not the clip's first state; the rollout differs.
  const auto stand = track_bfm(agent, humanoid(), r, {}, 0, {}, TrackStart::standing);
  const int nq = humanoid()->model()->nq, nv = humanoid()->model()->nv;
  for (int c = 0; c < 2; ++c) {
    ASSERT_EQ(stand[c].simulated.frames, bfm[c].simulated.frames);
    for (int k = 0; k < nq; ++k) EXPECT_EQ(stand[c].simulated.qpos[k], humanoid()->model()->qpos0[k]) << k;
    for (int k = 0; k < nv; ++k) EXPECT_EQ(stand[c].simulated.qvel[k], 0.0) << k;
  }
  EXPECT_NE(stand[1].simulated.qpos, bfm[1].simulated.qpos);
  EXPECT_EQ(track_bfm(agent, humanoid(), r, {}, 0, {}, TrackStart::reference)[1].simulated.qpos,
            bfm[1].simulated.qpos);
}

TEST(BfmTrackEval, HoldableStartClipsKeepsStandingPosesOnly) {
  const sim::Humanoid& h = *humanoid();
  const int nq = h.model()->nq, r0 = h.root_qpos();
  auto still = [&](double lean) {  // qpos0 leaning forward by `lean` rad about the x axis, 3 frames
    std::vector<double> p(h.model()->qpos0, h.model()->qpos0 + nq);
    const double q[4] = {std::cos(lean / 2), std::sin(lean / 2), 0, 0};
    double out[4];
    mju_mulQuat(out, q, p.data() + r0 + 3);
    std::copy(out, out + 4, p.begin() + r0 + 3);
    return still_trajectory(p.data(), nq, h.model()->nv, 3);
  };
  RefMotions r;
  r.add(h, "leaning", still(0.6));
  r.add(h, "standing", still(0.0));
  r.add(h, "swaying", swaying(h, 14, 0.05));
  const std::vector<int> ok = holdable_start_clips(humanoid(), r, 60);  // 2 s still
  EXPECT_EQ(ok, (std::vector<int>{1, 2}));
  EXPECT_THROW(holdable_start_clips(humanoid(), r, 1), Error);
}

TEST(BfmTrackEval, ExpertImitationRmsIsTheRmsOfPolicyMinusExpertLabel) {
  FbAgent agent(tiny_config().fb, 3);
  const RefMotions& r = toy_refs();
  const std::vector<double> rms = expert_imitation_rms(agent, humanoid(), r);
  const int A = humanoid()->model()->nu;
  ASSERT_EQ((int)rms.size(), A);
  // Reference: one state at a time through the public pieces (Eq 2 latents, actor mean, expert targets).
  std::vector<double> se(A, 0.0);
  int n = 0;
  sim::Env env(humanoid());
  std::vector<double> ctrl(A);
  for (int c = 0; c < r.clips(); ++c) {
    const int T = r.frames(c);
    Tensor s = Tensor::empty({T, r.obs_dim});
    std::copy(r.obs_at(c, 0), r.obs_at(c, 0) + (size_t)T * r.obs_dim, s.data<float>());
    const Tensor z = agent.infer_tracking_z(s).contiguous();
    const sim::QposTrajectory q = r.trajectory(c);
    const sim::BalanceReference bref = sim::balance_reference(*humanoid(), q);
    for (int t = 0; t + 1 < T; ++t, ++n) {
      const Tensor mu = agent.actor_mean(s.narrow(0, t, 1).contiguous(), z.narrow(0, t, 1).contiguous()).contiguous();
      env.reset(r.qpos_at(c, t), r.qvel_at(c, t), nullptr);
      sim::balance_targets(env, bref.frame(q, t + 1), sim::BalanceOptions{}, ctrl.data());
      for (int k = 0; k < A; ++k) {
        const double e = mu.data<float>()[k] - std::clamp(env.ctrl_to_action(k, ctrl[k]), -1.0, 1.0);
        se[k] += e * e;
      }
    }
  }
  for (int k = 0; k < A; ++k) EXPECT_NEAR(rms[k], std::sqrt(se[k] / n), 1e-5) << "actuator " << k;
  double mean = 0;
  for (double x : rms) mean += x;
  EXPECT_GT(mean / A, 1e-3);  // an untrained actor is not the expert
}

TEST(BfmTrackEval, SummaryByGroupSplitsTheClips) {
  // Three results in two groups: each group's summary is summarize_tracking of its own clips; labels must match.
  std::vector<sim::PdResult> r(3);
  r[0].frames = 10, r[0].frames_ok = 10, r[0].success = true, r[0].mpjpe_m = 0.1;
  r[1].frames = 10, r[1].frames_ok = 2, r[1].fell = true, r[1].mpjpe_m = 0.9;
  r[2].frames = 20, r[2].frames_ok = 5, r[2].mpjpe_m = 0.5;
  const nlohmann::json g = summarize_tracking_by_group(r, {"walk", "wave", "walk"});
  ASSERT_EQ(g.size(), 2u);
  EXPECT_EQ(g["walk"]["clips"], 2);
  EXPECT_EQ(g["wave"]["clips"], 1);
  EXPECT_DOUBLE_EQ(g["walk"]["success_rate"].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(g["walk"]["mean_fraction_of_frames_tracked"].get<double>(), (1.0 + 0.25) / 2);
  EXPECT_DOUBLE_EQ(g["wave"]["fall_rate"].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(g["wave"]["mpjpe_m"].get<double>(), 0.9);
  EXPECT_THROW(summarize_tracking_by_group(r, {"walk", "wave"}), t2m::Error);
}
