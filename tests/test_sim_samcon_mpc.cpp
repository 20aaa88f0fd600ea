// test_sim_samcon_mpc.cpp — the closed-loop SAMCON planner (sim/samcon_mpc.h) on the real 60-frame Bandai-Namco walk
// of test_sim_samcon (tests/fixtures/bvh/bandai_walk_60.bvh): with no sampling it is the balance expert, bit for
// bit; with sampling it walks the clip the expert falls on, also with noise on the applied targets that throws the
// same search's open-loop path off; the result does not depend on the thread count; bad options are rejected; and
// `t2m track-pd --samcon-mpc` runs it (report, exported targets) and refuses flags that do not go together.
#include <gtest/gtest.h>

#include <cmath>
#include <unistd.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "sim/balance_tracker.h"
#include "sim/samcon.h"
#include "sim/samcon_mpc.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"
#include "test_cli_util.h"
#include "test_sim_walk.h"

using namespace t2m::sim;
using t2m::sim::test::humanoid;
using t2m::sim::test::walk;

namespace {
SamconMpcOptions small() {
  SamconMpcOptions o;
  o.samples = 32;
  return o;
}
}  // namespace

TEST(SimSamconMpc, NoSamplingIsTheBalanceExpert) {
  SamconMpcOptions o;
  o.samples = 1;  // only the zero offset
  const SamconMpcResult r = track_samcon_mpc(humanoid(), walk(), o);
  Env env(humanoid());
  const PdResult e = track_balance(env, walk());
  ASSERT_EQ(e.simulated.frames, walk().frames);
  EXPECT_EQ(r.track.simulated.qpos, e.simulated.qpos);  // the same simulation, bit for bit
  EXPECT_EQ(r.track.simulated.qvel, e.simulated.qvel);
  EXPECT_EQ(r.track.frames_ok, e.frames_ok);
  EXPECT_EQ(r.track.success, e.success);
  for (double v : r.offset) EXPECT_EQ(v, 0.0);
  // Planning stops with the window that holds the first failed frame (index frames_ok).
  EXPECT_GE(r.frames_planned, e.frames_ok);
  EXPECT_LT(r.frames_planned, e.frames_ok + o.window);
}

TEST(SimSamconMpc, WalksTheClipTheExpertFallsOn) {
  Env env(humanoid());
  const PdResult e = track_balance(env, walk());
  ASSERT_FALSE(e.success);
  ASSERT_LT(e.frames_ok, 30);
  const SamconMpcResult r = track_samcon_mpc(humanoid(), walk(), small());
  EXPECT_TRUE(r.track.success);
  EXPECT_EQ(r.track.frames_ok, walk().frames);
  EXPECT_EQ(r.frames_planned, walk().frames - 1);
  EXPECT_LT(r.track.mpjpe_m, 0.15);
  EXPECT_FALSE(r.track.fell);
  ASSERT_EQ(r.ctrl.size(), (size_t)(walk().frames - 1) * env.model()->nu);
  bool moved = false;  // the planner did more than the expert
  for (double v : r.offset) moved = moved || v != 0.0;
  EXPECT_TRUE(moved);
}

TEST(SimSamconMpc, ClosedLoopSurvivesNoiseThatBreaksTheOpenLoopPath) {
  // The open-loop path of the beam search, replayed with noise on its targets, loses the walk; the planner, which
  // re-plans from wherever the noise has put the body, keeps it.
  SamconOptions so;
  so.samples = 64, so.beam = 8;
  const SamconResult path = track_samcon(humanoid(), walk(), so);
  ASSERT_TRUE(path.track.success);
  const double noise = 0.05;  // rad per target per step
  int open_ok = 0;
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    Env env(humanoid());
    TrackingScorer score(*humanoid(), walk());
    env.reset(walk().qpos.data(), walk().qvel.data(), nullptr);
    score.add_frame(env);
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> normal(0.0, noise);
    const int nu = env.model()->nu;
    std::vector<double> ctrl((size_t)nu);
    for (int t = 1; t < walk().frames; ++t) {
      for (int k = 0; k < nu; ++k) ctrl[(size_t)k] = path.ctrl[(size_t)(t - 1) * nu + k] + normal(rng);
      clamp_to_ctrlrange(env.model(), ctrl.data());
      env.step_targets(ctrl.data(), nullptr);
      score.add_frame(env);
    }
    open_ok += score.result().success;
  }
  int closed_ok = 0;
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    SamconMpcOptions o = small();
    o.target_noise = noise, o.seed = seed;
    closed_ok += track_samcon_mpc(humanoid(), walk(), o).track.success;
  }
  EXPECT_GT(closed_ok, open_ok);
  EXPECT_GE(closed_ok, 2);
}

