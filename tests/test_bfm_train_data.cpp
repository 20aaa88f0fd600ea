// test_bfm_train_data.cpp — BFM training data: replay buffer (ring, sampling determinism, save/load and bad files),
// reference motions, seed collection with the noisy PD tracker (shapes, action range, determinism).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "models/bfm/collect.h"
#include "models/bfm/ref_motions.h"
#include "models/bfm/replay_buffer.h"
#include "nn/checkpoint.h"
#include "tensor/parallel.h"
#include "test_bfm_sway.h"
#include "test_scratch_dir.h"

using namespace t2m;
using namespace t2m::bfm;
namespace fs = std::filesystem;

using t2m::test::humanoid;
using t2m::test::swaying;

namespace {
std::string tmp_path(const std::string& name) {
  return (t2m::test::scratch_root() / name).string();
}

// Row i holds obs = i + k/100, action = -i, next_obs = i + 0.5, clip = i % 3, frame = i.
void fill(ReplayBuffer& b, int n, int first = 0) {
  std::vector<float> o(b.obs_dim()), a(b.action_dim()), no(b.obs_dim());
  for (int i = first; i < first + n; ++i) {
    for (int k = 0; k < b.obs_dim(); ++k) o[k] = i + k / 100.0f, no[k] = i + 0.5f;
    for (int k = 0; k < b.action_dim(); ++k) a[k] = (float)-i;
    b.add(o.data(), a.data(), no.data(), i % 5 == 0 ? 0.0f : 1.0f, i % 3, i);
  }
}

RefMotions toy_refs() {
  RefMotions r;
  r.add(*humanoid(), "a", swaying(*humanoid(), 12, 0.05));
  r.add(*humanoid(), "b", swaying(*humanoid(), 20, 0.1));
  return r;
}
}  // namespace

TEST(BfmReplay, RingOverwritesOldestRows) {
  ReplayBuffer b(5, 4, 2);
  fill(b, 3);
  EXPECT_EQ(b.size(), 3);
  EXPECT_EQ(b.cursor(), 3);
  fill(b, 4, 3);  // rows 3..6: 5 and 6 overwrite rows 0 and 1
  EXPECT_EQ(b.size(), 5);
  EXPECT_EQ(b.added(), 7);
  EXPECT_EQ(b.cursor(), 2);
  EXPECT_EQ(b.frame_at(0), 5);
  EXPECT_EQ(b.frame_at(1), 6);
  EXPECT_EQ(b.frame_at(2), 2);
  EXPECT_FLOAT_EQ(b.obs_row(1)[3], 6.03f);
  EXPECT_FLOAT_EQ(b.action_row(0)[1], -5.0f);
  EXPECT_EQ(b.not_done_at(0), 0.0f);
  EXPECT_EQ(b.clip_at(1), 0);
  EXPECT_THROW(b.obs_row(5), Error);
}

TEST(BfmReplay, AddRejectsBadValues) {
  ReplayBuffer b(4, 3, 2);
  std::vector<float> o(3, 0.f), a(2, 0.f), no(3, 0.f);
  a[1] = NAN;
  EXPECT_THROW(b.add(o.data(), a.data(), no.data(), 1.f), Error);
  a[1] = 0;
  no[2] = INFINITY;
  EXPECT_THROW(b.add(o.data(), a.data(), no.data(), 1.f), Error);
  no[2] = 0;
  EXPECT_THROW(b.add(o.data(), a.data(), no.data(), 0.5f), Error);
  EXPECT_EQ(b.size(), 0);
  EXPECT_THROW(ReplayBuffer(0, 3, 2), Error);
  EXPECT_THROW(ReplayBuffer(4, 0, 2), Error);
  Generator g(1);
  EXPECT_THROW(b.sample(4, g), Error);  // empty
  b.add(o.data(), a.data(), no.data(), 1.f);
  EXPECT_THROW(b.sample(0, g), Error);
}

