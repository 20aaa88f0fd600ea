// test_promotion_planning.cpp — PRO-Motion posture planning: the pose / script encoders (gradcheck in double,
// unit embeddings, a tiny contrastive overfit on the key poses of a real Bandai clip), the emission / transition
// scores (softmax-normalised, value check against a direct computation), the Viterbi choice over a candidate
// lattice (consistency: the chosen poses are the path's candidates), the bundle round trip and bad inputs.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <unistd.h>

#include "autograd/autograd.h"
#include "models/data/loader.h"
#include "models/promotion/pose_text_encoders_train.h"
#include "models/promotion/promotion_pipeline.h"
#include "models/promotion/viterbi.h"
#include "models/text/retrieval_model.h"
#include "nn/train_log.h"
#include "sim/bvh.h"
#include "tensor/ops.h"

namespace {

using namespace t2m;
using namespace t2m::promotion;
namespace fs = std::filesystem;

PoseTextConfig tiny(int64_t vocab) {
  PoseTextConfig c;
  c.embed = 16, c.pose_hidden = 32, c.word_dim = 16, c.gru_hidden = 16, c.vocab = vocab;
  return c;
}

std::vector<data::MotionClip> walk() {
  const auto bvh = sim::read_bvh(std::string(T2M_SOURCE_DIR) + "/tests/fixtures/bvh/bandai_walk_60.bvh");
  return {data::make_motion_clip("dataset-1_walk_normal_001", "walk", "normal", sim::motion_from_bvh(bvh))};
}

TEST(PoseTextEncoders, UnitEmbeddingsAndGradcheck) {
  const auto tok = posture_script_tokenizer();
  Generator g(1);
  PoseTextEncoders m(tiny(tok.vocab_size()), g);
  const auto eb = text::encode_captions(tok, {"both knees are straight.", "the torso is vertical, the hands are "
                                                                          "spread apart."}, 96);
  const Tensor te = m.embed_scripts(eb.ids, eb.mask).data(), pe = m.embed_poses(ag::Variable(rand_normal({3, 187}, g))).data();
  EXPECT_EQ(te.shape(), (Shape{2, 16}));
  for (int i = 0; i < 2; ++i) EXPECT_NEAR(sum(square(te.select(0, i))).item(), 1.0, 1e-5);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(sum(square(pe.select(0, i))).item(), 1.0, 1e-5);
  m.to(DType::f64);
  auto f = [&](const std::vector<ag::Variable>& v) {
    return ag::sum(ag::mul(m.embed_poses(v[0]), m.embed_scripts(eb.ids, eb.mask)));
  };
  const auto r = ag::gradcheck(f, {rand_normal({2, 187}, g, 0, 1, DType::f64)});
  EXPECT_TRUE(r.ok) << r.message;
  EXPECT_THROW(m.embed_poses(ag::Variable(Tensor::zeros({2, 186}, DType::f64))), Error);
  EXPECT_THROW(m.embed_scripts(eb.ids, Tensor::ones({2, 3})), Error);
}

TEST(PoseTextEncoders, ScoresAreLogSoftmaxesOfScaledCosines) {
  const auto tok = posture_script_tokenizer();
  Generator g(2);
  PoseTextEncoders m(tiny(tok.vocab_size()), g);
  m.eval();
  const int K = 3, N = 4;
  const Tensor cand = rand_normal({K, N, 187}, g);
  const std::vector<std::string> scripts = {"both knees are straight.", "the left knee is bent.", "both feet are on "
                                                                                                  "the ground."};
  const auto s = posture_planning_scores(m, tok, cand, scripts);
  ASSERT_EQ(s.emission.shape(), (Shape{K, N}));
  ASSERT_EQ(s.transition.shape(), (Shape{K - 1, N, N}));
  for (int k = 0; k < K; ++k) EXPECT_NEAR(sum(exp(s.emission.select(0, k))).item(), 1.0, 1e-9);
  for (int k = 0; k < K - 1; ++k)
    for (int j = 0; j < N; ++j) EXPECT_NEAR(sum(exp(s.transition.select(0, k).select(0, j))).item(), 1.0, 1e-9);
  // Direct computation of one entry of each.
  const Tensor pe = m.embed_poses(ag::Variable(cand.reshape({K * N, 187}))).data().to(DType::f64);
  const auto eb = text::encode_captions(tok, scripts, 96);
  const Tensor te = m.embed_scripts(eb.ids, eb.mask).data().to(DType::f64);
  const double gm = m.gamma();
  auto dot = [](const Tensor& a, const Tensor& b) { return sum(mul(a, b)).item(); };
  double z = 0;
  for (int j = 0; j < N; ++j) z += std::exp(gm * dot(te.select(0, 1), pe.select(0, N + j)));
  EXPECT_NEAR(s.emission.at({1, 2}), gm * dot(te.select(0, 1), pe.select(0, N + 2)) - std::log(z), 1e-6);
  z = 0;
  for (int k = 0; k < N; ++k) z += std::exp(gm * dot(pe.select(0, 3), pe.select(0, N + k)));
  EXPECT_NEAR(s.transition.at({0, 3, 1}), gm * dot(pe.select(0, 3), pe.select(0, N + 1)) - std::log(z), 1e-6);
  EXPECT_THROW(posture_planning_scores(m, tok, cand, {"a", "b"}), Error);
}

TEST(PoseTextEncoders, OverfitAndPlanOnRealKeyPoses) {
  const auto clips = walk();
  const auto set = build_posture_script_set(clips, 8, true);  // 16 (key pose, script) pairs
  ASSERT_EQ(set.size(), 16);
  const auto stats = pose_stats_from_feature_stats(data::clip_feature_stats(clips));
  const auto tok = posture_script_tokenizer();
  Generator g(3);
  auto m = std::make_shared<PoseTextEncoders>(tiny(tok.vocab_size()), g);
  const fs::path dir = fs::temp_directory_path() / ("t2m_enc_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const double before = pose_text_retrieval(*m, tok, set, stats, 16).pose_to_script_top1;
  EncodersTrainConfig tc;
  tc.steps = 40, tc.batch = 8, tc.lr = 3e-3, tc.warmup = 5, tc.save_every = 40;
  const EncodersTrainPaths p{(dir / "s").string(), (dir / "log.jsonl").string(), ""};
  train_pose_text_encoders(*m, tok, set, stats, tc, p, false, "test");
  const auto log = nn::read_train_log(p.log);
  ASSERT_EQ(log.size(), 40u);
  double early = 0, late = 0;
  for (int i = 0; i < 5; ++i) early += log[i]["loss"].get<double>(), late += log[35 + i]["loss"].get<double>();
  EXPECT_LT(late, 0.8 * early) << early / 5 << " -> " << late / 5;
  const auto ret = pose_text_retrieval(*m, tok, set, stats, 16);
  EXPECT_GT(ret.pose_to_script_top1, before);

  // Posture planning over candidates: for each key frame the true key pose among poses of other frames; the
  // choice is the Viterbi path of the scores, and its poses are the candidates on that path.
  const int K = 8, N = 3;
  std::vector<float> cands;
  std::vector<std::string> scripts;
  for (int k = 0; k < K; ++k) {
    scripts.push_back(set.scripts[k]);
    for (int j = 0; j < N; ++j) {
      const float* pz = set.pose(j == 0 ? k : (k + 3 * j) % K);
      cands.insert(cands.end(), pz, pz + kPoseDim);
    }
  }
  PoseTextBundle b{m, tok, stats, {}};
  save_pose_text_bundle(b, (dir / "enc.t2mckpt").string());
  const PoseTextBundle back = load_pose_text_bundle((dir / "enc.t2mckpt").string());
  const PostureChoice c = plan_key_poses(back, cands, K, N, scripts);
  std::vector<float> norm = cands;
  normalize_poses(norm, stats);
  const auto s = posture_planning_scores(*m, tok, Tensor::from_vector(norm, {K, N, kPoseDim}), scripts);
  EXPECT_EQ(c.path, viterbi_decode(s.emission, s.transition).path);
  for (int k = 0; k < K; ++k) {
    EXPECT_EQ(c.poses[(size_t)k * kPoseDim + 5], cands[((size_t)k * N + c.path[k]) * kPoseDim + 5]);
  }
  EXPECT_NEAR(c.score, viterbi_path_score(s.emission, s.transition, c.path), 1e-9);
  EXPECT_THROW(plan_key_poses(back, cands, K, N + 1, scripts), Error);
  fs::remove_all(dir);
}

}  // namespace
