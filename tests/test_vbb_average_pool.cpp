// test_vbb_average_pool.cpp — the average-pooling VBB (models/text2bfm/vbb_average_pool.h): for compression
// 1/4/8/16 its posterior mean is the mean of c consecutive latents and its decoder repeats each program frame c
// times (both against direct loops); scored by vbb_eval it gives the same numbers as evaluate_average_pooling,
// with and without the sphere projection; a deeper VBB initialised at pooling (--pool-init) reproduces it in train
// mode too (residual branches zeroed); project_rows_to_sphere; reconstruct_clip_latents; bad arguments.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "autograd/no_grad.h"
#include "models/text2bfm/vbb_average_pool.h"
#include "models/text2bfm/vbb_eval.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

using namespace t2m;
using namespace t2m::text2bfm;
using t2m::testing::expect_error;

namespace {

Tensor randn(const Shape& s, uint64_t seed) {
  Generator g(seed);
  return rand_normal(s, g, 0.0, 1.0, DType::f32);
}

}  // namespace

TEST(VbbAveragePool, EncoderMeanIsTheWindowMeanAndDecoderRepeats) {
  const int64_t d = 8, B = 2, Tz = 32;
  const Tensor z = randn({B, Tz, d}, 1).contiguous();
  const float* zp = z.data<float>();
  for (int64_t c : {1, 4, 8, 16}) {
    SCOPED_TRACE("compression " + std::to_string(c));
    auto vbb = make_average_pooling_vbb(d, c, 32);
    EXPECT_EQ(vbb->config().compression(), c);
    EXPECT_FALSE(vbb->is_training());
    ag::NoGradGuard ng;
    Generator g(0);
    const VbbPosterior q = vbb->encode(ag::Variable(z), g);
    const int64_t Tm = Tz / c;
    ASSERT_EQ(q.mu.shape(), (Shape{B, d, Tm}));
    const Tensor mu = q.mu.data().contiguous(), lv = q.logvar.data().contiguous();
    double worst = 0;
    for (int64_t b = 0; b < B; ++b)
      for (int64_t k = 0; k < d; ++k)
        for (int64_t j = 0; j < Tm; ++j) {
          double mean = 0;
          for (int64_t t = j * c; t < (j + 1) * c; ++t) mean += zp[(b * Tz + t) * d + k];
          mean /= (double)c;
          worst = std::max(worst, std::abs(mean - mu.data<float>()[(b * d + k) * Tm + j]));
          EXPECT_EQ(lv.data<float>()[(b * d + k) * Tm + j], -30.f);
        }
    EXPECT_LT(worst, 1e-5);
    const Tensor m = randn({B, d, Tm}, 2).contiguous();
    const Tensor zh = vbb->decode(ag::Variable(m), g).data().contiguous();
    ASSERT_EQ(zh.shape(), (Shape{B, Tz, d}));
    worst = 0;
    for (int64_t b = 0; b < B; ++b)
      for (int64_t t = 0; t < Tz; ++t)
        for (int64_t k = 0; k < d; ++k)
          worst = std::max(worst, (double)std::abs(zh.data<float>()[(b * Tz + t) * d + k] -
                                                   m.data<float>()[(b * d + k) * Tm + t / c]));
    EXPECT_LT(worst, 1e-5);
  }
}

TEST(VbbAveragePool, DeepVbbInitialisedAtPoolingReproducesItInTrainMode) {
  VbbConfig cfg = VbbConfig::with_compression(4, 8);
  cfg.width = 32;
  cfg.latent = 8;
  cfg.depth = 2;
  cfg.dropout = 0.1;
  Generator g(5);
  Vbb vbb(cfg, g);
  const Tensor z = randn({2, 16, 8}, 6);
  Tensor before;
  {
    ag::NoGradGuard ng;
    before = vbb.encode(ag::Variable(z), g).mu.data().clone();
  }
  init_vbb_as_average_pooling(vbb);
  vbb.train();
  auto ref = make_average_pooling_vbb(8, 4, 32);
  ag::NoGradGuard ng;
  const Tensor mu = vbb.encode(ag::Variable(z), g).mu.data(), want = ref->encode(ag::Variable(z), g).mu.data();
  EXPECT_LT(max_abs_diff(mu, want), 1e-5);
  EXPECT_GT(max_abs_diff(before, want), 1e-2);  // the random init was not pooling already
  const Tensor m = randn({2, 8, 4}, 7);
  EXPECT_LT(max_abs_diff(vbb.decode(ag::Variable(m), g).data(), ref->decode(ag::Variable(m), g).data()), 1e-5);
  VbbConfig bad = cfg;
  bad.latent = 6;
  Vbb v2(bad, g);
  expect_error([&] { init_vbb_as_average_pooling(v2); }, {"vbb average pool:", "latent 6", "in_dim 8"});
}

