// test_casim_vq.cpp — the motion tokenizer of the AR CASIM baseline: nearest-code assignment, the EMA formula on a
// hand-computed example, dead-code reset, the straight-through gradient, a gradcheck and value check of the
// loss, a tiny overfit, checkpoint round trip and bad inputs.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <unistd.h>
#include <vector>

#include "autograd/autograd.h"
#include "models/casim/ar_checkpoint.h"
#include "models/casim/vq_codebook.h"
#include "models/casim/vq_vae.h"
#include "nn/optim_adamw.h"
#include "tensor/ops.h"

namespace {

using namespace t2m;
using namespace t2m::casim;

Tensor mat(std::vector<float> v, int64_t r, int64_t c) { return Tensor::from_vector(v, {r, c}); }

void set_state(VqCodebook& cb, const std::vector<float>& codes, const std::vector<float>& sum,
               const std::vector<float>& count) {
  auto copy = [](const Tensor& dst, const std::vector<float>& v) {
    Tensor d = dst;
    for (size_t i = 0; i < v.size(); ++i) d.data<float>()[i] = v[i];
  };
  copy(cb.codebook(), codes), copy(cb.ema_sum(), sum), copy(cb.ema_count(), count);
}

std::unique_ptr<VqCodebook> make_initialised(const VqCodebookConfig& c) {
  Generator g(1);
  auto p = std::make_unique<VqCodebook>(c, g);
  VqCodebook& cb = *p;
  // The first update initialises from encoder outputs; do it so the following updates are EMA updates.
  Tensor z = rand_normal({c.codes, c.dim}, g);
  cb.ema_update(z, cb.assign(z), g);
  EXPECT_TRUE(cb.initialised());
  return p;
}

TEST(CasimVqCodebook, AssignPicksTheNearestCode) {
  VqCodebookConfig c;
  c.codes = 7, c.dim = 3;
  Generator g(3);
  VqCodebook cb(c, g);
  const Tensor z = rand_normal({40, 3}, g);
  const auto ids = cb.assign(z).to_vector<int64_t>();
  const auto e = cb.codebook().to_vector<float>(), zv = z.to_vector<float>();
  for (int n = 0; n < 40; ++n) {
    int best = -1;
    double bd = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 7; ++k) {
      double d = 0;
      for (int j = 0; j < 3; ++j) d += std::pow((double)zv[n * 3 + j] - e[k * 3 + j], 2);
      if (d < bd) bd = d, best = k;
    }
    EXPECT_EQ(ids[n], best) << "row " << n;
  }
  // A point exactly on a code maps to it.
  EXPECT_EQ(cb.assign(cb.lookup(Tensor::from_vector(std::vector<int64_t>{5}, {1}))).to_vector<int64_t>()[0], 5);
}

TEST(CasimVqCodebook, EmaUpdateMatchesAHandComputedExample) {
  VqCodebookConfig c;
  c.codes = 2, c.dim = 2, c.decay = 0.5, c.dead_threshold = 0.1;
  auto cbp = make_initialised(c);
  VqCodebook& cb = *cbp;
  set_state(cb, {0, 0, 10, 10}, {0, 0, 20, 20}, {2, 2});
  // Rows 0, 1 -> code 0; row 2 -> code 1.
  const Tensor z = mat({1, 2, 3, 4, 9, 11}, 3, 2);
  const Tensor ids = Tensor::from_vector(std::vector<int64_t>{0, 0, 1}, {3});
  Generator g(9);
  EXPECT_EQ(cb.ema_update(z, ids, g), 0);
  // count = 0.5*2 + 0.5*(2, 1) = (2, 1.5); sum_0 = 0.5*(0,0) + 0.5*(4,6) = (2,3); sum_1 = 0.5*(20,20)+0.5*(9,11)
  EXPECT_EQ(cb.ema_count().to_vector<float>(), (std::vector<float>{2.0f, 1.5f}));
  EXPECT_EQ(cb.ema_sum().to_vector<float>(), (std::vector<float>{2.0f, 3.0f, 14.5f, 15.5f}));
  const auto e = cb.codebook().to_vector<float>();
  EXPECT_FLOAT_EQ(e[0], 1.0f);
  EXPECT_FLOAT_EQ(e[1], 1.5f);
  EXPECT_FLOAT_EQ(e[2], 14.5f / 1.5f);
  EXPECT_FLOAT_EQ(e[3], 15.5f / 1.5f);
}