TEST(BfmReplay, SamplingIsUniformDeterministicAndThreadIndependent) {
  ReplayBuffer b(1000, 8, 3);
  fill(b, 1000);
  Generator g1(42), g2(42);
  t2m::set_num_threads(1);
  const ReplayBatch x = b.sample(2048, g1);
  t2m::set_num_threads(2);
  const ReplayBatch y = b.sample(2048, g2);
  EXPECT_EQ(g1.offset(), g2.offset());
  EXPECT_EQ(x.frame.to_vector<int64_t>(), y.frame.to_vector<int64_t>());
  EXPECT_EQ(x.obs.to_vector<float>(), y.obs.to_vector<float>());
  // Rows stay consistent: every array of batch row k comes from the same buffer row.
  const auto fr = x.frame.to_vector<int64_t>();
  for (int k = 0; k < 2048; ++k) {
    EXPECT_FLOAT_EQ(x.obs.at({k, 5}), fr[k] + 0.05f);
    EXPECT_FLOAT_EQ(x.next_obs.at({k, 0}), fr[k] + 0.5f);
    EXPECT_FLOAT_EQ(x.action.at({k, 2}), -(float)fr[k]);
    EXPECT_EQ(x.clip.at({k}), fr[k] % 3);
    EXPECT_EQ(x.not_done.at({k, 0}), fr[k] % 5 == 0 ? 0.0 : 1.0);
  }
  // Uniform: each quarter of the rows gets about a quarter of the draws (binomial sd ~ 20 of 512).
  int q[4] = {0, 0, 0, 0};
  for (int64_t f : fr) ++q[f / 250];
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(q[i], 512, 100);
  // A different seed gives a different batch.
  Generator g3(43);
  EXPECT_NE(b.sample(2048, g3).frame.to_vector<int64_t>(), fr);
}

TEST(BfmReplay, SaveLoadRoundTrip) {
  ReplayBuffer b(6, 5, 2);
  fill(b, 8);  // wrapped
  const std::string p = tmp_path("rb.t2mckpt");
  b.save(p);
  EXPECT_FALSE(fs::exists(p + ".tmp"));
  const ReplayBuffer r = ReplayBuffer::load(p);
  EXPECT_EQ(r.capacity(), 6);
  EXPECT_EQ(r.size(), 6);
  EXPECT_EQ(r.cursor(), 2);
  EXPECT_EQ(r.added(), 8);
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(r.frame_at(i), b.frame_at(i));
    for (int k = 0; k < 5; ++k) EXPECT_EQ(r.obs_row(i)[k], b.obs_row(i)[k]);
  }
  Generator g1(3), g2(3);
  EXPECT_EQ(r.sample(50, g1).frame.to_vector<int64_t>(), b.sample(50, g2).frame.to_vector<int64_t>());
  // A partly filled buffer round-trips too (its rows beyond size are not written).
  ReplayBuffer c(10, 5, 2);
  fill(c, 3);
  c.save(p);
  EXPECT_EQ(ReplayBuffer::load(p).size(), 3);
}

TEST(BfmReplay, ExpertLabelsAreStoredSampledAndSaved) {
  ReplayBuffer b(6, 5, 2, /*with_expert_labels=*/true), plain(6, 5, 2);
  ASSERT_TRUE(b.has_expert_labels());
  std::vector<float> o(5, 1.0f), a(2, 0.5f), e(2);
  for (int i = 0; i < 8; ++i) {  // wraps
    e[0] = (float)i, e[1] = -(float)i;
    b.add(o.data(), a.data(), o.data(), 1.0f, 0, i, e.data());
  }
  EXPECT_THROW(b.add(o.data(), a.data(), o.data(), 1.0f, 0, 0), Error);                 // label missing
  EXPECT_THROW(plain.add(o.data(), a.data(), o.data(), 1.0f, 0, 0, e.data()), Error);   // label not wanted
  e[0] = NAN;
  EXPECT_THROW(b.add(o.data(), a.data(), o.data(), 1.0f, 0, 0, e.data()), Error);
  EXPECT_THROW(plain.expert_action_row(0), Error);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(b.expert_action_row(i)[0], (float)b.frame_at(i));
  Generator g(4);
  const ReplayBatch s = b.sample(20, g);
  ASSERT_EQ(s.expert_action.shape(), (Shape{20, 2}));
  for (int k = 0; k < 20; ++k) {
    EXPECT_EQ(s.expert_action.data<float>()[2 * k], (float)s.frame.data<int64_t>()[k]);
    EXPECT_EQ(s.expert_action.data<float>()[2 * k + 1], -(float)s.frame.data<int64_t>()[k]);
  }
  const std::string p = tmp_path("rb_labels.t2mckpt");
  b.save(p);
  const ReplayBuffer r = ReplayBuffer::load(p);
  ASSERT_TRUE(r.has_expert_labels());
  for (int i = 0; i < 6; ++i) EXPECT_EQ(r.expert_action_row(i)[1], b.expert_action_row(i)[1]);
  fill(plain, 3);
  plain.save(p);
  EXPECT_FALSE(ReplayBuffer::load(p).has_expert_labels());
}

