// test_vbb.cpp — the VBB model (models/text2bfm/vbb.h): shapes and parameter counts for compression 1/4/8/16 (counts
// for 4/8/16 equal the anchor MotionVAE's, printed by torch), the torch name map, causality of encoder and decoder, dropout
// only in train mode, a float64 finite-difference check of every parameter and the input on a tiny config, a
// tiny-batch overfit, and bad configs / inputs.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "autograd/gradcheck.h"
#include "autograd/no_grad.h"
#include "autograd/ops_elementwise.h"
#include "autograd/ops_reduce.h"
#include "autograd/ops_unary.h"
#include "models/text2bfm/vbb.h"
#include "models/text2bfm/vbb_loss.h"
#include "nn/loss_gaussian.h"
#include "nn/loss_regression.h"
#include "nn/optim_adamw.h"
#include "tensor/ops.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

using namespace t2m;
using namespace t2m::text2bfm;
using t2m::testing::expect_error;

namespace {

Tensor randn(const Shape& s, uint64_t seed, DType dt = DType::f32) {
  Generator g(seed);
  return rand_normal(s, g, 0.0, 1.0, dt);
}

VbbConfig tiny(int64_t levels = 1) {
  VbbConfig c;
  c.in_dim = 3;
  c.width = 4;
  c.latent = 2;
  c.levels = levels;
  c.depth = 2;
  c.growth = 2;
  c.groups = 2;
  c.dropout = 0.1;
  return c;
}

}  // namespace

TEST(Vbb, ShapesAndParameterCountsForEveryCompression) {
  // Anchor MotionVAE(in_dim=64, levels=L) parameter counts, from torch (sum of numel over parameters()).
  // Compression 1 ("no compression", zero stride-2 levels): one level adds 6530464 − 4489120 = 2041344 parameters
  // (a stride-2 conv and a residual stack in each of encoder and decoder), so 4489120 − 2 · 2041344 = 406432.
  const int64_t want[4] = {406432, 4489120, 6530464, 8571808};
  int i = 0;
  for (int64_t c : {1, 4, 8, 16}) {
    Generator g(1);
    VbbConfig cfg = VbbConfig::with_compression(c, 64);
    EXPECT_EQ(cfg.compression(), c);
    Vbb vbb(cfg, g);
    EXPECT_EQ(vbb.num_parameters(), want[i++]) << "compression " << c;
    vbb.eval();
    ag::NoGradGuard ng;
    const int64_t Tz = 32;
    VbbOutput o = vbb.forward(ag::Variable(randn({2, Tz, 64}, 2)), g);
    EXPECT_EQ(o.mu.shape(), (Shape{2, 48, Tz / c}));
    EXPECT_EQ(o.logvar.shape(), (Shape{2, 48, Tz / c}));
    EXPECT_EQ(o.m.shape(), (Shape{2, 48, Tz / c}));
    EXPECT_EQ(o.z_hat.shape(), (Shape{2, Tz, 64}));
    EXPECT_TRUE(std::isfinite(sum(o.z_hat.data()).item()));
  }
  // The anchor's bench config (in 256, compression 8): 6.83M parameters.
  Generator g(1);
  VbbConfig cfg;
  cfg.in_dim = 256;
  EXPECT_EQ(Vbb(cfg, g).num_parameters(), 6825568);
}

TEST(Vbb, ParameterNamesMapToTorch) {
  Generator g(1);
  Vbb vbb(tiny(2), g);
  std::set<std::string> names;
  for (auto& [n, v] : vbb.named_parameters()) names.insert(vbb_torch_name(n));
  for (const char* n : {"enc.0.conv.weight", "enc.0.conv.bias", "enc.2.conv.weight", "enc.3.0.n1.weight",
                        "enc.3.1.c1.conv.weight", "enc.3.1.c2.weight", "enc.4.conv.bias", "enc.5.0.n2.bias",
                        "enc.6.conv.weight", "dec.0.conv.weight", "dec.2.1.c1.conv.bias", "dec.4.conv.weight",
                        "dec.5.0.n1.weight", "dec.7.conv.weight", "dec.8.conv.weight", "dec.10.conv.bias"})
    EXPECT_TRUE(names.count(n)) << n;
  EXPECT_EQ(names.size(), vbb.named_parameters().size());
  // Decoder dilations reversed: the first decoder block has the largest dilation.
  EXPECT_EQ(vbb.named_parameters().size(), names.size());
}