TEST(CasimVqCodebook, DeadCodeResetReplacesExactlyTheDeadCodes) {
  VqCodebookConfig c;
  c.codes = 4, c.dim = 2, c.decay = 0.5, c.dead_threshold = 1.0;
  auto cbp = make_initialised(c);
  VqCodebook& cb = *cbp;
  // Codes 2 and 3 have low counts and get no rows this batch: 0.5 * 1.5 = 0.75 < 1 -> dead. Code 1 gets none
  // either but stays alive (0.5 * 4 = 2).
  set_state(cb, {0, 0, 5, 5, 50, 50, 70, 70}, {0, 0, 20, 20, 75, 75, 105, 105}, {2, 4, 1.5, 1.5});
  const Tensor z = mat({0.5f, 0.5f, -0.5f, 0.25f, 1, 1}, 3, 2);
  const Tensor ids = Tensor::from_vector(std::vector<int64_t>{0, 0, 0}, {3});
  Generator g(4);
  EXPECT_EQ(cb.ema_update(z, ids, g), 2);
  const auto e = cb.codebook().to_vector<float>(), cnt = cb.ema_count().to_vector<float>();
  const auto s = cb.ema_sum().to_vector<float>();
  // Alive: code 0 = (0.5*(0,0) + 0.5*(1,1.75)) / (0.5*2 + 0.5*3) = (0.5, 0.875)/2.5; code 1 = (10,10)/2 = 5.
  EXPECT_FLOAT_EQ(e[0], 0.5f / 2.5f);
  EXPECT_FLOAT_EQ(e[1], 0.875f / 2.5f);
  EXPECT_FLOAT_EQ(e[2], 5.0f);
  EXPECT_FLOAT_EQ(e[3], 5.0f);
  EXPECT_FLOAT_EQ(cnt[0], 2.5f);
  EXPECT_FLOAT_EQ(cnt[1], 2.0f);
  // Dead: each is one of this batch's rows, with restarted averages.
  const auto zv = z.to_vector<float>();
  for (int k = 2; k < 4; ++k) {
    bool found = false;
    for (int n = 0; n < 3; ++n) found |= e[k * 2] == zv[n * 2] && e[k * 2 + 1] == zv[n * 2 + 1];
    EXPECT_TRUE(found) << "code " << k << " = (" << e[k * 2] << ", " << e[k * 2 + 1] << ")";
    EXPECT_EQ(cnt[k], 1.0f);
    EXPECT_EQ(s[k * 2], e[k * 2]);
  }
}

TEST(CasimVqCodebook, StraightThroughPassesTheGradientUnchanged) {
  VqCodebookConfig c;
  c.codes = 5, c.dim = 3;
  Generator g(5);
  VqCodebook cb(c, g);
  ag::Variable z(rand_normal({4, 3}, g), true);
  const Tensor ids = cb.assign(z.data());
  const ag::Variable q = cb.quantize_st(z, ids);
  // Forward: the codes. Backward: d sum(w * q) / dz = w.
  const auto qv = q.data().to_vector<float>(), lv = cb.lookup(ids).to_vector<float>();
  for (size_t i = 0; i < qv.size(); ++i) EXPECT_NEAR(qv[i], lv[i], 1e-6);
  const Tensor w = rand_normal({4, 3}, g);
  ag::sum(q * ag::Variable(w)).backward();
  const auto gv = z.grad().to_vector<float>(), wv = w.to_vector<float>();
  for (size_t i = 0; i < gv.size(); ++i) EXPECT_FLOAT_EQ(gv[i], wv[i]);
  EXPECT_FALSE(cb.named_parameters()[0].second.grad().defined());  // the codebook learns by EMA only
}

VqVaeConfig tiny_config() {
  VqVaeConfig c;
  c.feature_dim = 6, c.width = 8, c.depth = 1, c.groups = 4;
  c.codebook.codes = 16, c.codebook.dim = 4;
  return c;
}