TEST(BfmReplay, LoadRejectsBadFiles) {
  ReplayBuffer b(6, 5, 2);
  fill(b, 4);
  const std::string good = tmp_path("good.t2mckpt");
  b.save(good);
  EXPECT_THROW(ReplayBuffer::load(tmp_path("missing.t2mckpt")), Error);
  // Truncated file (checksum / size check).
  {
    std::ifstream f(good, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(f)), {});
    const std::string p = tmp_path("trunc.t2mckpt");
    std::ofstream(p, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    EXPECT_THROW(ReplayBuffer::load(p), Error);
    std::ofstream(p, std::ios::binary) << "not a checkpoint at all";
    EXPECT_THROW(ReplayBuffer::load(p), Error);
  }
  // Valid checkpoints with bad content.
  const auto edit = [&](const std::function<void(nn::Checkpoint&)>& f) {
    nn::Checkpoint ck = nn::Checkpoint::load(good);
    f(ck);
    const std::string p = tmp_path("edited.t2mckpt");
    ck.save(p);
    return p;
  };
  EXPECT_THROW(ReplayBuffer::load(edit([](nn::Checkpoint& ck) { ck.meta["format"] = "t2m-train-state"; })), Error);
  EXPECT_THROW(ReplayBuffer::load(edit([](nn::Checkpoint& ck) { ck.meta["size"] = 7; })), Error);  // > capacity
  EXPECT_THROW(ReplayBuffer::load(edit([](nn::Checkpoint& ck) { ck.meta["cursor"] = 1; })), Error);
  EXPECT_THROW(ReplayBuffer::load(edit([](nn::Checkpoint& ck) { ck.meta.erase("obs_dim"); })), Error);
  EXPECT_THROW(ReplayBuffer::load(edit([](nn::Checkpoint& ck) { ck.meta["obs_dim"] = 4; })), Error);  // shapes
  EXPECT_THROW(ReplayBuffer::load(edit([](nn::Checkpoint& ck) {
                 Tensor o = ck.get("obs").clone();
                 o.set({1, 2}, NAN);
                 ck.put("obs", o);
               })),
               Error);
  EXPECT_THROW(ReplayBuffer::load(edit([](nn::Checkpoint& ck) {
                 Tensor d = ck.get("not_done").clone();
                 d.set({0}, 0.5);
                 ck.put("not_done", d);
               })),
               Error);
  EXPECT_THROW(ReplayBuffer::load(edit([](nn::Checkpoint& ck) { ck.put("clip", Tensor::zeros({4})); })), Error);
  EXPECT_NO_THROW(ReplayBuffer::load(edit([](nn::Checkpoint&) {})));
}

TEST(BfmRefs, ClipIndexingAndTrajectories) {
  const RefMotions r = toy_refs();
  EXPECT_EQ(r.clips(), 2);
  EXPECT_EQ(r.total_frames(), 32);
  EXPECT_EQ(r.obs_dim, 313);
  EXPECT_EQ(r.global_frame(1, 3), 15);
  EXPECT_EQ(r.body_pos.size(), (size_t)32 * 21 * 3);
  const sim::QposTrajectory q = r.trajectory(1, 4, 5);
  EXPECT_EQ(q.frames, 5);
  EXPECT_EQ(q.qpos[0], r.qpos_at(1, 4)[0]);
  EXPECT_THROW(r.obs_at(0, 12), Error);
  EXPECT_THROW(r.obs_at(2, 0), Error);
  EXPECT_THROW(r.trajectory(0, 10, 5), Error);
  RefMotions bad;
  EXPECT_THROW(bad.add(*humanoid(), "short", swaying(*humanoid(), 1, 0.0)), Error);
}

