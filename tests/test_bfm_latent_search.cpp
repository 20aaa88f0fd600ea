// test_bfm_latent_search.cpp — BFM tracking with the evaluation-time search over z (models/bfm/latent_search.h):
// one candidate is plain Eq 2 tracking bit for bit, the search tracks closer than plain tracking, the result does
// not depend on the thread count, bad options and references are refused; `t2m eval track` refuses bad search flags;
// from a standing start the body begins at qpos0 at rest against the moved reference, with a relaxed fail distance
// for the transition.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "models/bfm/latent_search.h"
#include "models/bfm/policy_checkpoint.h"
#include "models/bfm/track_eval.h"
#include "sim/align_start.h"
#include "sim/env.h"
#include "sim/retarget.h"
#include "tensor/parallel.h"
#include "test_cli_util.h"
#include "test_bfm_sway.h"

using namespace t2m;
using namespace t2m::bfm;

using t2m::test::humanoid;
using t2m::test::sway_refs;
using t2m::test::tiny_fb_config;


TEST(BfmLatentSearch, OneCandidateIsPlainTrackingBitForBit) {
  FbAgent agent(tiny_fb_config(), 1);
  const RefMotions r = sway_refs({{25, 0.1}});
  LatentSearchOptions o;
  o.samples = 1;  // only δ = 0: the latents of Eq 2 unchanged
  const auto searched = track_bfm_search(agent, humanoid(), r, o);
  const auto plain = track_bfm(agent, humanoid(), r);
  ASSERT_EQ(searched.size(), 1u);
  EXPECT_EQ(searched[0].simulated.qpos, plain[0].simulated.qpos);
  EXPECT_EQ(searched[0].mpjpe_m, plain[0].mpjpe_m);
  EXPECT_EQ(searched[0].frames_ok, plain[0].frames_ok);
}

TEST(BfmLatentSearch, TracksCloserThanPlainTrackingAndIgnoresThreads) {
  // The shipped tracker (bfm_track, session 9) on two sways of the standing pose.
  auto agent_ptr = load_policy(std::string(T2M_SOURCE_DIR) + "/models/checkpoints/bfm_track.t2mckpt");
  FbAgent& agent = *agent_ptr;
  const RefMotions r = sway_refs({{60, 0.05}, {90, 0.1}});
  LatentSearchOptions o;
  o.samples = 16;
  o.horizon = 3;
  const auto plain = track_bfm(agent, humanoid(), r);
  const int threads = get_num_threads();
  set_num_threads(1);
  const auto one = track_bfm_search(agent, humanoid(), r, o);
  set_num_threads(2);
  const auto two = track_bfm_search(agent, humanoid(), r, o);
  set_num_threads(threads);
  ASSERT_EQ(one.size(), 2u);
  for (int c = 0; c < 2; ++c) {
    EXPECT_EQ(one[c].simulated.qpos, two[c].simulated.qpos) << c;
    EXPECT_EQ(one[c].frames, r.frames(c));
    EXPECT_LT(one[c].mpjpe_m, 0.8 * plain[c].mpjpe_m) << c << ": searched " << one[c].mpjpe_m << " plain " << plain[c].mpjpe_m;
    EXPECT_GT(one[c].frames_ok, plain[c].frames_ok + 5) << c;  // plain: 41 of 60 and 16 of 90 frames here
  }
  EXPECT_TRUE(one[0].success);  // the searched policy holds the gentle sway to the end; plain tracking does not
  EXPECT_FALSE(plain[0].success);
  const RefMotions short_clip = sway_refs({{20, 0.05}});
  const auto seed1 = track_bfm_search(agent, humanoid(), short_clip, o);
  o.seed = 2;  // another draw, another path
  EXPECT_NE(track_bfm_search(agent, humanoid(), short_clip, o)[0].simulated.qpos, seed1[0].simulated.qpos);
}

TEST(BfmLatentSearch, RefusesBadOptionsAndReferences) {
  FbAgent agent(tiny_fb_config(), 1);
  const RefMotions r = sway_refs({{10, 0.1}});
  for (auto f : {+[](LatentSearchOptions& o) { o.samples = 0; }, +[](LatentSearchOptions& o) { o.window = 0; },
                 +[](LatentSearchOptions& o) { o.horizon = 0; }, +[](LatentSearchOptions& o) { o.sigma = -0.1; },
                 +[](LatentSearchOptions& o) { o.sigma = NAN; }, +[](LatentSearchOptions& o) { o.carry = 1.5; },
                 +[](LatentSearchOptions& o) { o.carry = -0.5; }}) {
    LatentSearchOptions o;
    f(o);
    EXPECT_THROW(check_search_options(o), Error);
    EXPECT_THROW(track_bfm_search(agent, humanoid(), r, o), Error);
  }
  EXPECT_THROW(track_bfm_search(agent, humanoid(), RefMotions{}), Error);  // no clips
  EXPECT_THROW(track_bfm_search(agent, humanoid(), r, {}, {}, -1), Error);  // Eq 2 window
  FbConfig other = tiny_fb_config();
  other.obs_dim += 1;
  FbAgent wrong(other, 1);
  EXPECT_THROW(track_bfm_search(wrong, humanoid(), r), Error);
}