TEST(SimSamconMpc, SameResultForAnyThreadCount) {
  const int saved = t2m::get_num_threads();
  SamconMpcOptions o;
  o.samples = 12, o.horizon = 2, o.seed = 5, o.target_noise = 0.02;
  std::vector<SamconMpcResult> r;
  for (int threads : {1, 2}) {
    t2m::set_num_threads(threads);
    r.push_back(track_samcon_mpc(humanoid(), walk(), o));
  }
  t2m::set_num_threads(saved);
  EXPECT_EQ(r[0].offset, r[1].offset);
  EXPECT_EQ(r[0].ctrl, r[1].ctrl);
  EXPECT_EQ(r[0].track.simulated.qpos, r[1].track.simulated.qpos);
  EXPECT_GT(r[0].frames_planned, 0);
}

namespace {
// RMS change of the planned offset between consecutive windows (rad), over the planned steps.
double offset_jump_rms(const SamconMpcResult& r, int window, int nu) {
  double s = 0;
  int64_t n = 0;
  for (int t = window; t < r.frames_planned; t += window)
    for (int k = 0; k < nu; ++k) {
      const double d = r.offset[(size_t)t * nu + k] - r.offset[(size_t)(t - window) * nu + k];
      s += d * d, ++n;
    }
  return n ? std::sqrt(s / n) : 0.0;
}
}  // namespace

// --mpc-temperature: the survivors' cost-weighted mean offset still walks the fixture, and its offsets change
// less from window to window than the cheapest candidate's (a random draw each window); same for any thread count.
TEST(SimSamconMpc, WeightedMeanOffsetsWalkAndAreSmoother) {
  SamconMpcOptions o = small();
  const SamconMpcResult argmin = track_samcon_mpc(humanoid(), walk(), o);
  o.temperature = 0.05;
  const SamconMpcResult mean = track_samcon_mpc(humanoid(), walk(), o);
  EXPECT_TRUE(mean.track.success);
  const int nu = humanoid()->model()->nu;
  const double jm = offset_jump_rms(mean, o.window, nu), ja = offset_jump_rms(argmin, o.window, nu);
  EXPECT_GT(jm, 0.0);
  EXPECT_LT(jm, 0.8 * ja) << "mean " << jm << " argmin " << ja;
  const int saved = t2m::get_num_threads();
  t2m::set_num_threads(1);
  const SamconMpcResult one = track_samcon_mpc(humanoid(), walk(), o);
  t2m::set_num_threads(saved);
  EXPECT_EQ(one.offset, mean.offset);
}

