// test_bfm_planner_demos.cpp — the planner's demonstrations as BFM training rows (models/bfm/planner_demos.h): the
// ctrl file (round trip, bad files), the replay revisiting the run's states bit for bit with the planner's clean
// labels, failed runs, bad demonstrations, planner-owned clips, filtered sampling, and the trainer with --demos
// (resume, a changed demo directory).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "models/bfm/planner_demos.h"
#include "models/bfm/trainer.h"
#include "sim/ctrl_file.h"
#include "sim/samcon_mpc.h"
#include "test_cli_util.h"
#include "test_sim_walk.h"
#include "test_scratch_dir.h"

using namespace t2m;
using namespace t2m::bfm;
namespace fs = std::filesystem;
using sim::test::humanoid;
using sim::test::walk;

namespace {
const std::string kWalk = "dataset-2_walk_active_001";            // demonstrated
const std::string kHold = "dataset-2_raise-up-left-hand_active_001";  // another content: not the planner's
const std::string kWalk2 = "dataset-1_walk_proud_002";            // same content as a demonstration: the planner's

std::string tmp_dir(const std::string& name) {
  return t2m::test::scratch_dir(name).string();
}

const RefMotions& refs() {
  static const RefMotions r = [] {
    RefMotions x;
    x.add(*humanoid(), kWalk, walk());
    x.add(*humanoid(), kHold, still_trajectory(walk().qpos.data(), walk().nq, walk().nv, 240));
    x.add(*humanoid(), kWalk2, walk());
    return x;
  }();
  return r;
}

// A planner run on the walk fixture (32 samples walk it; docs/SIM.md §5d), with noise on the applied targets.
const sim::SamconMpcResult& run(double noise) {
  static std::map<double, sim::SamconMpcResult> cache;
  auto it = cache.find(noise);
  if (it == cache.end()) {
    sim::SamconMpcOptions o;
    o.samples = 32;
    o.target_noise = noise;
    it = cache.emplace(noise, sim::track_samcon_mpc(humanoid(), walk(), o)).first;
  }
  return it->second;
}

// What `t2m track-pd --samcon-mpc --export-dir DIR` writes for a clip NAME.
void export_run(const sim::SamconMpcResult& r, const std::string& dir, const std::string& name,
                int frames_searched = -1) {
  sim::save_ctrl_json({walk().fps, humanoid()->model()->nu, frames_searched < 0 ? r.frames_planned : frames_searched,
                       r.ctrl, r.offset},
                      dir + "/" + name + ".ctrl.json");
  sim::save_trajectory_json(r.track.simulated, dir + "/" + name + ".qpos.json");
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream f(path);
  f << text;
}

ReplayBuffer replayed(const PlannerDemos& d) {
  ReplayBuffer b(d.rows, refs().obs_dim, humanoid()->model()->nu, true);
  replay_planner_demos(humanoid(), refs(), d, b);
  return b;
}
}  // namespace