// Without residual blocks (depth 0: convolutions, strides, replicate padding, upsampling only) the encoder and the
// decoder are strictly causal: program frame j sees input frames < (j+1)·c only; output frame t sees program frames
// <= t / c only. With residual blocks (next test) GroupNorm's statistics pool over the whole time axis, exactly as
// torch's nn.GroupNorm in the anchor, so every output depends slightly on every frame.
TEST(Vbb, ConvolutionPathIsCausal) {
  for (int64_t c : {1, 4, 8, 16}) {
    SCOPED_TRACE("compression " + std::to_string(c));
    Generator g(3);
    VbbConfig cfg = VbbConfig::with_compression(c, 16);
    cfg.width = 64;
    cfg.depth = 0;
    Vbb vbb(cfg, g);
    vbb.eval();
    ag::NoGradGuard ng;
    const int64_t Tz = 64;
    Tensor z = randn({1, Tz, 16}, 4);
    VbbPosterior a = vbb.encode(ag::Variable(z), g);
    for (int64_t t0 : {8, 21, 40, 63}) {
      Tensor z2 = z.clone();
      z2.slice(1, t0, Tz).copy_(randn({1, Tz - t0, 16}, 5 + t0));
      VbbPosterior b = vbb.encode(ag::Variable(z2), g);
      for (int64_t j = 0; j < Tz / c; ++j) {
        const double d = max_abs_diff(a.mu.data().slice(2, j, j + 1), b.mu.data().slice(2, j, j + 1)) +
                         max_abs_diff(a.logvar.data().slice(2, j, j + 1), b.logvar.data().slice(2, j, j + 1));
        if ((j + 1) * c <= t0) {
          EXPECT_EQ(d, 0.0) << "program frame " << j << " saw input frame " << t0;
        } else if (j == t0 / c) {
          EXPECT_GT(d, 0.0) << "program frame " << j << " ignores input frame " << t0;
        }
      }
    }
    const int64_t Tm = Tz / c;
    Tensor m = randn({1, 48, Tm}, 7);
    Tensor za = vbb.decode(ag::Variable(m), g).data();
    EXPECT_EQ(za.shape(), (Shape{1, Tz, 16}));
    for (int64_t j0 : {1, 3, 7}) {
      if (j0 >= Tm) continue;
      Tensor m2 = m.clone();
      m2.slice(2, j0, j0 + 1).copy_(randn({1, 48, 1}, 8 + j0));
      Tensor zb = vbb.decode(ag::Variable(m2), g).data();
      for (int64_t t = 0; t < Tz; ++t) {
        const double d = max_abs_diff(za.slice(1, t, t + 1), zb.slice(1, t, t + 1));
        if (t < j0 * c) {
          EXPECT_EQ(d, 0.0) << "frame " << t << " saw program frame " << j0;
        } else if (t == j0 * c) {
          EXPECT_GT(d, 0.0);
        }
      }
    }
  }
}

// The paper/anchor block (GroupNorm over (C/G, T)) leaks future frames into earlier outputs through the norm
// statistics only: the leak is smaller than the effect on the outputs that see the changed frames directly.
TEST(Vbb, GroupNormStatisticsAreTheOnlyNonCausalPath) {
  Generator g(3);
  VbbConfig cfg = VbbConfig::with_compression(8, 16);
  cfg.width = 64;
  Vbb vbb(cfg, g);
  vbb.eval();
  ag::NoGradGuard ng;
  const int64_t Tz = 64, t0 = 56;
  Tensor z = randn({1, Tz, 16}, 4);
  Tensor z2 = z.clone();
  z2.slice(1, t0, Tz).copy_(randn({1, Tz - t0, 16}, 5));
  Tensor a = vbb.encode(ag::Variable(z), g).mu.data(), b = vbb.encode(ag::Variable(z2), g).mu.data();
  const double early = max_abs_diff(a.slice(2, 0, 7), b.slice(2, 0, 7));
  const double direct = max_abs_diff(a.slice(2, 7, 8), b.slice(2, 7, 8));
  EXPECT_GT(early, 0.0);
  EXPECT_LT(early, direct);
}

TEST(Vbb, DropoutOnlyInTrainModeAndEpsZeroDecodesTheMean) {
  Generator g(9);
  Vbb vbb(tiny(1), g);
  Tensor z = randn({2, 8, 3}, 10);
  ag::NoGradGuard ng;
  vbb.eval();
  Generator g1(5), g2(77);
  Tensor zero = Tensor::zeros({2, 2, 4});
  VbbOutput a = vbb.forward(ag::Variable(z), zero, g1), b = vbb.forward(ag::Variable(z), zero, g2);
  EXPECT_EQ(max_abs_diff(a.z_hat.data(), b.z_hat.data()), 0.0);
  EXPECT_EQ(max_abs_diff(a.m.data(), a.mu.data()), 0.0);
  EXPECT_EQ(max_abs_diff(vbb.decode(a.mu, g1).data(), a.z_hat.data()), 0.0);
  vbb.train();
  VbbOutput c = vbb.forward(ag::Variable(z), zero, g1), d = vbb.forward(ag::Variable(z), zero, g2);
  EXPECT_GT(max_abs_diff(c.z_hat.data(), d.z_hat.data()), 0.0);
  // Sampled forward: m - mu = eps * exp(logvar / 2) with eps ~ N(0, 1) from the generator.
  vbb.eval();
  VbbOutput e = vbb.forward(ag::Variable(z), g1);
  EXPECT_GT(max_abs_diff(e.m.data(), e.mu.data()), 0.0);
}

