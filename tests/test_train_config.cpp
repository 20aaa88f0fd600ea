// test_train_config.cpp — the shared trainer config (nn/train_config.h): the run-identity JSON keys, every rule of
// validate_common with its message, and that a derived trainer config keeps its own defaults and extra checks.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>

#include "models/casim/vq_train.h"
#include "models/promotion/go_diffuser_train.h"
#include "nn/train_config.h"

namespace {

using t2m::Error;
using t2m::nn::TrainLoopConfig;

void expect_bad(const std::function<void(TrainLoopConfig&)>& change, int64_t min_batch = 1) {
  TrainLoopConfig c;
  change(c);
  try {
    c.validate_common("test train", c.common_json(), min_batch);
    FAIL() << "no error for " << c.common_json().dump();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("test train: bad config"), std::string::npos) << e.what();
  }
}

TEST(TrainConfig, CommonJsonHasTheRunIdentityOnly) {
  TrainLoopConfig c;
  c.save_every = 7, c.stop_at = 3;
  const auto j = c.common_json();
  for (const char* k : {"steps", "batch", "lr", "weight_decay", "warmup", "seed"}) EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_FALSE(j.contains("save_every"));  // a later chunk may change these and still resume
  EXPECT_FALSE(j.contains("stop_at"));
  EXPECT_EQ(j.size(), 6u);
}

TEST(TrainConfig, ValidateRejectsEachBadField) {
  EXPECT_NO_THROW(TrainLoopConfig().validate_common("t", {}));
  expect_bad([](TrainLoopConfig& c) { c.steps = 0; });
  expect_bad([](TrainLoopConfig& c) { c.batch = 0; });
  expect_bad([](TrainLoopConfig& c) { c.batch = 1; }, 2);
  expect_bad([](TrainLoopConfig& c) { c.lr = 0; });
  expect_bad([](TrainLoopConfig& c) { c.lr = std::nan(""); });
  expect_bad([](TrainLoopConfig& c) { c.weight_decay = -1e-3; });
  expect_bad([](TrainLoopConfig& c) { c.warmup = -1; });
  expect_bad([](TrainLoopConfig& c) { c.warmup = c.steps; });
  expect_bad([](TrainLoopConfig& c) { c.save_every = 0; });
  expect_bad([](TrainLoopConfig& c) { c.stop_at = -1; });
}

TEST(TrainConfig, SharedRecipe) {
  TrainLoopConfig c;
  c.steps = 100, c.warmup = 10, c.lr = 1e-3, c.weight_decay = 0.05;
  const auto o = c.adamw();
  EXPECT_EQ(o.lr, 1e-3);
  EXPECT_EQ(o.weight_decay, 0.05);
  ASSERT_TRUE((bool)o.no_decay);
  const auto s = c.lr_schedule();
  EXPECT_NEAR(s.at(0), 1e-3 / 10, 1e-12);    // warm-up: lr (step + 1) / warmup
  EXPECT_NEAR(s.at(10), 1e-3, 1e-12);        // cosine starts at lr
  EXPECT_NEAR(s.at(100), 1e-4, 1e-12);       // and ends at lr / 10
  EXPECT_EQ(c.end_step(), 100);
  c.stop_at = 40;
  EXPECT_EQ(c.end_step(), 40);
  c.stop_at = 400;
  EXPECT_EQ(c.end_step(), 100);
}

TEST(TrainConfig, DerivedConfigsKeepTheirDefaultsAndChecks) {
  const t2m::promotion::GoTrainConfig go;
  EXPECT_EQ(go.steps, 1400);
  EXPECT_EQ(go.batch, 16);
  EXPECT_EQ(go.warmup, 50);
  EXPECT_EQ(go.to_json(), go.common_json());
  t2m::casim::VqTrainConfig vq;
  EXPECT_EQ(vq.weight_decay, 0.0);
  EXPECT_EQ(vq.to_json()["window"], 64);
  EXPECT_NO_THROW(vq.validate());
  vq.window = 6;  // not a multiple of 4: the derived check
  EXPECT_THROW(vq.validate(), Error);
}

}  // namespace