TEST(CasimVqVae, DecoderGradcheckAndLossValue) {
  Generator g(7);
  VqVae m(tiny_config(), g);
  m.to(DType::f64);
  const Tensor zq = rand_normal({1, 2, 4}, g, 0.0, 1.0, DType::f64);
  const auto r = ag::gradcheck([&](const std::vector<ag::Variable>& v) { return m.decode(v[0]); }, {zq});
  EXPECT_TRUE(r.ok) << r.message;
  m.to(DType::f32);
  // Loss value: recon MSE over real frames + 0.5 * velocity MSE + 0.02 * commitment, recomputed by hand.
  const Tensor x = rand_normal({2, 8, 6}, g);
  const Tensor mask = Tensor::from_vector(std::vector<float>{1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 0, 0, 0, 0}, {2, 8});
  m.codebook().ema_update(m.encode(ag::Variable(x)).data().reshape({-1, 4}),
                          Tensor::zeros({4}, DType::i64), g);  // initialise the codes
  const VqStep s = vq_loss(m, x, mask);
  const auto xr = s.recon.data().to_vector<float>(), xv = x.to_vector<float>(), mk = mask.to_vector<float>();
  double rec = 0, vel = 0, nr = 0, nv = 0;
  for (int b = 0; b < 2; ++b)
    for (int t = 0; t < 8; ++t)
      for (int d = 0; d < 6; ++d) {
        const int i = (b * 8 + t) * 6 + d;
        rec += mk[b * 8 + t] * std::pow(xr[i] - xv[i], 2), nr += mk[b * 8 + t];
        if (t > 0) vel += mk[b * 8 + t] * std::pow((xr[i] - xr[i - 6]) - (xv[i] - xv[i - 6]), 2), nv += mk[b * 8 + t];
      }
  EXPECT_NEAR(s.rec, rec / nr, 1e-5);
  EXPECT_NEAR(s.vel, vel / nv, 1e-5);
  EXPECT_NEAR(s.loss.item(), s.rec + 0.5 * s.vel + 0.02 * s.commit, 1e-5);
  // Latent frames 0, 1 of item 0 and frame 0 of item 1 (its frame 4 is padding) are real; the other is -1.
  EXPECT_EQ(s.ids_real.size(0), 3);
  EXPECT_EQ(s.ids.to_vector<int64_t>()[3], -1);
}

TEST(CasimVqVae, OverfitsATinyBatch) {
  Generator g(11);
  VqVae m(tiny_config(), g);
  // Two smooth sequences (B, 16, 6).
  std::vector<float> xv(2 * 16 * 6);
  for (int b = 0; b < 2; ++b)
    for (int t = 0; t < 16; ++t)
      for (int d = 0; d < 6; ++d) xv[(b * 16 + t) * 6 + d] = (float)std::sin(0.4 * t * (d + 1) + b);
  const Tensor x = Tensor::from_vector(xv, {2, 16, 6}), mask = Tensor::ones({2, 16});
  nn::AdamWOptions ao;
  ao.lr = 3e-3;
  nn::AdamW opt(m.trainable_parameters(), ao);
  double first = 0, last = 0;
  for (int step = 0; step < 200; ++step) {
    opt.zero_grad();
    VqStep s = vq_loss(m, x, mask);
    s.loss.backward();
    opt.step();
    m.codebook().ema_update(s.z_real, s.ids_real, g);
    if (step == 0) first = s.rec;
    last = s.rec;
  }
  EXPECT_LT(last, 0.15 * first) << "first " << first << " last " << last;
  // tokenize -> detokenize reproduces what the loss saw (same codes, same decoder).
  const Tensor ids = m.tokenize(x);
  EXPECT_EQ(ids.shape(), (Shape{2, 4}));
  EXPECT_EQ(m.detokenize(ids).shape(), (Shape{2, 16, 6}));
}

TEST(CasimVqVae, CheckpointRoundTripAndBadInputs) {
  Generator g(13);
  VqBundle b;
  b.model = std::make_shared<VqVae>(tiny_config(), g);
  b.stats.mean.assign(6, 0.5f), b.stats.std.assign(6, 2.0f);
  const std::string p = std::filesystem::temp_directory_path() / ("casim_vq_" + std::to_string(getpid()) + ".ck");
  save_vq(b, p);
  const VqBundle r = load_vq(p);
  const Tensor x = rand_normal({1, 8, 6}, g);
  EXPECT_EQ(r.model->tokenize(x).to_vector<int64_t>(), b.model->tokenize(x).to_vector<int64_t>());
  EXPECT_EQ(r.stats.std, b.stats.std);
  EXPECT_THROW(load_ar(p), Error);  // a tokenizer is not a GPT file
  std::filesystem::remove(p);
  EXPECT_THROW(b.model->tokenize(rand_normal({1, 6, 6}, g)), Error);   // T not a multiple of 4
  EXPECT_THROW(b.model->tokenize(rand_normal({1, 8, 5}, g)), Error);   // wrong feature dim
  EXPECT_THROW(b.model->detokenize(Tensor::from_vector(std::vector<int64_t>{16}, {1, 1})), Error);  // id >= K
  EXPECT_THROW(vq_loss(*b.model, x, Tensor::ones({1, 4})), Error);   // mask shape
  VqVaeConfig bad = tiny_config();
  bad.groups = 3;
  EXPECT_THROW(VqVae(bad, g), Error);
}

}  // namespace