TEST(BfmRefs, StaticHoldsAreStillPosesOfQpos0AndClipStarts) {
  RefMotions r = toy_refs();
  append_static_holds(r, r, *humanoid(), spread_indices(2, 2), 7);
  ASSERT_EQ(r.clips(), 5);  // 2 clips + qpos0 + the first frames of both clips
  EXPECT_EQ(r.names[2], "hold:qpos0");
  EXPECT_EQ(r.names[3], "hold:a");
  EXPECT_EQ(r.names[4], "hold:b");
  EXPECT_EQ(r.total_frames(), 32 + 3 * 7);
  const int nq = r.nq, nv = r.nv, D = r.obs_dim;
  for (int t = 0; t < 7; ++t) {
    for (int k = 0; k < nq; ++k) {
      EXPECT_EQ(r.qpos_at(2, t)[k], humanoid()->model()->qpos0[k]);
      EXPECT_EQ(r.qpos_at(4, t)[k], r.qpos_at(1, 0)[k]);
    }
    for (int k = 0; k < nv; ++k) EXPECT_EQ(r.qvel_at(3, t)[k], 0.0);
    for (int k = 0; k < D; ++k) EXPECT_EQ(r.obs_at(3, t)[k], r.obs_at(3, 0)[k]);  // a still state every frame
  }
  // The first clip's start pose differs from its later frames (it sways); the hold keeps frame 0.
  EXPECT_NE(r.qpos_at(0, 5)[humanoid()->hinge_qpos(0)], r.qpos_at(3, 5)[humanoid()->hinge_qpos(0)]);
  RefMotions only;  // holds into another set: the poses of the source's clips
  append_static_holds(only, toy_refs(), *humanoid(), spread_indices(2, 1), 3);
  ASSERT_EQ(only.clips(), 2);
  EXPECT_EQ(only.names[1], "hold:a");
  EXPECT_EQ(only.qpos_at(1, 2)[humanoid()->hinge_qpos(0)], r.qpos_at(0, 0)[humanoid()->hinge_qpos(0)]);
  EXPECT_THROW(append_static_holds(r, r, *humanoid(), {-1}, 7), Error);
  EXPECT_THROW(append_static_holds(r, r, *humanoid(), {5}, 7), Error);
  EXPECT_THROW(append_static_holds(r, r, *humanoid(), {0}, 1), Error);
  EXPECT_EQ(spread_indices(10, 4), (std::vector<int>{0, 2, 5, 7}));
  EXPECT_EQ(spread_indices(3, 5), (std::vector<int>{0, 1, 2}));
  EXPECT_TRUE(spread_indices(0, 5).empty());
}