// The learnable teacher's options: offsets only on the trunk and leg hinges (the others stay exactly 0), and a cost
// on the offsets' change between windows that makes them more persistent; the fixture walk is still tracked.
TEST(SimSamconMpc, LowerBodyOffsetsWithAChangeCostWalkAndPersist) {
  const std::vector<int> lb = lower_body_actuators(*humanoid());
  ASSERT_EQ(lb.size(), 30u);
  const mjModel* m = humanoid()->model();
  for (int k : lb) {
    const std::string n = mj_id2name(m, mjOBJ_ACTUATOR, k);
    EXPECT_TRUE(n.find("Leg") != std::string::npos || n.find("Foot") != std::string::npos ||
                n.find("Toes") != std::string::npos || n.rfind("Spine", 0) == 0 || n.rfind("Chest", 0) == 0)
        << n;
  }
  SamconMpcOptions o = small();
  o.hinges = lb;
  const SamconMpcResult free = track_samcon_mpc(humanoid(), walk(), o);
  o.change_cost = 4, o.size_cost = 2;
  const SamconMpcResult held = track_samcon_mpc(humanoid(), walk(), o);
  const int nu = m->nu;
  for (const SamconMpcResult* r : {&free, &held}) {
    EXPECT_TRUE(r->track.success);
    std::vector<char> in((size_t)nu, 0);
    for (int k : lb) in[(size_t)k] = 1;
    bool moved = false;
    for (size_t i = 0; i < r->offset.size(); ++i) {
      if (!in[i % (size_t)nu]) {
        EXPECT_EQ(r->offset[i], 0.0) << "hinge " << i % nu;
      }
      moved = moved || r->offset[i] != 0.0;
    }
    EXPECT_TRUE(moved);
  }
  const double jh = offset_jump_rms(held, o.window, nu), jf = offset_jump_rms(free, o.window, nu);
  EXPECT_LT(jh, 0.8 * jf) << "with change cost " << jh << " without " << jf;
}

// DAgger (BodyDriver): a driver that applies the planner's own targets reproduces its run bit for bit, labels
// included (the planner plans from the same states); share 0 is the run without a driver; at share 0.5 the driver
// leads some windows and the planner the others, and the planner's offsets are recorded in all of them.
TEST(SimSamconMpc, DriverLeadsTheBodyWhilePlannerLabels) {
  SamconMpcOptions o = small();
  o.samples = 12, o.horizon = 2, o.seed = 3;
  const SamconMpcResult plan = track_samcon_mpc(humanoid(), walk(), o);
  const int nu = humanoid()->model()->nu;
  ASSERT_GT(plan.frames_planned, 20);
  std::vector<int> calls;
  const BodyDriver replay = [&](const Env& body, int t, double* ctrl) {
    EXPECT_EQ(body.model()->nu, nu);
    calls.push_back(t);
    std::copy_n(plan.ctrl.data() + (size_t)(t - 1) * nu, nu, ctrl);
  };
  const SamconMpcResult led = track_samcon_mpc(humanoid(), walk(), o, PdOptions{}, replay);
  ASSERT_EQ((int)calls.size(), walk().frames - 1);
  for (int t = 1; t < walk().frames; ++t) EXPECT_EQ(calls[(size_t)t - 1], t);
  EXPECT_EQ(led.track.simulated.qpos, plan.track.simulated.qpos);
  EXPECT_EQ(led.offset, plan.offset);
  EXPECT_EQ(led.ctrl, plan.ctrl);

  const BodyDriver limp = [&](const Env& body, int, double* ctrl) {  // every target at the middle of its range
    for (int k = 0; k < nu; ++k) ctrl[k] = body.action_to_ctrl(k, 0.0);
  };
  SamconMpcOptions o0 = o;
  o0.driver_share = 0;
  const SamconMpcResult none = track_samcon_mpc(humanoid(), walk(), o0, PdOptions{}, limp);
  EXPECT_EQ(none.ctrl, plan.ctrl);
  EXPECT_EQ(none.offset, plan.offset);

  SamconMpcOptions oh = o;
  oh.driver_share = 0.5;
  const SamconMpcResult half = track_samcon_mpc(humanoid(), walk(), oh, PdOptions{}, limp);
  Env probe(humanoid());
  int driven = 0, planned = 0, with_offset = 0;
  for (int t = 0; t + o.window < half.frames_planned; t += o.window) {
    bool is_limp = true, has_offset = false;
    for (int k = 0; k < nu; ++k) {
      is_limp = is_limp && half.ctrl[(size_t)t * nu + k] == std::clamp(probe.action_to_ctrl(k, 0.0),
                                                                          humanoid()->model()->actuator_ctrlrange[2 * k],
                                                                          humanoid()->model()->actuator_ctrlrange[2 * k + 1]);
      has_offset = has_offset || half.offset[(size_t)t * nu + k] != 0.0;
    }
    driven += is_limp, planned += !is_limp, with_offset += has_offset;
  }
  EXPECT_GT(with_offset, 0);
  EXPECT_GT(driven, 0);
  EXPECT_GT(planned, 0);

  const BodyDriver broken = [&](const Env&, int, double* ctrl) { std::fill_n(ctrl, nu, NAN); };
  EXPECT_THROW(track_samcon_mpc(humanoid(), walk(), o, PdOptions{}, broken), t2m::Error);
}

