// test_train_step.cpp — nn/train_step.h: the shared step (loss, norm, clipped update against hand computation,
// the non-finite guard naming the parameter) and the end-of-run loss plot (written, or skipped without error).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "autograd/autograd.h"
#include "nn/optim_adamw.h"
#include "nn/optim_sgd.h"
#include "nn/train_step.h"

namespace fs = std::filesystem;
using namespace t2m;
using nn::NamedParams;

namespace {

// loss = sum(w * c) with w = [1, 2], c = [3, 4]: value 11, dloss/dw = c, grad norm 5.
struct Tiny {
  NamedParams params{{"w", ag::Variable::parameter(Tensor::from_vector(std::vector<double>{1.0, 2.0}, {2}))}};
  ag::Variable loss() const {
    const ag::Variable c(Tensor::from_vector(std::vector<double>{3.0, 4.0}, {2}));
    return ag::sum(ag::mul(params[0].second, c));
  }
  std::vector<double> w() const { return params[0].second.data().to_vector<double>(); }
};

fs::path temp_dir(const std::string& tag) {
  fs::path d = fs::temp_directory_path() / ("t2m_train_step_test_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

}  // namespace

TEST(TrainStep, SgdClippedUpdateMatchesHand) {
  Tiny t;
  nn::SGDOptions so;
  so.lr = 0.1;
  nn::SGD opt(t.params, so);
  const nn::StepStats s = nn::backward_clip_step(t.loss(), t.params, opt);  // max_norm 1
  EXPECT_DOUBLE_EQ(s.loss, 11.0);
  EXPECT_DOUBLE_EQ(s.grad_norm, 5.0);  // before clipping
  const double k = 1.0 / (5.0 + 1e-6);  // clip factor
  const std::vector<double> w = t.w();
  EXPECT_NEAR(w[0], 1.0 - 0.1 * 3.0 * k, 1e-12);
  EXPECT_NEAR(w[1], 2.0 - 0.1 * 4.0 * k, 1e-12);
  EXPECT_EQ(opt.step_count(), 1);
}

TEST(TrainStep, MaxNormAboveTheNormLeavesTheGradient) {
  Tiny t;
  nn::SGDOptions so;
  so.lr = 0.1;
  nn::SGD opt(t.params, so);
  const nn::StepStats s = nn::backward_clip_step(t.loss(), t.params, opt, 100.0);
  EXPECT_DOUBLE_EQ(s.grad_norm, 5.0);
  const std::vector<double> w = t.w();
  EXPECT_NEAR(w[0], 1.0 - 0.3, 1e-12);
  EXPECT_NEAR(w[1], 2.0 - 0.4, 1e-12);
}

TEST(TrainStep, AdamWFirstStepMatchesHand) {
  Tiny t;
  nn::AdamWOptions ao;
  ao.lr = 0.01;
  ao.weight_decay = 0.1;
  nn::AdamW opt(t.params, ao);
  const nn::StepStats s = nn::backward_clip_step(t.loss(), t.params, opt, 2.0);
  EXPECT_DOUBLE_EQ(s.loss, 11.0);
  EXPECT_DOUBLE_EQ(s.grad_norm, 5.0);
  // First AdamW step: m_hat = g, v_hat = g^2, so p <- p (1 - lr wd) - lr g / (|g| + eps), g clipped to norm 2.
  const double k = 2.0 / (5.0 + 1e-6);
  const double g[2] = {3.0 * k, 4.0 * k}, p0[2] = {1.0, 2.0};
  const std::vector<double> w = t.w();
  for (int i = 0; i < 2; ++i)
    EXPECT_NEAR(w[i], p0[i] * (1 - 0.01 * 0.1) - 0.01 * g[i] / (std::fabs(g[i]) + 1e-8), 1e-12) << i;
}

TEST(TrainStep, NonFiniteGradientNamesTheParameterAndSkipsTheStep) {
  NamedParams ps{{"ok", ag::Variable::parameter(Tensor::from_vector(std::vector<double>{1.0, 2.0}, {2}))},
                 {"bad", ag::Variable::parameter(Tensor::from_vector(std::vector<double>{0.0, 1.0}, {2}))}};
  nn::SGD opt(ps, nn::SGDOptions{});
  // d sqrt(x) / dx = 0.5 / sqrt(x): infinite at x = 0, while the loss itself (1 + 2 + 0 + 1) is finite.
  const ag::Variable loss = ag::add(ag::sum(ps[0].second), ag::sum(ag::sqrt(ps[1].second)));
  try {
    nn::backward_clip_step(loss, ps, opt);
    FAIL() << "expected t2m::Error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("check_finite_grads"), std::string::npos) << m;
    EXPECT_NE(m.find("'bad'"), std::string::npos) << m;
    EXPECT_EQ(m.find("'ok'"), std::string::npos) << m;
  }
  EXPECT_EQ(opt.step_count(), 0);
  EXPECT_EQ(ps[0].second.data().to_vector<double>(), (std::vector<double>{1.0, 2.0}));
}

TEST(TrainStep, LossPlotWrittenForALog) {
  const fs::path d = temp_dir("plot");
  const fs::path log = d / "log.jsonl", svg = d / "loss.svg";
  {
    std::ofstream f(log);
    f << R"({"step": 1, "loss": 2.0, "lr": 0.001, "grad_norm": 1.5})" << "\n"
      << R"({"step": 2, "loss": 1.0, "lr": 0.001, "grad_norm": 1.2})" << "\n"
      << R"({"step": 3, "loss": 0.5, "lr": 0.001, "grad_norm": 0.9})" << "\n";
  }
  nn::write_loss_plot_if_logged(log.string(), svg.string(), "tiny run: loss");
  ASSERT_TRUE(fs::exists(svg));
  const std::string s = slurp(svg);
  EXPECT_NE(s.find("<svg"), std::string::npos);
  EXPECT_NE(s.find("</svg>"), std::string::npos);
  EXPECT_NE(s.find("tiny run: loss"), std::string::npos);
  EXPECT_NE(s.find("<polyline"), std::string::npos);
  // Several keys on a linear axis.
  const fs::path svg2 = d / "keys.svg";
  nn::write_loss_plot_if_logged(log.string(), svg2.string(), "two keys", {"loss", "grad_norm"}, false);
  ASSERT_TRUE(fs::exists(svg2));
  const std::string s2 = slurp(svg2);
  EXPECT_NE(s2.find("grad_norm"), std::string::npos);
  fs::remove_all(d);
}

TEST(TrainStep, LossPlotSkippedWithoutLogOrPath) {
  const fs::path d = temp_dir("skip");
  const fs::path svg = d / "loss.svg";
  // A missing log: nothing written, no error.
  EXPECT_NO_THROW(nn::write_loss_plot_if_logged((d / "missing.jsonl").string(), svg.string(), "t"));
  EXPECT_FALSE(fs::exists(svg));
  // An empty log (nothing trained in this call): no error, no plot.
  const fs::path empty = d / "empty.jsonl";
  std::ofstream(empty).close();
  EXPECT_NO_THROW(nn::write_loss_plot_if_logged(empty.string(), svg.string(), "t"));
  EXPECT_FALSE(fs::exists(svg));
  // An empty svg path: nothing done even with a log.
  const fs::path log = d / "log.jsonl";
  std::ofstream(log) << R"({"step": 1, "loss": 2.0})" << "\n";
  EXPECT_NO_THROW(nn::write_loss_plot_if_logged(log.string(), "", "t"));
  EXPECT_EQ(std::distance(fs::directory_iterator(d), fs::directory_iterator()), 2);  // empty.jsonl, log.jsonl
  fs::remove_all(d);
}
