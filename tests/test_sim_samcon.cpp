// test_sim_samcon.cpp — Env::save_state / restore_state and the SAMCON search (sim/samcon.h) on a real 60-frame
// Bandai-Namco walk (tests/fixtures/bvh/bandai_walk_60.bvh): restoring continues bit for bit, the search with no
// sampling is the balance expert, the search finds a path through the walk the expert falls on, and the result does
// not depend on the thread count.
#include <gtest/gtest.h>

#include <string>

#include "sim/balance_tracker.h"
#include "sim/samcon.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"
#include "test_sim_walk.h"

using namespace t2m::sim;
using t2m::sim::test::humanoid;
using t2m::sim::test::walk;

namespace {
// Balance-expert steps towards frames t0+1 .. t1 of the walk; returns the qpos after each step.
std::vector<double> expert_steps(Env& env, const BalanceReference& br, int t0, int t1) {
  std::vector<double> ctrl(env.model()->nu), out;
  for (int t = t0 + 1; t <= t1; ++t) {
    balance_targets(env, br.frame(walk(), t), BalanceOptions{}, ctrl.data());
    env.step_targets(ctrl.data(), nullptr);
    out.insert(out.end(), env.data()->qpos, env.data()->qpos + env.nq());
  }
  return out;
}
}  // namespace

TEST(SimEnvState, RestoreContinuesBitForBit) {
  const QposTrajectory& q = walk();
  const BalanceReference br = balance_reference(*humanoid(), q);
  Env a(humanoid()), b(humanoid());
  a.reset(q.qpos.data(), q.qvel.data(), nullptr);
  expert_steps(a, br, 0, 5);
  EnvState s;
  a.save_state(s);
  EXPECT_GT(s.contact.size(), 0u);  // a foot on the floor at frame 5: the expert's stance legs come from these
  const std::vector<double> cont = expert_steps(a, br, 5, 13);
  b.reset(q.qpos.data() + 20 * q.nq, nullptr, nullptr);  // somewhere else entirely
  expert_steps(b, br, 20, 23);
  b.restore_state(s);
  EXPECT_EQ(expert_steps(b, br, 5, 13), cont);
}

TEST(SimEnvState, MismatchedStateThrows) {
  Env env(humanoid());
  EnvState s;
  env.save_state(s);
  s.qpos.pop_back();
  EXPECT_THROW(env.restore_state(s), t2m::Error);
}

TEST(SimSamcon, NoSamplingIsTheBalanceExpert) {
  SamconOptions o;
  o.samples = 1, o.beam = 1, o.sigma = 0.0;
  const SamconResult r = track_samcon(humanoid(), walk(), o);
  Env env(humanoid());
  const PdResult e = track_balance(env, walk());
  ASSERT_EQ(e.simulated.frames, walk().frames);
  EXPECT_EQ(r.track.simulated.qpos, e.simulated.qpos);  // the same simulation, bit for bit
  EXPECT_EQ(r.track.simulated.qvel, e.simulated.qvel);
  EXPECT_EQ(r.track.mpjpe_m, e.mpjpe_m);
  EXPECT_EQ(r.track.max_error_m, e.max_error_m);
  EXPECT_EQ(r.track.root_drift_m, e.root_drift_m);
  EXPECT_EQ(r.track.frames_ok, e.frames_ok);
  EXPECT_EQ(r.track.success, e.success);
  // The search stops in the window that holds the first frame the expert fails on (frame index frames_ok).
  EXPECT_LE(r.frames_searched, e.frames_ok - 1);
  EXPECT_GT(r.frames_searched, e.frames_ok - 1 - o.window);
  for (double v : r.offset) EXPECT_EQ(v, 0.0);
}

TEST(SimSamcon, FindsAPathThroughAWalkTheExpertFallsOn) {
  Env env(humanoid());
  const PdResult e = track_balance(env, walk());
  ASSERT_FALSE(e.success);
  ASSERT_LT(e.frames_ok, 30);
  SamconOptions o;
  o.samples = 64, o.beam = 8;
  const SamconResult r = track_samcon(humanoid(), walk(), o);
  EXPECT_EQ(r.frames_searched, walk().frames - 1);
  // The replay of the kept path reproduces the search: every frame within the failure distance.
  EXPECT_TRUE(r.track.success);
  EXPECT_EQ(r.track.frames_ok, walk().frames);
  EXPECT_LT(r.track.mpjpe_m, 0.15);
  EXPECT_FALSE(r.track.fell);
  ASSERT_EQ(r.ctrl.size(), (size_t)(walk().frames - 1) * env.model()->nu);
}

TEST(SimSamcon, SameResultForAnyThreadCount) {
  const int saved = t2m::get_num_threads();
  SamconOptions o;
  o.samples = 24, o.beam = 4, o.seed = 7;
  std::vector<SamconResult> r;
  for (int threads : {1, 2}) {
    t2m::set_num_threads(threads);
    r.push_back(track_samcon(humanoid(), walk(), o));
  }
  t2m::set_num_threads(saved);
  EXPECT_EQ(r[0].offset, r[1].offset);
  EXPECT_EQ(r[0].frames_searched, r[1].frames_searched);
  EXPECT_EQ(r[0].track.simulated.qpos, r[1].track.simulated.qpos);
  EXPECT_GT(r[0].frames_searched, 0);
}

TEST(SimSamcon, BadOptionsThrow) {
  for (auto f : {+[](SamconOptions& o) { o.samples = 0; }, +[](SamconOptions& o) { o.beam = 0; },
                 +[](SamconOptions& o) { o.beam = o.samples + 1; }, +[](SamconOptions& o) { o.window = 0; },
                 +[](SamconOptions& o) { o.sigma = -0.1; }}) {
    SamconOptions o;
    f(o);
    EXPECT_THROW(track_samcon(humanoid(), walk(), o), t2m::Error);
  }
  QposTrajectory bad = walk();
  bad.qvel.pop_back();
  EXPECT_THROW(track_samcon(humanoid(), bad, SamconOptions{}), t2m::Error);
}