TEST(SimSamconMpc, BadOptionsThrow) {
  for (auto f : {+[](SamconMpcOptions& o) { o.samples = 0; }, +[](SamconMpcOptions& o) { o.window = 0; },
                 +[](SamconMpcOptions& o) { o.horizon = 0; }, +[](SamconMpcOptions& o) { o.sigma = -0.1; },
                 +[](SamconMpcOptions& o) { o.carry = 1.5; }, +[](SamconMpcOptions& o) { o.target_noise = -1; },
                 +[](SamconMpcOptions& o) { o.temperature = -0.1; }, +[](SamconMpcOptions& o) { o.size_cost = -1; },
                 +[](SamconMpcOptions& o) { o.change_cost = NAN; }, +[](SamconMpcOptions& o) { o.hinges = {60}; },
                 +[](SamconMpcOptions& o) { o.hinges = {3, 3}; }, +[](SamconMpcOptions& o) { o.hinges = {-1}; },
                 +[](SamconMpcOptions& o) { o.driver_share = 1.5; }, +[](SamconMpcOptions& o) { o.driver_share = NAN; }}) {
    SamconMpcOptions o;
    f(o);
    EXPECT_THROW(track_samcon_mpc(humanoid(), walk(), o), t2m::Error);
  }
  QposTrajectory bad = walk();
  bad.qvel.pop_back();
  EXPECT_THROW(track_samcon_mpc(humanoid(), bad, SamconMpcOptions{}), t2m::Error);
}

TEST(SimSamconMpc, TrackPdCommand) {
  namespace fs = std::filesystem;
  using t2m::test::read_text;
  using t2m::test::run_t2m;
  if (!fs::exists(t2m::test::t2m_binary())) GTEST_SKIP() << "t2m binary not built next to the test";
  const fs::path w = fs::temp_directory_path() / ("t2m_samcon_mpc_cli_" + std::to_string(::getpid()));
  fs::remove_all(w);
  fs::create_directories(w);
  const std::string bvh = "'" + std::string(T2M_SOURCE_DIR) + "/tests/fixtures/bvh/bandai_walk_60.bvh'";
  const fs::path out = w / "report.json", exp = w / "exp";
  ASSERT_EQ(run_t2m("track-pd --samcon-mpc --mpc-samples 4 --mpc-horizon 1 --target-noise 0.01 --threads 1 --bvh " +
                        bvh + " --out '" + out.string() + "' --export-dir '" + exp.string() + "'",
                    w / "ok.log"),
            0)
      << read_text(w / "ok.log");
  const nlohmann::json j = nlohmann::json::parse(read_text(out));
  EXPECT_EQ(j["summary"]["controller"], "samcon-mpc");
  EXPECT_EQ(j["summary"]["clips"], 1);
  const nlohmann::json c = nlohmann::json::parse(read_text(exp / "bandai_walk_60.ctrl.json"));
  EXPECT_EQ(c["format"], "t2m-ctrl-1");
  EXPECT_EQ(c["ctrl"].size(), (size_t)(walk().frames - 1) * c["nu"].get<size_t>());
  // --resume skips the clip whose NAME.ctrl.json is there; its files stay as they were.
  const std::string before = read_text(exp / "bandai_walk_60.qpos.json");
  ASSERT_EQ(run_t2m("track-pd --samcon-mpc --mpc-samples 4 --mpc-horizon 1 --threads 1 --resume --bvh " + bvh +
                        " --out '" + out.string() + "' --export-dir '" + exp.string() + "'",
                    w / "resume.log"),
            0)
      << read_text(w / "resume.log");
  const nlohmann::json jr = nlohmann::json::parse(read_text(out));
  EXPECT_EQ(jr["summary"]["clips_skipped"], 1);
  EXPECT_EQ(jr["summary"]["clips_ok"], 0);
  EXPECT_EQ(read_text(exp / "bandai_walk_60.qpos.json"), before);
  // Flags that do not go together: one "t2m: ..." line, non-zero exit, no report.
  const fs::path none = w / "none.json";
  for (const std::string& bad : {std::string("--samcon --samcon-mpc"), std::string("--target-noise 0.1"),
                                 std::string("--samcon-mpc --mpc-carry 2"), std::string("--samcon-mpc --resume"),
                                 std::string("--resume --export-dir '" + exp.string() + "'"),
                                 std::string("--content walk"), std::string("--every 0"),
                                 std::string("--mpc-lower-body"), std::string("--mpc-change-cost 1"),
                                 std::string("--samcon-mpc --mpc-student-share 0.5"),
                                 std::string("--mpc-student '" + exp.string() + "/bandai_walk_60.ctrl.json'"),
                                 std::string("--samcon-mpc --mpc-student '" + exp.string() + "/bandai_walk_60.ctrl.json'")}) {
    EXPECT_NE(run_t2m("track-pd " + bad + " --bvh " + bvh + " --out '" + none.string() + "'", w / "bad.log"), 0)
        << bad;
    const std::string log = read_text(w / "bad.log");
    EXPECT_EQ(log.rfind("t2m: ", 0), 0u) << log;
    EXPECT_FALSE(fs::exists(none)) << bad;
  }
  fs::remove_all(w);
}