// Every parameter and the input against central differences (float64, tiny config, 2 levels, eval mode).
TEST(Vbb, GradcheckEveryParameterFloat64) {
  Generator g(11);
  Vbb vbb(tiny(2), g);
  vbb.eval();
  vbb.to(DType::f64);
  std::vector<ag::Variable> params = vbb.parameters();
  std::vector<Tensor> inputs{randn({2, 8, 3}, 12, DType::f64)};
  for (auto& p : params) {
    p.data().copy_(t2m::mul(randn(p.shape(), 100 + inputs.size(), DType::f64), 0.5));
    inputs.push_back(p.data().clone());
  }
  const Tensor eps = randn({2, 2, 2}, 13, DType::f64);
  ag::GradcheckResult r = ag::gradcheck(
      [&](const std::vector<ag::Variable>& v) {
        for (size_t i = 0; i < params.size(); ++i) {
          ag::Variable alias = ag::mul(v[i + 1], 1.0);
          params[i].impl()->data = alias.data();
          params[i].impl()->grad_fn = alias.grad_fn();
        }
        VbbOutput o = vbb.forward(v[0], eps, g);
        // All three outputs reach the checked scalar (mean and log-variance through their own weights too).
        return ag::add(ag::add(ag::sum(ag::mul(o.z_hat, o.z_hat)), ag::sum(o.mu)), ag::sum(ag::exp(o.logvar)));
      },
      inputs);
  for (auto& p : params) p.impl()->grad_fn = nullptr;
  EXPECT_TRUE(r.ok) << r.message;
}

// A tiny VBB memorises 4 smooth sequences: the anchor's loss (MSE + 1e-4 KL) falls by 8x in 200 steps.
TEST(Vbb, OverfitsATinyBatch) {
  Generator g(14);
  VbbConfig cfg;
  cfg.in_dim = 6;
  cfg.width = 16;
  cfg.latent = 4;
  cfg.levels = 2;
  cfg.depth = 1;
  cfg.groups = 4;
  cfg.dropout = 0.0;
  Vbb vbb(cfg, g);
  const int64_t B = 4, Tz = 16;
  Tensor z = Tensor::empty({B, Tz, 6});
  for (int64_t b = 0; b < B; ++b)
    for (int64_t t = 0; t < Tz; ++t)
      for (int64_t d = 0; d < 6; ++d)
        z.slice(0, b, b + 1).slice(1, t, t + 1).slice(2, d, d + 1).fill_(std::sin(0.3 * t * (1 + d % 3) + b + d));
  nn::AdamWOptions ao;
  ao.lr = 5e-3;
  ao.weight_decay = 0.0;
  nn::AdamW opt(vbb.named_parameters(), ao);
  double first = 0, last = 0;
  for (int step = 0; step < 200; ++step) {
    opt.zero_grad();
    VbbOutput o = vbb.forward(ag::Variable(z), g);
    ag::Variable loss = ag::add(nn::mse_loss(o.z_hat, ag::Variable(z)), ag::mul(vbb_prior_kl(o.mu, o.logvar), 1e-4));
    loss.backward();
    opt.step();
    if (step == 0) first = loss.item();
    last = loss.item();
  }
  EXPECT_LT(last, first / 8) << "first " << first << " last " << last;
}

TEST(Vbb, BadConfigsAndInputs) {
  Generator g(1);
  VbbConfig c = tiny();
  c.groups = 3;
  expect_error([&] { Vbb v(c, g); }, {"vbb:", "width 4", "groups 3"});
  c = tiny();
  c.levels = -1;
  expect_error([&] { Vbb v(c, g); }, {"vbb:", "levels", "0..6"});
  c.levels = 7;
  expect_error([&] { Vbb v(c, g); }, {"vbb:", "levels", "0..6"});
  c = tiny();
  c.dropout = 1.0;
  expect_error([&] { Vbb v(c, g); }, {"vbb:", "dropout"});
  c = tiny();
  c.latent = 0;
  expect_error([&] { Vbb v(c, g); }, {"vbb:", "latent"});
  expect_error([&] { VbbConfig::with_compression(6); }, {"vbb:", "1, 4, 8 or 16", "6"});
  expect_error([&] { VbbConfig::with_compression(2); }, {"vbb:", "1, 4, 8 or 16", "2"});
  Vbb v(tiny(2), g);
  expect_error([&] { v.encode(ag::Variable(randn({2, 8, 5}, 1)), g); }, {"vbb:", "z must be", "[2, 8, 5]"});
  expect_error([&] { v.encode(ag::Variable(randn({8, 3}, 1)), g); }, {"vbb:", "z must be"});
  expect_error([&] { v.encode(ag::Variable(randn({2, 6, 3}, 1)), g); }, {"vbb:", "Tz = 6", "compression 4"});
  expect_error([&] { v.decode(ag::Variable(randn({2, 3, 2}, 1)), g); }, {"vbb:", "m must be"});
  expect_error([&] { v.forward(ag::Variable(randn({2, 8, 3}, 1)), Tensor::zeros({2, 2, 3}), g); },
               {"vbb:", "eps", "[2, 2, 2]"});
}
