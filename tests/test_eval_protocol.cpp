// test_eval_protocol.cpp — the R-run evaluation protocol: one run equals the metrics called by hand in the
// documented order, a real-motion ceiling row on synthetic embeddings (R-precision ~1, control at chance, FID 0),
// per-run sampling gives a CI > 0 and is reproducible, JSON report, errors.
#include <gtest/gtest.h>

#include <cmath>

#include "models/eval/protocol.h"
#include "tensor/ops.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

using namespace t2m;
using t2m::testing::randn;
using namespace t2m::eval;
using t2m::testing::expect_error;

namespace {

}  // namespace

TEST(EvalProtocol, OneRunEqualsTheMetricsInDocumentedOrder) {
  Tensor motion = randn({100, 6}, 1), text = add(motion, mul(randn({100, 6}, 2), 0.8));
  Tensor real = randn({80, 6}, 3), mm = randn({4, 12, 6}, 4);
  EvalProtocol p;
  p.runs = 1;
  p.seed = 77;
  p.diversity_pairs = 50;
  EvalReport rep = evaluate_protocol(p, [&](Generator&, int) { return EvalEmbeddings{text, motion, real, mm}; });
  const std::vector<std::string> want_names = {"r_precision_top1", "r_precision_top2", "r_precision_top3",
                                               "control_r_precision_top1", "control_r_precision_top2",
                                               "control_r_precision_top3", "fid", "mm_dist", "diversity",
                                               "multimodality"};
  EXPECT_EQ(rep.names, want_names);
  Generator g(run_seed(77, 0));
  RPrecision rp = r_precision(text, motion, g);
  RPrecision ctl = shuffled_r_precision(text, motion, g);
  const double f = fid(motion, real), mmd = mm_dist(text, motion);
  const double div = diversity(motion, g, 50), mmod = multimodality(mm, g, 10);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(rep.values[k].mean, rp.top[k]);
    EXPECT_EQ(rep.values[3 + k].mean, ctl.top[k]);
  }
  EXPECT_EQ(rep.at("fid").mean, f);
  EXPECT_EQ(rep.at("mm_dist").mean, mmd);
  EXPECT_EQ(rep.at("diversity").mean, div);
  EXPECT_EQ(rep.at("multimodality").mean, mmod);
  EXPECT_EQ(rep.at("fid").ci95, 0.0);  // one run
}

TEST(EvalProtocol, RealMotionCeilingRowOnSyntheticEmbeddings) {
  // Well-aligned encoders: text = motion + small noise; the real row compares real motions with themselves.
  const int64_t N = 32 * 20;
  Tensor motion = randn({N, 8}, 11), text = add(motion, mul(randn({N, 8}, 12), 0.02));
  EvalProtocol p;  // 20 runs, batches of 32
  p.seed = 5;
  EvalReport rep = evaluate_protocol(p, [&](Generator&, int) { return EvalEmbeddings{text, motion, motion, {}}; });
  EXPECT_FALSE(rep.has("multimodality"));
  EXPECT_EQ(rep.at("r_precision_top3").mean, 1.0);
  EXPECT_EQ(rep.at("r_precision_top3").ci95, 0.0);
  EXPECT_NEAR(rep.at("control_r_precision_top3").mean, 3.0 / 32.0, 0.02);
  EXPECT_GT(rep.at("control_r_precision_top3").ci95, 0.0);
  EXPECT_NEAR(rep.at("fid").mean, 0.0, 1e-9);
  EXPECT_NEAR(rep.at("mm_dist").mean, 0.02 * std::sqrt(8.0), 0.01);  // E||noise|| ~ sigma sqrt(D)
  EXPECT_NEAR(rep.at("diversity").mean, 4.0, 0.3);                    // E||a - b|| ~ sqrt(2 D) for N(0, I)
  EXPECT_GT(rep.at("diversity").ci95, 0.0);
  nlohmann::json j = rep.to_json();
  EXPECT_EQ(j["runs"], 20);
  EXPECT_EQ(j["batch_size"], 32);
  EXPECT_EQ(j["metrics"]["r_precision_top3"]["mean"], 1.0);
  EXPECT_TRUE(j["metrics"]["fid"].contains("ci95"));
  EXPECT_EQ(j["metrics"].size(), rep.names.size());
}

TEST(EvalProtocol, SamplingPerRunIsSeededAndReproducible) {
  Tensor text = randn({96, 5}, 21);
  auto embed = [&](Generator& gen, int) {
    Tensor motion = add(text, rand_normal({96, 5}, gen, 0.0, 1.0, DType::f64));  // a "generator" with noise
    return EvalEmbeddings{text, motion, text, {}};
  };
  EvalProtocol p;
  p.runs = 6;
  p.seed = 9;
  p.diversity_pairs = 96;
  EvalReport a = evaluate_protocol(p, embed), b = evaluate_protocol(p, embed);
  for (size_t i = 0; i < a.values.size(); ++i) EXPECT_EQ(a.values[i].mean, b.values[i].mean) << a.names[i];
  EXPECT_GT(a.at("fid").ci95, 0.0);
  EXPECT_GT(a.at("mm_dist").ci95, 0.0);
  p.seed = 10;
  EvalReport c = evaluate_protocol(p, embed);
  EXPECT_NE(a.at("fid").mean, c.at("fid").mean);
}

TEST(EvalProtocol, Errors) {
  Tensor x = randn({64, 4}, 31);
  EvalProtocol p;
  p.runs = 0;
  expect_error([&] { evaluate_protocol(p, [&](Generator&, int) { return EvalEmbeddings{x, x, {}, {}}; }); },
               {"evaluate_protocol", "runs must be >= 1"});
  p.runs = 3;
  p.diversity_pairs = 64;
  expect_error([&] {
    evaluate_protocol(p, [&](Generator&, int r) { return EvalEmbeddings{x, x, r == 1 ? x : Tensor(), {}}; });
  }, {"evaluate_protocol", "run 1 switched"});
  expect_error([&] { evaluate_protocol(p, [&](Generator&, int) { return EvalEmbeddings{x, x.slice(0, 0, 40), {}, {}}; }); },
               {"r_precision", "[64, 4]", "[40, 4]"});
  EvalReport rep = evaluate_protocol(p, [&](Generator&, int) { return EvalEmbeddings{x, x, {}, {}}; });
  expect_error([&] { rep.at("fid"); }, {"no metric named 'fid'"});
}