TEST(BfmCollect, SeedDataShapesRangeAndDeterminism) {
  const RefMotions refs = toy_refs();
  CollectOptions o;
  o.envs = 3;
  o.max_episode_steps = 7;
  o.action_noise = 0.3;
  ReplayBuffer b1(100, refs.obs_dim, 60), b2(100, refs.obs_dim, 60);
  TrackingCollector c(humanoid(), refs, o);
  Generator g1(7), g2(7);
  t2m::set_num_threads(1);
  const CollectStats s = c.collect_expert(40, g1, b1);
  t2m::set_num_threads(2);
  TrackingCollector c2(humanoid(), refs, o);
  c2.collect_expert(40, g2, b2);
  EXPECT_EQ(s.transitions, 40);
  EXPECT_EQ(b1.size(), 40);
  EXPECT_GT(s.episodes, 3);  // episodes of at most 7 steps in 14 steps per env
  EXPECT_LE(s.mean_episode_steps(), 7.0);
  int clipped = 0;
  for (int i = 0; i < 40; ++i) {
    for (int k = 0; k < 60; ++k) {
      const float a = b1.action_row(i)[k];
      EXPECT_GE(a, -1.0f);
      EXPECT_LE(a, 1.0f);
      clipped += std::fabs(a) == 1.0f;
      EXPECT_EQ(a, b2.action_row(i)[k]);
    }
    for (int k = 0; k < refs.obs_dim; ++k) EXPECT_EQ(b1.next_obs_row(i)[k], b2.next_obs_row(i)[k]);
    const int clip = (int)b1.clip_at(i), t = (int)b1.frame_at(i);
    ASSERT_TRUE(clip == 0 || clip == 1);
    ASSERT_GE(t, 0);
    ASSERT_LT(t + 1, refs.frames(clip));
    EXPECT_EQ(b1.not_done_at(i), 1.0f);
  }
  EXPECT_LT(clipped, 40 * 60 / 4);  // noise 0.3 around mid-range targets rarely hits the bounds
  // Consecutive rows of one env's episode chain: s' of step t is s of step t+1 (rows of env 0 are 0, 3, 6, ...).
  int chained = 0;
  for (int i = 0; i + 3 < 40; i += 3)
    if (b1.frame_at(i + 3) == b1.frame_at(i) + 1 && b1.clip_at(i + 3) == b1.clip_at(i)) {
      ++chained;
      for (int k = 0; k < refs.obs_dim; ++k) ASSERT_EQ(b1.obs_row(i + 3)[k], b1.next_obs_row(i)[k]);
    }
  EXPECT_GT(chained, 5);
  // The first row starts in the reference state: its obs is the reference's s_t.
  for (int k = 0; k < refs.obs_dim; ++k)
    EXPECT_NEAR(b1.obs_row(0)[k], refs.obs_at((int)b1.clip_at(0), (int)b1.frame_at(0))[k], 1e-4);
}

TEST(BfmCollect, NoiselessPdActionIsTheTrackerTarget) {
  // With zero noise, the stored action maps back (Env::action_to_ctrl) to the PD target qref[t+1] + kd/kp qdref.
  const RefMotions refs = toy_refs();
  CollectOptions o;
  o.envs = 1;
  o.action_noise = 0;
  o.expert = Expert::pd;
  ReplayBuffer b(10, refs.obs_dim, 60);
  TrackingCollector c(humanoid(), refs, o);
  Generator g(1);
  c.collect_expert(3, g, b);
  sim::Env env(humanoid());
  const mjModel* m = humanoid()->model();
  const int clip = (int)b.clip_at(0), t = (int)b.frame_at(0);
  for (int k = 0; k < 60; ++k) {
    const int jid = m->actuator_trnid[2 * k];
    const double target = refs.qpos_at(clip, t + 1)[m->jnt_qposadr[jid]] +
                          m->dof_damping[m->jnt_dofadr[jid]] / m->actuator_gainprm[mjNGAIN * k] *
                              refs.qvel_at(clip, t + 1)[m->jnt_dofadr[jid]];
    const double lo = m->actuator_ctrlrange[2 * k], hi = m->actuator_ctrlrange[2 * k + 1];
    EXPECT_NEAR(env.action_to_ctrl(k, b.action_row(0)[k]), std::clamp(target, lo, hi), 1e-5);
  }
}