TEST(SimCtrlFile, RoundTripAndBadFiles) {
  const std::string d = tmp_dir("ctrl");
  const sim::CtrlSequence c{30.0, 2, 1, {0.1, -0.2, 0.3, 1e-17}, {0.0, 0.5, -0.25, 0.125}};
  sim::save_ctrl_json(c, d + "/a.ctrl.json");
  const sim::CtrlSequence r = sim::load_ctrl_json(d + "/a.ctrl.json");
  EXPECT_EQ(r.fps, c.fps);
  EXPECT_EQ(r.nu, 2);
  EXPECT_EQ(r.steps(), 2);
  EXPECT_EQ(r.frames_searched, 1);
  EXPECT_EQ(r.ctrl, c.ctrl);  // exact: doubles round-trip
  EXPECT_EQ(r.offset, c.offset);
  // Written whole through a temp file (sim/atomic_file.h): only the final file is left; an unwritable path throws
  // one error naming it and leaves nothing.
  EXPECT_EQ(std::distance(fs::directory_iterator(d), fs::directory_iterator{}), 1);
  try {
    sim::save_ctrl_json(c, d + "/missing/b.ctrl.json");
    ADD_FAILURE() << "no error";
  } catch (const t2m::Error& e) {
    EXPECT_NE(std::string(e.what()).find("save_ctrl_json: cannot write '" + d + "/missing/b.ctrl.json'"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(d), fs::directory_iterator{}), 1);
  const std::string ok = R"("fps": 30, "nu": 2, "frames_searched": 1, "ctrl": [1, 2, 3, 4], "offset": [0, 0, 0, 0])";
  const std::vector<std::string> bad = {
      "",                                                          // empty
      "{\"format\": \"t2m-ctrl-1\", " + ok,                        // truncated
      "{\"format\": \"t2m-qpos-1\", " + ok + "}",                  // another format
      R"({"format": "t2m-ctrl-1", "fps": 30, "nu": 2, "ctrl": [1, 2], "offset": [0, 0]})",  // no frames_searched
      R"({"format": "t2m-ctrl-1", "fps": 30, "nu": 2, "frames_searched": 0, "ctrl": [1, 2, 3], "offset": [0, 0, 0]})",
      R"({"format": "t2m-ctrl-1", "fps": 30, "nu": 2, "frames_searched": 0, "ctrl": [1, 2], "offset": [0]})",
      R"({"format": "t2m-ctrl-1", "fps": 30, "nu": 2, "frames_searched": 2, "ctrl": [1, 2], "offset": [0, 0]})",
      R"({"format": "t2m-ctrl-1", "fps": 30, "nu": 0, "frames_searched": 0, "ctrl": [], "offset": []})",
      R"({"format": "t2m-ctrl-1", "fps": 30, "nu": 2, "frames_searched": 0, "ctrl": [1, null], "offset": [0, 0]})",
  };
  for (size_t i = 0; i < bad.size(); ++i) {
    write_text(d + "/bad.ctrl.json", bad[i]);
    EXPECT_THROW(sim::load_ctrl_json(d + "/bad.ctrl.json"), Error) << "case " << i;
  }
  EXPECT_THROW(sim::load_ctrl_json(d + "/missing.ctrl.json"), Error);
  EXPECT_THROW(sim::save_ctrl_json({30.0, 2, 0, {1.0, NAN}, {0.0, 0.0}}, d + "/nan.ctrl.json"), Error);
  EXPECT_FALSE(fs::exists(d + "/nan.ctrl.json"));
}

// Without noise the label is the applied action; with noise they differ by about the noise (0.02 rad ~ 0.02-0.03
// action units); the replayed rows chain (s' of row t is s of row t+1) and the replay matched the run's qpos.json.
TEST(BfmPlannerDemos, ReplayRevisitsTheRunsStatesWithThePlannersLabels) {
  for (double noise : {0.0, 0.02}) {
    const sim::SamconMpcResult& r = run(noise);
    const std::string d = tmp_dir(noise > 0 ? "noisy" : "clean");
    export_run(r, d, kWalk);
    const PlannerDemos demos = load_planner_demos(d, refs());
    ASSERT_EQ(demos.files.size(), 1u);
    EXPECT_EQ(demos.clip[0], 0);
    const bool finished = r.frames_planned == walk().frames - 1;
    EXPECT_EQ(demos.failed_runs, finished ? 0 : 1);
    EXPECT_EQ(demos.rows, finished ? r.frames_planned : std::max(0, r.frames_planned - 15));
    if (noise == 0) {
      EXPECT_TRUE(finished);
    }
    const ReplayBuffer b = replayed(demos);  // checked against NAME.qpos.json: no throw
    ASSERT_EQ(b.size(), demos.rows);
    const int D = b.obs_dim(), A = b.action_dim();
    double diff = 0;
    for (int64_t t = 0; t < b.size(); ++t) {
      EXPECT_EQ(b.clip_at(t), 0);
      EXPECT_EQ(b.frame_at(t), t);
      if (t + 1 < b.size()) {
        for (int k = 0; k < D; ++k) ASSERT_EQ(b.next_obs_row(t)[k], b.obs_row(t + 1)[k]) << t;
      }
      for (int k = 0; k < A; ++k) {
        const float a = b.action_row(t)[k], l = b.expert_action_row(t)[k];
        ASSERT_TRUE(a >= -1 && a <= 1 && l >= -1 && l <= 1);
        if (noise == 0) {
          ASSERT_EQ(a, l) << "row " << t << " actuator " << k;
        }
        diff += std::fabs(a - l);
      }
    }
    diff /= (double)b.size() * A;
    if (noise > 0) {
      EXPECT_GT(diff, 0.008);
      EXPECT_LT(diff, 0.05);
    }
    // The first observation is the reference start state's.
    for (int k = 0; k < D; ++k) ASSERT_FLOAT_EQ(b.obs_row(0)[k], refs().obs_at(0, 0)[k]);
  }
}

// DAgger with the planner: the policy driver applies mu(s, z_{t-1}) (z = Eq 2 on the reference) as targets; a run
// it leads half the time exports and replays like a planner run, each state labelled with the planner's choice.
TEST(BfmPlannerDemos, PolicyDriverLeadsARunThatReplaysWithPlannerLabels) {
  FbConfig cfg;
  cfg.hidden = 32, cfg.b_hidden = 32, cfg.z_dim = 8;
  FbAgent agent(cfg, 7);
  const sim::BodyDriver drive = policy_driver(agent, humanoid(), walk());
  sim::Env env(humanoid());
  std::vector<float> obs((size_t)env.obs_dim());
  env.reset(walk().qpos.data(), walk().qvel.data(), obs.data());
  std::vector<double> ctrl((size_t)env.action_dim());
  drive(env, 1, ctrl.data());
  const Tensor states = Tensor::from_vector(std::vector<float>(refs().obs.begin(), refs().obs.begin() +
                                                               (int64_t)walk().frames * refs().obs_dim),
                                            {(int64_t)walk().frames, (int64_t)refs().obs_dim});
  const Tensor z = agent.infer_tracking_z(states).contiguous();
  const Tensor mu = agent.actor_mean(Tensor::from_vector(obs, {1, (int64_t)obs.size()}),
                                     Tensor::from_vector(std::vector<float>(z.data<float>(), z.data<float>() + 8), {1, 8}))
                        .contiguous();
  for (int k = 0; k < env.action_dim(); ++k) EXPECT_EQ(ctrl[(size_t)k], env.action_to_ctrl(k, mu.data<float>()[k]));
  EXPECT_THROW(drive(env, 0, ctrl.data()), Error);
  EXPECT_THROW(drive(env, walk().frames, ctrl.data()), Error);
  FbConfig other = cfg;
  other.action_dim = 10;
  FbAgent wrong(other, 7);
  EXPECT_THROW(policy_driver(wrong, humanoid(), walk()), Error);

  sim::SamconMpcOptions o;
  o.samples = 16, o.horizon = 2, o.driver_share = 0.5;  // no noise: the planner's windows apply their labels exactly
  const sim::SamconMpcResult r = sim::track_samcon_mpc(humanoid(), walk(), o, sim::PdOptions{}, drive);
  ASSERT_GT(r.frames_planned, 15 + 3);
  const std::string d = tmp_dir("dagger");
  export_run(r, d, kWalk);
  const ReplayBuffer b = replayed(load_planner_demos(d, refs()));  // the student's states revisited: no throw
  ASSERT_GT(b.size(), 0);
  int led = 0;  // rows where the applied action is not the planner's label: the student's windows
  for (int64_t t = 0; t < b.size(); ++t) {
    double e = 0;
    for (int k = 0; k < b.action_dim(); ++k) e = std::max(e, (double)std::fabs(b.action_row(t)[k] - b.expert_action_row(t)[k]));
    led += e > 0;
  }
  EXPECT_GT(led, 0);
  EXPECT_LT(led, b.size());
}

TEST(BfmPlannerDemos, FailedRunsDropTheirLastSteps) {
  const std::string d = tmp_dir("failed");
  export_run(run(0.0), d, kWalk, /*frames_searched=*/30);  // as if the planner had lost the body at frame 30
  PlannerDemoOptions o;
  o.drop_before_fail = 10;
  const PlannerDemos demos = load_planner_demos(d, refs(), o);
  EXPECT_EQ(demos.failed_runs, 1);
  EXPECT_EQ(demos.rows, 20);
  EXPECT_EQ(replayed(demos).size(), 20);
  // Several directories, comma-separated: their runs in order.
  const std::string d2 = tmp_dir("failed2");
  export_run(run(0.0), d2, kWalk2, /*frames_searched=*/25);
  const PlannerDemos both = load_planner_demos(d + "," + d2, refs(), o);
  ASSERT_EQ(both.files.size(), 2u);
  EXPECT_EQ(both.clip, (std::vector<int>{0, 2}));
  EXPECT_EQ(both.rows, 20 + 15);
  EXPECT_EQ(both.failed_runs, 2);
  EXPECT_THROW(load_planner_demos(d + "," + d2 + "/missing", refs(), o), Error);
  EXPECT_EQ(demo_directories("a,b/c,"), (std::vector<std::string>{"a", "b/c", ""}));
  EXPECT_EQ(demo_directories("a"), (std::vector<std::string>{"a"}));
  o.drop_before_fail = 30;  // nothing left: no usable run
  EXPECT_THROW(load_planner_demos(d, refs(), o), Error);
  o.drop_before_fail = -1;
  EXPECT_THROW(load_planner_demos(d, refs(), o), Error);
}

TEST(BfmPlannerDemos, BadDemonstrationsThrow) {
  EXPECT_THROW(load_planner_demos(tmp_dir("none") + "/missing", refs()), Error);
  const std::string empty = tmp_dir("empty");
  EXPECT_THROW(load_planner_demos(empty, refs()), Error);
  // Only a run of a clip that is not a reference: skipped, so nothing usable.
  const std::string other = tmp_dir("other");
  export_run(run(0.0), other, "dataset-2_walk_active_999");
  EXPECT_THROW(load_planner_demos(other, refs()), Error);
  export_run(run(0.0), other, kWalk);
  const PlannerDemos ok = load_planner_demos(other, refs());
  EXPECT_EQ(ok.files.size(), 1u);
  EXPECT_EQ(ok.skipped, std::vector<std::string>{"dataset-2_walk_active_999.ctrl.json"});
  // A tampered qpos.json (or a run on another reference, another physics build): the replay departs from it.
  const std::string tamper = tmp_dir("tamper");
  sim::SamconMpcResult r = run(0.0);
  r.track.simulated.qpos[(size_t)20 * r.track.simulated.nq + 2] += 1e-6;
  export_run(r, tamper, kWalk);
  EXPECT_THROW(replayed(load_planner_demos(tamper, refs())), Error);
  // Another number of steps than the clip has.
  const std::string shortd = tmp_dir("short");
  const int nu = humanoid()->model()->nu;
  sim::save_ctrl_json({30.0, nu, 10, std::vector<double>((size_t)20 * nu, 0.0), std::vector<double>((size_t)20 * nu, 0.0)},
                      shortd + "/" + kWalk + ".ctrl.json");
  EXPECT_THROW(load_planner_demos(shortd, refs()), Error);
  // A corrupt ctrl file.
  write_text(shortd + "/" + kWalk + ".ctrl.json", "{\"format\": \"t2m-ctrl-1\"");
  EXPECT_THROW(load_planner_demos(shortd, refs()), Error);
  // A buffer without labels or of other dims.
  ReplayBuffer nolabels(ok.rows, refs().obs_dim, nu, false);
  EXPECT_THROW(replay_planner_demos(humanoid(), refs(), ok, nolabels), Error);
}

TEST(BfmPlannerDemos, OwnedClipsAreThoseOfTheDemonstratedContents) {
  const std::string d = tmp_dir("owned");
  export_run(run(0.0), d, kWalk);
  EXPECT_EQ(planner_owned_clips(refs(), load_planner_demos(d, refs())), (std::vector<char>{1, 0, 1}));
}

TEST(BfmReplay, SampleWhereKeepsOnlyAcceptedRows) {
  ReplayBuffer b(300, 4, 2);
  std::vector<float> o(4), a(2);
  for (int i = 0; i < 300; ++i) {
    o[0] = (float)i;
    b.add(o.data(), a.data(), o.data(), 1.0f, i % 3, i);
  }
  Generator g1(7), g2(7);
  ReplayBatch x = make_replay_batch(500, 4, 2), y = make_replay_batch(500, 4, 2);
  const auto keep = [&](int64_t row) { return b.clip_at(row) == 1; };
  ASSERT_TRUE(b.sample_where_into(500, g1, keep, x));
  ASSERT_TRUE(b.sample_where_into(500, g2, keep, y));
  const auto clips = x.clip.to_vector<int64_t>();
  for (int64_t c : clips) ASSERT_EQ(c, 1);
  EXPECT_EQ(x.frame.to_vector<int64_t>(), y.frame.to_vector<int64_t>());  // deterministic
  int low = 0;  // uniform over the accepted rows: about half below row 150
  for (int64_t f : x.frame.to_vector<int64_t>()) low += f < 150;
  EXPECT_NEAR(low, 250, 60);
  ReplayBatch z = make_replay_batch(4, 4, 2);
  EXPECT_FALSE(b.sample_where_into(4, g1, [](int64_t) { return false; }, z));  // gives up after 64 dry rounds
}

// `t2m train bfm --demos DIR`: the demonstration buffer, the owned clips, training, resume; a changed directory is
// refused on resume. Runs without demos keep their config (no demo keys: older states resume).
TEST(BfmTrainLoop, DemonstrationsJoinTheSeedData) {
  const std::string demos = tmp_dir("train_demos"), d1 = tmp_dir("run1"), d2 = tmp_dir("run2");
  export_run(run(0.02), demos, kWalk);
  BfmTrainConfig c;
  c.fb.hidden = 16, c.fb.b_hidden = 16, c.fb.z_dim = 6, c.fb.track_window = 3;
  c.seed = 5, c.seed_transitions = 120, c.envs = 2, c.max_episode_steps = 10;
  c.total_updates = 100, c.offline_updates = 2, c.collect_every = 2, c.collect_transitions = 12;
  c.online_capacity = 40, c.batch = 16, c.bc_batch = 8;
  EXPECT_FALSE(c.to_json().contains("demo_dir"));
  c.demo_dir = demos;
  c.demo_fraction = 0.5;
  EXPECT_EQ(BfmTrainConfig::from_json(c.to_json()).to_json(), c.to_json());
  std::vector<float> straight;
  {
    BfmTrainer t(c, humanoid(), refs(), d1);
    t.prepare_seed();
    ASSERT_NE(t.demo_buffer(), nullptr);
    EXPECT_EQ(t.demo_buffer()->size(), load_planner_demos(demos, refs()).rows);
    EXPECT_EQ(t.planner_owned(), (std::vector<char>{1, 0, 1}));
    for (int i = 0; i < 6; ++i) EXPECT_TRUE(std::isfinite(t.train_step().fb.fb_loss));
    for (const auto& [n, v] : t.agent().named_parameters()) {
      const auto x = v.data().to_vector<float>();
      straight.insert(straight.end(), x.begin(), x.end());
    }
  }
  {
    BfmTrainer t(c, humanoid(), refs(), d2);
    t.prepare_seed();
    for (int i = 0; i < 3; ++i) t.train_step();
    t.save();
  }
  {
    BfmTrainer t(c, humanoid(), refs(), d2);
    ASSERT_TRUE(t.resumed());
    t.prepare_seed();
    for (int i = 0; i < 3; ++i) t.train_step();
    std::vector<float> resumed;
    for (const auto& [n, v] : t.agent().named_parameters()) {
      const auto x = v.data().to_vector<float>();
      resumed.insert(resumed.end(), x.begin(), x.end());
    }
    EXPECT_EQ(resumed, straight);
  }
  // The demonstrations changed under a saved run (another frames_searched: other rows): refused.
  export_run(run(0.02), demos, kWalk, 40);
  {
    BfmTrainer t(c, humanoid(), refs(), d2);
    EXPECT_THROW(t.prepare_seed(), Error);
  }
  BfmTrainConfig bad = c;
  bad.demo_fraction = 1.5;
  EXPECT_THROW(bad.validate(), Error);
}

// `t2m train bfm --demos DIR1,DIR2` checks every directory before it writes anything.
TEST(BfmTrainLoop, DemosFlagNamesAMissingDirectory) {
  if (!fs::exists(t2m::test::t2m_binary())) GTEST_SKIP() << "t2m binary not built next to the test";
  const std::string demos = tmp_dir("cli_demos"), w = tmp_dir("cli_run");
  const fs::path out = fs::path(w) / "run";
  const int rc = t2m::test::run_t2m("train bfm --out '" + out.string() + "' --demos '" + demos + "," + demos +
                                        "/missing'", fs::path(w) / "log");
  const std::string log = t2m::test::read_text(fs::path(w) / "log");
  EXPECT_NE(rc, 0);
  EXPECT_EQ(log.rfind("t2m: train bfm: --demos: no directory", 0), 0u) << log;
  EXPECT_FALSE(fs::exists(out / "config.json"));
}