// Clip selection of the sim commands: --every K --every-from J takes the J-th, (J+K)-th, ... clip by name, so that
// demonstration runs can be split into disjoint, separately reproducible directories.
TEST(SimSamconMpc, EveryFromSelectsTheClipsBetween) {
  namespace fs = std::filesystem;
  using t2m::test::read_text;
  using t2m::test::run_t2m;
  if (!fs::exists(t2m::test::t2m_binary())) GTEST_SKIP() << "t2m binary not built next to the test";
  const fs::path w = fs::temp_directory_path() / ("t2m_every_from_" + std::to_string(::getpid()));
  fs::remove_all(w);
  fs::create_directories(w / "clips");
  for (int i = 0; i < 5; ++i)
    fs::copy_file(fs::path(T2M_SOURCE_DIR) / "tests/fixtures/bvh/bandai_walk_60.bvh",
                  w / "clips" / ("clip_" + std::to_string(i) + ".bvh"));
  const std::string base = "track-pd --split all --threads 1 --clips '" + (w / "clips").string() + "' --out '";
  const auto names = [&](const std::string& flags) {
    const fs::path out = w / "report.json";
    EXPECT_EQ(run_t2m(base + out.string() + "' " + flags, w / "run.log"), 0) << read_text(w / "run.log");
    std::vector<std::string> n;
    const nlohmann::json report = nlohmann::json::parse(read_text(out));
    for (const auto& c : report["clips"]) n.push_back(c["name"]);
    return n;
  };
  EXPECT_EQ(names("--every 2"), (std::vector<std::string>{"clip_0", "clip_2", "clip_4"}));
  EXPECT_EQ(names("--every 2 --every-from 1"), (std::vector<std::string>{"clip_1", "clip_3"}));
  EXPECT_EQ(names("--every 3 --every-from 2"), (std::vector<std::string>{"clip_2"}));
  const fs::path none = w / "none.json";
  for (const std::string& bad : {std::string("--every 2 --every-from 2"), std::string("--every-from 1"),
                                 std::string("--every 3 --every-from -1")}) {
    EXPECT_NE(run_t2m("track-pd --split all --clips '" + (w / "clips").string() + "' " + bad + " --out '" + none.string() + "'",
                      w / "bad.log"),
              0)
        << bad;
    EXPECT_EQ(read_text(w / "bad.log").rfind("t2m: ", 0), 0u) << read_text(w / "bad.log");
    EXPECT_FALSE(fs::exists(none)) << bad;
  }
  fs::remove_all(w);
}