TEST(BfmCollect, NoiselessBalanceActionIsTheExpertTarget) {
  // Expert::balance (the default): the first stored action is sim::balance_targets at the episode's start state.
  const RefMotions refs = toy_refs();
  CollectOptions o;
  o.envs = 1;
  o.action_noise = 0;
  ASSERT_EQ(o.expert, Expert::balance);
  ReplayBuffer b(10, refs.obs_dim, 60);
  TrackingCollector c(humanoid(), refs, o);
  Generator g(3);
  c.collect_expert(2, g, b);
  const int clip = (int)b.clip_at(0), t = (int)b.frame_at(0);
  sim::Env env(humanoid());
  env.reset(refs.qpos_at(clip, t), refs.qvel_at(clip, t), nullptr);
  const sim::QposTrajectory q = refs.trajectory(clip);
  const sim::BalanceReference br = sim::balance_reference(*humanoid(), q);
  std::vector<double> ctrl(60);
  sim::balance_targets(env, br.frame(q, t + 1), o.balance, ctrl.data());
  for (int k = 0; k < 60; ++k) EXPECT_NEAR(env.action_to_ctrl(k, b.action_row(0)[k]), ctrl[k], 1e-5) << k;
  EXPECT_EQ(expert_from_string("pd"), Expert::pd);
  EXPECT_STREQ(expert_name(expert_from_string("balance")), "balance");
  EXPECT_THROW(expert_from_string("mpc"), Error);
  CollectOptions named;
  set_expert(named, "balance-hips");
  EXPECT_EQ(named.expert, Expert::balance);
  EXPECT_TRUE(named.balance.torque_at_hips_only);
  set_expert(named, "pd");
  EXPECT_EQ(named.expert, Expert::pd);
  EXPECT_FALSE(named.balance.torque_at_hips_only);
  EXPECT_THROW(set_expert(named, "balance-knees"), Error);
}

TEST(BfmCollect, PolicyRowsCarryTheExpertLabelOfTheirState) {
  // DAgger relabelling: a policy that always outputs 0 visits states; each row's label is the noiseless expert
  // action in that row's state (checked by replaying the row's start state for the first row of env 0), and the
  // stored action stays the policy's.
  const RefMotions refs = toy_refs();
  CollectOptions o;
  o.envs = 2;
  o.action_noise = 0;
  ReplayBuffer b(20, refs.obs_dim, 60, /*with_expert_labels=*/true);
  TrackingCollector c(humanoid(), refs, o);
  const EncodeFn enc = [](const Tensor& s) { return Tensor::full({s.size(0), 4}, 1.0f); };
  const PolicyFn zero = [](const Tensor& obs, const Tensor&, float, Generator&, Tensor& a) {
    a = Tensor::zeros({obs.size(0), 60});
  };
  Generator g(5);
  c.collect_policy(6, enc, zero, g, b);
  ASSERT_EQ(b.size(), 6);
  for (int k = 0; k < 60; ++k) EXPECT_EQ(b.action_row(0)[k], 0.0f);
  const int clip = (int)b.clip_at(0), t = (int)b.frame_at(0);
  sim::Env env(humanoid());
  env.reset(refs.qpos_at(clip, t), refs.qvel_at(clip, t), nullptr);
  const sim::QposTrajectory q = refs.trajectory(clip);
  std::vector<double> ctrl(60);
  sim::balance_targets(env, sim::balance_reference(*humanoid(), q).frame(q, t + 1), o.balance, ctrl.data());
  for (int k = 0; k < 60; ++k)
    EXPECT_NEAR(b.expert_action_row(0)[k], std::clamp(env.ctrl_to_action(k, ctrl[k]), -1.0, 1.0), 1e-6) << k;
  // Later rows of env 0 (rows 2, 4) are in states the zero policy produced, and their labels differ from row 0's.
  double diff = 0;
  for (int k = 0; k < 60; ++k) diff += std::fabs(b.expert_action_row(4)[k] - b.expert_action_row(0)[k]);
  EXPECT_GT(diff, 1e-3);
}

TEST(BfmCollect, BadOptionsThrow) {
  const RefMotions refs = toy_refs();
  CollectOptions o;
  o.envs = 0;
  EXPECT_THROW(TrackingCollector(humanoid(), refs, o), Error);
  o.envs = 2;
  o.fail_distance = 0;
  EXPECT_THROW(TrackingCollector(humanoid(), refs, o), Error);
  o.fail_distance = 0.5;
  TrackingCollector c(humanoid(), refs, o);
  ReplayBuffer wrong(10, 5, 60);
  Generator g(0);
  EXPECT_THROW(c.collect_expert(4, g, wrong), Error);
  ReplayBuffer b(10, refs.obs_dim, 60);
  EXPECT_THROW(c.collect_expert(-1, g, b), Error);
}
