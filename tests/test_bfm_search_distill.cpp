// test_bfm_search_distill.cpp — distilling the z search into the actor (models/bfm/search_distill.h) and the
// search's data-collection options (latent_search.h: elites, action noise, recorded rows): the recorded actions are
// the policy's clean means on the latent it was given, noise and elites change the path and nothing else, the rows
// file round-trips and refuses truncated / foreign / mismatched files, the anchor rollouts label with the policy's
// own mean, the fit overfits a few rows and refuses bad input; `t2m train bfm-distill` refuses bad flags.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "models/bfm/latent_search.h"
#include "models/bfm/policy_checkpoint.h"
#include "models/bfm/search_distill.h"
#include "models/bfm/track_eval.h"
#include "test_bfm_sway.h"
#include "test_cli_util.h"

using namespace t2m;
using namespace t2m::bfm;
namespace fs = std::filesystem;

using t2m::test::humanoid;
using t2m::test::sway_refs;
using t2m::test::tiny_fb_config;

namespace {
// mu(s_r, z_r) of row r, recomputed.
std::vector<float> mean_of_row(FbAgent& agent, const SearchRows& rows, int64_t r) {
  const int D = agent.config().obs_dim, d = agent.config().z_dim;
  Tensor s = Tensor::empty({1, D}), z = Tensor::empty({1, d});
  std::copy_n(rows.obs.data() + r * D, D, s.data<float>());
  std::copy_n(rows.z.data() + r * d, d, z.data<float>());
  const Tensor a = agent.actor_mean(s, z).contiguous();
  return std::vector<float>(a.data<float>(), a.data<float>() + a.numel());
}

// Relabels rows with the mean of another actor of the same shape (seed 7): labels the fit can reach.
void label_with_teacher(SearchRows& rows) {
  FbAgent teacher(tiny_fb_config(), 7);
  for (int64_t i = 0; i < rows.rows(); ++i) {
    const std::vector<float> a = mean_of_row(teacher, rows, i);
    std::copy(a.begin(), a.end(), rows.action.begin() + i * (int64_t)a.size());
  }
}

fs::path scratch(const std::string& tag) {
  const fs::path w = fs::temp_directory_path() / ("t2m_search_distill_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(w);
  fs::create_directories(w);
  return w;
}
}  // namespace

TEST(BfmSearchDistill, RecordedRowsAreTheCleanMeansOnThePlainLatentWithOneCandidate) {
  FbAgent agent(tiny_fb_config(), 3);
  const RefMotions r = sway_refs({{20, 0.05}, {15, 0.1}});
  LatentSearchOptions o;
  o.samples = 1;  // δ = 0 only: the recorded action is mu(s, z_t) of the plain latent
  o.action_noise = 0.05;
  SearchRows rows;
  const auto res = track_bfm_search(agent, humanoid(), r, o, {}, 0, &rows);
  ASSERT_GT(rows.rows(), 0);
  const int A = agent.config().action_dim;
  ASSERT_EQ(rows.action.size(), (size_t)rows.rows() * A);
  for (int64_t i = 0; i < rows.rows(); ++i) {
    ASSERT_EQ(mean_of_row(agent, rows, i), std::vector<float>(rows.action.begin() + i * A, rows.action.begin() + (i + 1) * A)) << i;
    ASSERT_LE(rows.frame[i], r.frames(rows.clip[i]) - 2);
  }
  // The noise changes the path but not the labels' meaning; without noise the path is plain tracking's.
  o.action_noise = 0;
  const auto clean = track_bfm_search(agent, humanoid(), r, o);
  const auto plain = track_bfm(agent, humanoid(), r);
  EXPECT_EQ(clean[0].simulated.qpos, plain[0].simulated.qpos);
  EXPECT_NE(res[0].simulated.qpos, plain[0].simulated.qpos);
}

TEST(BfmSearchDistill, ElitesAverageOffsetsAndStillTrackCloserThanPlain) {
  auto agent = load_policy(std::string(T2M_SOURCE_DIR) + "/models/checkpoints/bfm_track.t2mckpt");
  const RefMotions r = sway_refs({{60, 0.05}});
  LatentSearchOptions o;
  o.samples = 16;
  o.horizon = 3;
  const auto best = track_bfm_search(*agent, humanoid(), r, o);
  o.elites = 4;
  SearchRows rows;
  const auto elite = track_bfm_search(*agent, humanoid(), r, o, {}, 0, &rows);
  const auto plain = track_bfm(*agent, humanoid(), r);
  EXPECT_NE(elite[0].simulated.qpos, best[0].simulated.qpos);
  EXPECT_GT(elite[0].frames_ok, plain[0].frames_ok) << "plain " << plain[0].frames_ok;
  // While the search is in charge every step is recorded; its actions are not the plain latent's.
  EXPECT_GE(rows.rows(), elite[0].frames_ok - 1);
  int differ = 0;
  const int A = agent->config().action_dim;
  for (int64_t i = 0; i < rows.rows(); ++i)
    differ += mean_of_row(*agent, rows, i) != std::vector<float>(rows.action.begin() + i * A, rows.action.begin() + (i + 1) * A);
  EXPECT_GT(differ, rows.rows() / 2);
}

TEST(BfmSearchDistill, RowsFileRoundTripsAndRefusesBadFiles) {
  FbAgent agent(tiny_fb_config(), 4);
  const RefMotions r = sway_refs({{12, 0.05}, {10, 0.1}});
  SearchRows rows = plain_tracking_rows(agent, humanoid(), r, 0.02, 5);
  ASSERT_GT(rows.rows(), 0);
  const fs::path w = scratch("file");
  const FbConfig c = agent.config();
  save_search_rows(rows, r.names, (w / "a.t2mckpt").string(), {{"note", 1}});
  std::vector<std::string> names;
  const SearchRows back = load_search_rows((w / "a.t2mckpt").string(), c.obs_dim, c.z_dim, c.action_dim, &names);
  EXPECT_EQ(names, r.names);
  EXPECT_EQ(back.obs, rows.obs);
  EXPECT_EQ(back.z, rows.z);
  EXPECT_EQ(back.action, rows.action);
  EXPECT_EQ(back.clip, rows.clip);
  EXPECT_EQ(back.frame, rows.frame);
  EXPECT_THROW(load_search_rows((w / "a.t2mckpt").string(), c.obs_dim, c.z_dim + 1, c.action_dim), Error);
  EXPECT_THROW(load_search_rows((w / "missing.t2mckpt").string(), c.obs_dim, c.z_dim, c.action_dim), Error);
  {  // truncated
    std::ifstream in(w / "a.t2mckpt", std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(w / "t.t2mckpt", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  EXPECT_THROW(load_search_rows((w / "t.t2mckpt").string(), c.obs_dim, c.z_dim, c.action_dim), Error);
  save_policy(agent, (w / "policy.t2mckpt").string());  // a checkpoint of another kind
  EXPECT_THROW(load_search_rows((w / "policy.t2mckpt").string(), c.obs_dim, c.z_dim, c.action_dim), Error);
  EXPECT_THROW(save_search_rows(rows, {"only-one-name"}, (w / "b.t2mckpt").string()), Error);  // clip 1 unnamed
  EXPECT_FALSE(fs::exists(w / "b.t2mckpt"));
  EXPECT_THROW(save_search_rows(SearchRows{}, r.names, (w / "c.t2mckpt").string()), Error);
  fs::remove_all(w);
}

TEST(BfmSearchDistill, AnchorRowsAreThePlainRolloutLabelledWithItsOwnMean) {
  FbAgent agent(tiny_fb_config(), 5);
  const RefMotions r = sway_refs({{15, 0.05}});
  const SearchRows a = plain_tracking_rows(agent, humanoid(), r, 0.0, 1);
  const auto plain = track_bfm(agent, humanoid(), r);
  ASSERT_GT(a.rows(), 0);
  ASSERT_LE(a.rows(), 14);
  const int A = agent.config().action_dim;
  for (int64_t i = 0; i < a.rows(); ++i) {
    EXPECT_EQ(a.frame[i], i);
    EXPECT_EQ(mean_of_row(agent, a, i), std::vector<float>(a.action.begin() + i * A, a.action.begin() + (i + 1) * A));
  }
  if (plain[0].frames_ok == r.frames(0)) {  // a clip tracked to the end gives every step
    EXPECT_EQ(a.rows(), 14);
  }
  const SearchRows n1 = plain_tracking_rows(agent, humanoid(), r, 0.1, 1), n2 = plain_tracking_rows(agent, humanoid(), r, 0.1, 1);
  EXPECT_EQ(n1.obs, n2.obs);  // deterministic for a seed
  EXPECT_THROW(plain_tracking_rows(agent, humanoid(), r, -1.0, 1), Error);
}

TEST(BfmSearchDistill, FitOverfitsAFewRowsAndKeepsTheAnchor) {
  FbAgent agent(tiny_fb_config(), 6);
  const RefMotions r = sway_refs({{12, 0.05}});
  SearchRows labels = plain_tracking_rows(agent, humanoid(), r, 0.05, 1);
  const SearchRows anchor = labels;  // the same states, labelled with the current mean
  label_with_teacher(labels);
  DistillOptions o;
  o.updates = 300;
  o.batch = 8;
  o.lr = 3e-3;
  o.anchor_weight = 0;
  FbAgent copy(tiny_fb_config(), 6);
  const DistillStats st = fit_actor_to_search(agent, labels, anchor, o);
  EXPECT_LT(st.label_rms_after, 0.5 * st.label_rms_before) << st.label_rms_before << " -> " << st.label_rms_after;
  EXPECT_LT(st.anchor_rms_before, 1e-6);  // its own mean (batched: rounding only)
  EXPECT_GT(st.anchor_rms_after, 0.0);  // nothing held the old behaviour
  // B is untouched: the Eq 2 latents stay the same.
  EXPECT_EQ(agent.embed_backward(clip_states(r, 0)).contiguous().to_vector<float>(),
            copy.embed_backward(clip_states(r, 0)).contiguous().to_vector<float>());
  // With a large anchor weight on the label states themselves the fit stays near the old mean.
  o.anchor_weight = 100;
  const DistillStats held = fit_actor_to_search(copy, labels, anchor, o);
  EXPECT_LT(held.anchor_rms_after, 0.5 * st.anchor_rms_after);
  o.anchor_weight = 1;
  EXPECT_THROW(fit_actor_to_search(copy, SearchRows{}, anchor, o), Error);       // no labels
  EXPECT_THROW(fit_actor_to_search(copy, labels, SearchRows{}, o), Error);       // anchor weight without rows
  o.lr = 0;
  EXPECT_THROW(fit_actor_to_search(copy, labels, anchor, o), Error);
  FbConfig other = tiny_fb_config();
  other.z_dim = 8;
  FbAgent wrong(other, 1);
  o.lr = 1e-3;
  EXPECT_THROW(fit_actor_to_search(wrong, labels, anchor, o), Error);  // rows of other dims
}

TEST(BfmSearchDistill, FitIsDeterministicForItsSeedAndTheSeedMatters) {
  const RefMotions r = sway_refs({{12, 0.05}});
  FbAgent base(tiny_fb_config(), 6);
  const SearchRows anchor = plain_tracking_rows(base, humanoid(), r, 0.05, 1);
  SearchRows labels = anchor;
  label_with_teacher(labels);
  DistillOptions o;
  o.updates = 20;
  o.batch = 4;  // fewer than the rows: the seed picks the batches
  o.lr = 3e-3;
  const auto fitted_mean = [&](uint64_t seed) {
    FbAgent agent(tiny_fb_config(), 6);
    o.seed = seed;
    fit_actor_to_search(agent, labels, anchor, o);
    return mean_of_row(agent, labels, 0);
  };
  ASSERT_GT(labels.rows(), o.batch);
  const std::vector<float> a7 = fitted_mean(7);
  EXPECT_EQ(a7, fitted_mean(7));
  EXPECT_NE(a7, fitted_mean(8));
}

TEST(BfmSearchDistill, SearchOptionsRefuseBadElitesAndNoise) {
  LatentSearchOptions o;
  o.samples = 8;
  o.elites = 9;
  EXPECT_THROW(check_search_options(o), Error);
  o.elites = 0;
  EXPECT_THROW(check_search_options(o), Error);
  o.elites = 8;
  EXPECT_NO_THROW(check_search_options(o));
  o.action_noise = -0.1;
  EXPECT_THROW(check_search_options(o), Error);
  o.action_noise = NAN;
  EXPECT_THROW(check_search_options(o), Error);
  o.action_noise = 0;
  o.transition = -1;
  EXPECT_THROW(check_search_options(o), Error);
  o.transition = 30;
  for (double f : {0.0, -1.0, (double)NAN, (double)INFINITY}) {
    o.transition_fail_distance = f;
    EXPECT_THROW(check_search_options(o), Error) << f;
  }
}

TEST(BfmSearchDistill, TrainBfmDistillRefusesBadFlags) {
  using t2m::test::read_text;
  using t2m::test::run_t2m;
  if (!fs::exists(t2m::test::t2m_binary())) GTEST_SKIP() << "t2m binary not built next to the test";
  const fs::path w = scratch("cli");
  const std::string policy = std::string(T2M_SOURCE_DIR) + "/models/checkpoints/bfm_track.t2mckpt";
  const fs::path out = w / "rows";
  const std::string good = "--policy '" + policy + "' --out '" + out.string() + "' ";
  fs::create_directories(w / "empty");  // an earlier round's directory without rows: refused before the search
  for (const std::string& args :
       {good + "--every 0", good + "--search-samples 8 --elites 9", good + "--action-noise -1", good + "--contents ,",
        good + "--chunk-clips 0", good + "--no-such-flag", good + "--every 3 --offset 3", good + "--offset -1", good + "--max-chunks -2",
        good + "--fit-seed x", good + "--standing-start --transition-fail-distance 0",
        good + "--standing-start --transition-frames -1",
        good + "--with-rows '" + (w / "none").string() + "'", good + "--with-rows '" + (w / "empty").string() + "'",
        "--policy '" + (w / "none").string() + "' --out '" + out.string() + "'"}) {
    EXPECT_NE(run_t2m("train bfm-distill " + args, w / "bad.log"), 0) << args;
    EXPECT_EQ(read_text(w / "bad.log").rfind("t2m: ", 0), 0u) << read_text(w / "bad.log");
    EXPECT_FALSE(fs::exists(out)) << args;
  }
  fs::remove_all(w);
}