TEST(VbbAveragePool, ScoresEqualTheAveragePoolingRow) {
  LatentSet set;
  set.z_dim = 6;
  set.obs_dim = 1;
  Generator g(3);
  for (int c = 0; c < 3; ++c) {  // clips of 20, 37 and 9 frames (padded windows included)
    const int64_t T = c == 0 ? 20 : c == 1 ? 37 : 9;
    set.names.push_back("clip" + std::to_string(c));
    set.content.push_back("walk");
    set.style.push_back("normal");
    const Tensor zc = rand_normal({T, set.z_dim}, g, 0.0, 1.0, DType::f32).contiguous();
    set.z.insert(set.z.end(), zc.data<float>(), zc.data<float>() + zc.numel());
    set.states.insert(set.states.end(), (size_t)T, 0.f);
    set.offset.push_back(set.offset.back() + T);
  }
  for (bool project : {false, true}) {
    auto vbb = make_average_pooling_vbb(set.z_dim, 4, 32);
    const VbbEvalResult a = evaluate_vbb(*vbb, set, 16, nullptr, 4, project);
    const VbbEvalResult b = evaluate_average_pooling(set, 4, 16, nullptr, 4, project);
    EXPECT_EQ(a.frames, 66);
    EXPECT_EQ(a.frames, b.frames);
    EXPECT_GT(a.latent_mse, 0.1);
    EXPECT_NEAR(a.latent_mse, b.latent_mse, 1e-5 * b.latent_mse) << "project " << project;
  }
  // Projection changes the pooled score (the means are shorter than sqrt(d)).
  EXPECT_GT(std::abs(evaluate_average_pooling(set, 4, 16, nullptr, 4, true).latent_mse -
                     evaluate_average_pooling(set, 4, 16, nullptr, 4, false).latent_mse),
            1e-3);
}

TEST(VbbAveragePool, ProjectRowsToSphere) {
  const Tensor z = randn({3, 5, 4}, 4);
  const Tensor p = project_rows_to_sphere(z).contiguous();
  ASSERT_EQ(p.shape(), z.shape());
  const Tensor zc = z.contiguous();
  for (int64_t r = 0; r < 15; ++r) {
    double n = 0, dot = 0, nz = 0;
    for (int64_t k = 0; k < 4; ++k) {
      n += (double)p.data<float>()[r * 4 + k] * p.data<float>()[r * 4 + k];
      nz += (double)zc.data<float>()[r * 4 + k] * zc.data<float>()[r * 4 + k];
      dot += (double)p.data<float>()[r * 4 + k] * zc.data<float>()[r * 4 + k];
    }
    EXPECT_NEAR(n, 4.0, 1e-5);
    EXPECT_NEAR(dot, std::sqrt(n * nz), 1e-4);  // same direction
  }
  Tensor zero = Tensor::zeros({2, 4});
  EXPECT_EQ(project_rows_to_sphere(zero).data<float>()[3], 0.f);
}

// One clip through the pooling VBB as the tracking row `eval text2bfm --tracking --through-vbb` uses it: each latent
// becomes the projected mean of its block of c, the last block padded by repeating the clip's last latent.
TEST(VbbAveragePool, ReconstructClipLatentsIsTheProjectedBlockMean) {
  const int64_t d = 8, c = 4, T = 10;  // blocks [0,4) [4,8) [8,10)+2 copies of latent 9
  const Tensor z = randn({T, d}, 5).contiguous();
  auto vbb = make_average_pooling_vbb(d, c, 32);
  const Tensor r = reconstruct_clip_latents(*vbb, z).contiguous();
  ASSERT_EQ(r.shape(), (Shape{T, d}));
  const float* zp = z.data<float>();
  double worst = 0;
  for (int64_t t = 0; t < T; ++t) {
    std::vector<double> mean(d, 0.0);
    const int64_t j0 = t / c * c;
    for (int64_t u = j0; u < j0 + c; ++u)
      for (int64_t k = 0; k < d; ++k) mean[k] += zp[std::min(u, T - 1) * d + k] / (double)c;
    double n2 = 0;
    for (double v : mean) n2 += v * v;
    for (int64_t k = 0; k < d; ++k)
      worst = std::max(worst, std::abs(mean[k] * std::sqrt(d / n2) - r.data<float>()[t * d + k]));
  }
  EXPECT_LT(worst, 1e-4);
  expect_error([&] { reconstruct_clip_latents(*vbb, randn({T, d + 1}, 6)); }, {"program dataset:", "latents"});
}

TEST(VbbAveragePool, BadArguments) {
  expect_error([] { make_average_pooling_vbb(8, 2, 32); }, {"vbb average pool:", "1, 4, 8 or 16", "2"});
  expect_error([] { make_average_pooling_vbb(0, 8, 32); }, {"vbb average pool:", "in_dim"});
  expect_error([] { make_average_pooling_vbb(20, 8, 32); }, {"vbb average pool:", "width", "40", "32"});
  expect_error([] { make_average_pooling_vbb(8, 8, 48); }, {"vbb average pool:", "width", "48"});
}