TEST(BfmLatentSearch, EvalTrackRefusesBadSearchFlags) {
  namespace fs = std::filesystem;
  using t2m::test::read_text;
  using t2m::test::run_t2m;
  if (!fs::exists(t2m::test::t2m_binary())) GTEST_SKIP() << "t2m binary not built next to the test";
  const fs::path w = fs::temp_directory_path() / ("t2m_latent_search_cli_" + std::to_string(::getpid()));
  fs::remove_all(w);
  fs::create_directories(w);
  const std::string policy = std::string(T2M_SOURCE_DIR) + "/models/checkpoints/bfm_track.t2mckpt";
  const fs::path out = w / "out.json";
  for (const std::string& bad : {std::string("--search-samples 8"), std::string("--z-search --search-samples 0"),
                                 std::string("--z-search --search-sigma -1"), std::string("--z-search --search-horizon 0")}) {
    EXPECT_NE(run_t2m("eval track --policy '" + policy + "' " + bad + " --out '" + out.string() + "'", w / "bad.log"), 0)
        << bad;
    EXPECT_EQ(read_text(w / "bad.log").rfind("t2m: ", 0), 0u) << read_text(w / "bad.log");
    EXPECT_FALSE(fs::exists(out)) << bad;
  }
  fs::remove_all(w);
}

TEST(BfmLatentSearch, StandingStartBeginsAtQpos0AgainstTheMovedReference) {
  FbAgent agent(tiny_fb_config(), 1);
  const auto h = humanoid();
  const int nq = h->model()->nq, nv = h->model()->nv;
  // A sway 2.2 m away and turned: from qpos0 it can only be tracked once the reference is moved to start there.
  std::vector<double> far(h->model()->qpos0, h->model()->qpos0 + nq);
  far[0] = 2.0, far[1] = -1.0, far[3] = std::cos(0.5), far[6] = std::sin(0.5);
  RefMotions r;
  r.add(*h, "far", sim::align_start(*h, t2m::test::swaying(*h, 12, 0.1), far.data()));
  LatentSearchOptions o;
  o.samples = 4;
  o.start = TrackStart::standing;
  SearchRows rows;
  const auto res = track_bfm_search(agent, h, r, o, {}, 0, &rows);
  ASSERT_EQ(res.size(), 1u);
  const auto& sim_q = res[0].simulated;
  for (int k = 0; k < nq; ++k) EXPECT_EQ(sim_q.qpos[k], h->model()->qpos0[k]) << k;  // frame 0: qpos0 ...
  for (int k = 0; k < nv; ++k) EXPECT_EQ(sim_q.qvel[k], 0.0) << k;                    // ... at rest
  EXPECT_LT(res[0].mpjpe_m, 0.3);  // scored against the moved reference
  const auto unmoved = track_bfm(agent, h, r, {}, 0, {}, TrackStart::standing);
  EXPECT_GT(unmoved[0].mpjpe_m, 1.5);  // the clip where it is: 2.2 m off
  // The first row is the standing body's state.
  sim::Env env(h);
  std::vector<float> s0((size_t)r.obs_dim);
  const std::vector<double> rest((size_t)nv, 0.0);
  env.reset(h->model()->qpos0, rest.data(), s0.data());
  ASSERT_GT(rows.rows(), 0);
  for (int k = 0; k < r.obs_dim; ++k) ASSERT_EQ(rows.obs[k], s0[k]) << k;
  // The latents are the clip's own (Eq 2 on its states, which the move leaves as they are).
  const Tensor z = agent.infer_tracking_z(clip_states(r, 0), agent.config().track_window).contiguous();
  for (int k = 0; k < agent.config().z_dim; ++k) EXPECT_EQ(rows.z[k], z.data<float>()[k]);
}

TEST(BfmLatentSearch, StandingStartRelaxesTheFailDistanceForTheTransition) {
  FbAgent agent(tiny_fb_config(), 1);
  const RefMotions r = sway_refs({{30, 0.1}});
  sim::PdOptions strict;
  strict.fail_distance = 0.01;  // every frame fails at once ...
  LatentSearchOptions o;
  o.samples = 4;
  o.start = TrackStart::standing;
  o.transition = 0;
  SearchRows none;
  track_bfm_search(agent, humanoid(), r, o, strict, 0, &none);
  EXPECT_EQ(none.rows(), o.window);  // ... so the search plans the first window only
  o.transition = 12;
  o.transition_fail_distance = 5.0;  // ... except during the first 12 frames
  SearchRows relaxed;
  track_bfm_search(agent, humanoid(), r, o, strict, 0, &relaxed);
  EXPECT_EQ(relaxed.rows(), 12);  // windows from frames 0, 3, 6, 9; frame 12, the first strict one, fails
  o.start = TrackStart::reference;  // the relaxation belongs to the standing start only
  SearchRows ref;
  track_bfm_search(agent, humanoid(), r, o, strict, 0, &ref);
  EXPECT_EQ(ref.rows(), o.window);
}
