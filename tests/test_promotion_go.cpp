// test_promotion_go.cpp — the go-diffuser: shapes and bad inputs, double-precision gradcheck of the network, the
// role of the key tokens (masking them changes the output), a resumable training run on a real 60-frame Bandai
// clip (bit-identical resume, loss going down), and end-to-end generation from hand-made key poses: a motion of
// the right shape whose key frames are near the given poses.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <unistd.h>

#include "autograd/autograd.h"
#include "models/data/features.h"
#include "models/data/loader.h"
#include "models/promotion/go_diffuser.h"
#include "models/promotion/go_diffuser_checkpoint.h"
#include "models/promotion/go_diffuser_eval.h"
#include "models/promotion/go_diffuser_train.h"
#include "models/promotion/pose.h"
#include "nn/train_log.h"
#include "sim/bvh.h"
#include "tensor/ops.h"

namespace {

using namespace t2m;
using namespace t2m::promotion;
namespace fs = std::filesystem;

GoDiffuserConfig tiny() {
  GoDiffuserConfig c;
  c.frames = 16, c.keys = 4, c.width = 32, c.layers = 2, c.heads = 4, c.mlp_ratio = 2, c.diffusion_steps = 20;
  return c;
}

Tensor key_frames_for(int64_t B, const GoDiffuserConfig& c) {
  const auto f = key_frame_indices((int)c.frames, (int)c.keys);
  std::vector<int64_t> v;
  for (int64_t b = 0; b < B; ++b)
    for (int x : f) v.push_back(x);
  return Tensor::from_vector(v, {B, c.keys});
}

TEST(GoDiffuser, ShapesAndBadInputs) {
  Generator g(1);
  const auto c = tiny();
  GoDiffuser m(c, g);
  const Tensor x = rand_normal({2, 16, 257}, g), keys = rand_normal({2, 4, kPoseDim}, g);
  const Tensor t = Tensor::from_vector(std::vector<int64_t>{0, 19}, {2}), kf = key_frames_for(2, c);
  const Tensor km = Tensor::ones({2, 4});
  EXPECT_EQ(m.forward(ag::Variable(x), t, ag::Variable(keys), kf, km).data().shape(), (Shape{2, 16, 257}));
  EXPECT_THROW(m.forward(ag::Variable(rand_normal({2, 15, 257}, g)), t, ag::Variable(keys), kf, km), Error);
  EXPECT_THROW(m.forward(ag::Variable(x), t, ag::Variable(rand_normal({2, 3, kPoseDim}, g)), kf, km), Error);
  EXPECT_THROW(m.forward(ag::Variable(x), Tensor::full({2}, 20, DType::i64), ag::Variable(keys), kf, km), Error);
  EXPECT_THROW(m.forward(ag::Variable(x), t, ag::Variable(keys), Tensor::full({2, 4}, 16, DType::i64), km), Error);
  EXPECT_THROW(m.forward(ag::Variable(x), t, ag::Variable(keys), kf, Tensor::ones({2, 5})), Error);
  GoDiffuserConfig bad = c;
  bad.keys = 17;
  EXPECT_THROW(GoDiffuser(bad, g), Error);
  bad = c, bad.width = 30;  // not divisible by 4 heads
  EXPECT_THROW(GoDiffuser(bad, g), Error);
  bad = c, bad.cond_drop = 1.0;
  EXPECT_THROW(bad.validate(), Error);
  EXPECT_EQ(GoDiffuserConfig::from_json(c.to_json()).to_json(), c.to_json());
}

TEST(GoDiffuser, GradcheckInDouble) {
  Generator g(2);
  GoDiffuserConfig c = tiny();
  c.frames = 5, c.keys = 2, c.width = 8, c.layers = 1, c.heads = 2;
  GoDiffuser m(c, g);
  m.to(DType::f64);
  const Tensor t = Tensor::from_vector(std::vector<int64_t>{3}, {1}), kf = key_frames_for(1, c);
  const Tensor km = Tensor::ones({1, 2});
  auto f = [&](const std::vector<ag::Variable>& v) {
    return ag::sum(ag::square(m.forward(v[0], t, v[1], kf, km)));
  };
  ag::GradcheckOptions o;
  o.atol = 1e-5, o.rtol = 1e-4;
  const auto r = ag::gradcheck(f, {rand_normal({1, 5, 257}, g, 0, 1, DType::f64),
                                   rand_normal({1, 2, kPoseDim}, g, 0, 1, DType::f64)}, o);
  EXPECT_TRUE(r.ok) << r.message;
}

TEST(GoDiffuser, KeyTokensConditionTheOutput) {
  Generator g(3);
  const auto c = tiny();
  GoDiffuser m(c, g);
  m.eval();
  const Tensor x = rand_normal({1, 16, 257}, g), t = Tensor::full({1}, 5, DType::i64), kf = key_frames_for(1, c);
  const ag::Variable k1(rand_normal({1, 4, kPoseDim}, g)), k2(rand_normal({1, 4, kPoseDim}, g));
  const Tensor on = Tensor::ones({1, 4}), off = Tensor::zeros({1, 4});
  const Tensor a = m.forward(ag::Variable(x), t, k1, kf, on).data();
  const Tensor b = m.forward(ag::Variable(x), t, k2, kf, on).data();
  EXPECT_GT(amax(abs(sub(a, b))).item(), 1e-4);  // different keys, different output
  // Masked key tokens are invisible: any key values give the same output.
  const Tensor u1 = m.forward(ag::Variable(x), t, k1, kf, off).data();
  const Tensor u2 = m.forward(ag::Variable(x), t, k2, kf, off).data();
  EXPECT_LT(amax(abs(sub(u1, u2))).item(), 1e-6);
}

// Key-pose inpainting: the last DDPM step returns the x_0 estimate exactly, so with inpainting the sample carries
// the key poses at the key frames bit for bit (pose dims only; the other dims stay the network's), without it not.
TEST(GoDiffuser, InpaintingPassesThroughTheKeyPoses) {
  Generator g(8);
  const auto c = tiny();
  GoDiffuser m(c, g);
  m.eval();
  const Tensor keys = rand_normal({2, 4, kPoseDim}, g), kf = key_frames_for(2, c);
  Generator s1(5), s2(5);
  const auto with = m.sample(keys, kf, s1, 1.0, true).to_vector<float>();
  const auto without = m.sample(keys, kf, s2, 1.0, false).to_vector<float>();
  const auto kv = keys.to_vector<float>();
  const auto f = key_frame_indices((int)c.frames, (int)c.keys);
  double off_with = 0, off_without = 0;
  for (int b = 0; b < 2; ++b)
    for (int k = 0; k < 4; ++k)
      for (int d = 0; d < kPoseDim; ++d) {
        const float want = kv[(size_t)(b * 4 + k) * kPoseDim + d];
        const size_t at = ((size_t)b * c.frames + f[k]) * 257 + kPoseFeatureBegin + d;
        off_with = std::max(off_with, (double)std::fabs(with[at] - want));
        off_without = std::max(off_without, (double)std::fabs(without[at] - want));
      }
  EXPECT_EQ(off_with, 0.0);
  EXPECT_GT(off_without, 0.1);
  // Frames between the keys are the network's (not copies of a key pose).
  EXPECT_NE(with[(size_t)(f[0] + 1) * 257 + kPoseFeatureBegin], kv[0]);
}

// 8 copies of the first 16 frames of the real walk fixture: one window (and its mirror) to overfit (the loader
// visits each clip once per epoch; a batch of 8 needs 8 clips).
std::vector<data::MotionClip> walk_clip() {
  const auto bvh = sim::read_bvh(std::string(T2M_SOURCE_DIR) + "/tests/fixtures/bvh/bandai_walk_60.bvh");
  auto c = data::make_motion_clip("dataset-1_walk_normal_001", "walk", "normal", sim::motion_from_bvh(bvh));
  c.frames = 16;
  c.features.resize(16 * data::kFeatureDim);
  return std::vector<data::MotionClip>(8, c);
}

TEST(GoDiffuser, TrainsResumablyAndGeneratesFromKeyPoses) {
  const auto clips = walk_clip();
  const auto stats = data::clip_feature_stats(clips);
  const fs::path dir = fs::temp_directory_path() / ("t2m_go_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  GoTrainConfig tc;
  tc.steps = 150, tc.batch = 8, tc.lr = 3e-3, tc.warmup = 5, tc.save_every = 25, tc.seed = 4;
  const auto c = tiny();
  // Straight run vs the same run in two chunks (stop at 60, then resume): identical parameters.
  Generator g1(5), g2(5);
  GoDiffuser a(c, g1), b(c, g2);
  const GoTrainPaths pa{(dir / "a.state").string(), (dir / "a.jsonl").string(), ""};
  const GoTrainPaths pb{(dir / "b.state").string(), (dir / "b.jsonl").string(), ""};
  auto ra = train_go_diffuser(a, clips, stats, tc, pa, false, "test");
  GoTrainConfig first = tc;
  first.stop_at = 60;
  train_go_diffuser(b, clips, stats, first, pb, false, "test");
  train_go_diffuser(b, clips, stats, tc, pb, true, "test");
  EXPECT_EQ(ra.steps, 150);
  const auto pa_ = a.named_parameters(), pb_ = b.named_parameters();
  for (size_t i = 0; i < pa_.size(); ++i)
    EXPECT_EQ(pa_[i].second.data().to_vector<float>(), pb_[i].second.data().to_vector<float>()) << pa_[i].first;
  const auto log = nn::read_train_log(pa.log);
  ASSERT_EQ(log.size(), 150u);
  double early = 0, late = 0;
  for (int i = 0; i < 20; ++i) early += log[i]["loss"].get<double>(), late += log[130 + i]["loss"].get<double>();
  EXPECT_LT(late, 0.5 * early) << early / 20 << " -> " << late / 20;

  // Checkpoint round trip.
  GoBundle bundle{std::make_shared<GoDiffuser>(c, g1), stats, {}};
  bundle.model->load_from([&] { nn::Checkpoint ck; a.save_to(ck); return ck; }());
  save_go_checkpoint(bundle, (dir / "go.t2mckpt").string());
  const GoBundle back = load_go_checkpoint((dir / "go.t2mckpt").string());
  EXPECT_EQ(back.stats.mean, stats.mean);
  EXPECT_EQ(back.model->config().to_json(), c.to_json());

  // End to end on a toy planner output: the key poses of the clip's first window (hand-picked frames), normalised.
  std::vector<float> win(clips[0].features.begin(), clips[0].features.begin() + 16 * 257);
  data::normalize_features(win, stats);
  const auto kf_idx = key_frame_indices(16, 4);
  std::vector<float> keys;
  for (int f : kf_idx) {
    const auto p = pose_from_features(win.data() + f * 257);
    keys.insert(keys.end(), p.begin(), p.end());
  }
  Generator sg(6);
  const Tensor out = back.model->sample(Tensor::from_vector(keys, {1, 4, kPoseDim}), key_frames_for(1, c), sg);
  ASSERT_EQ(out.shape(), (Shape{1, 16, 257}));
  const auto o = out.to_vector<float>();
  double err = 0, base = 0;
  for (int i = 0; i < 4; ++i)
    for (int d = 0; d < kPoseDim; ++d) {
      const double want = keys[i * kPoseDim + d];
      err += std::pow(o[kf_idx[i] * 257 + 3 + d] - want, 2);
      base += want * want;  // the error of predicting the mean pose (0 in normalised units)
    }
  EXPECT_LT(err, 0.3 * base) << "key-frame MSE " << err / (4 * kPoseDim) << " vs mean-pose " << base / (4 * kPoseDim);
  // Denormalised, it is a motion the feature inverse accepts.
  std::vector<float> raw = o;
  data::denormalize_features(raw, back.stats);
  EXPECT_EQ(data::features_to_positions(raw).size(), 16u * 21 * 3);
  fs::remove_all(dir);
}

// APE / AVE: zero for identical motions; a constant height offset of every joint gives APE = offset (root, local,
// global), 0 trajectory error, AVE 0; bad inputs throw.
TEST(GoDiffuserEval, ApeAveValues) {
  const auto clip = walk_clip()[0];
  const std::vector<float>& a = clip.features;
  auto r0 = ape_ave({&a}, {&a});
  EXPECT_EQ(r0.ape_global, 0.0);
  EXPECT_EQ(r0.ave_global, 0.0);
  std::vector<float> b = a;
  for (int t = 0; t < clip.frames; ++t) {
    b[(size_t)t * 257 + data::kFeatRootHeight] += 0.1f;
    for (int j = 0; j < 20; ++j) b[(size_t)t * 257 + data::kFeatLocalPos + 3 * j + 2] += 0.1f;
  }
  const auto r = ape_ave({&a, &a}, {&b, &b});
  EXPECT_NEAR(r.ape_root, 0.1, 1e-5);
  EXPECT_NEAR(r.ape_traj, 0.0, 1e-6);
  EXPECT_NEAR(r.ape_local, 0.1, 1e-5);
  EXPECT_NEAR(r.ape_global, 0.1, 1e-5);
  EXPECT_NEAR(r.ave_global, 0.0, 1e-6);
  EXPECT_EQ(r.samples, 2);
  std::vector<float> short_b(b.begin(), b.begin() + 257 * 10);
  EXPECT_THROW(ape_ave({&a}, {&short_b}), Error);
  EXPECT_THROW(ape_ave({}, {}), Error);
}

}  // namespace
