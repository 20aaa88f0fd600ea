// test_loader.cpp — batches: shapes, masks and padding, window contents, mirroring, captions, epochs, determinism.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <string>
#include <vector>

#include "models/data/captions.h"
#include "models/data/features.h"
#include "models/data/features_mirror.h"
#include "models/data/loader.h"
#include "test_features_synthetic.h"

using namespace t2m::data;
using t2m::testing::synthetic_walk;

namespace {

std::vector<MotionClip> make_clips(int n) {
  static const char* contents[] = {"walk", "wave-left-hand", "run", "raise-up-right-hand", "bow"};
  static const char* styles[] = {"normal", "elderly", "exhausted", "happy", "chimpira"};
  const int lengths[] = {30, 64, 100, 200, 10, 65, 80};
  std::vector<MotionClip> clips;
  for (int i = 0; i < n; ++i) {
    auto m = synthetic_walk(lengths[i % 7], 0.4 * i, i, -i, 0.1 * (i % 3), 1.0 + 0.1 * i);
    clips.push_back(make_motion_clip("clip" + std::to_string(i), contents[i % 5], styles[i % 5], m));
  }
  return clips;
}

struct Item {
  int clip, start, length;
  bool mirrored;
  std::string caption;
  bool operator==(const Item& o) const {
    return clip == o.clip && start == o.start && length == o.length && mirrored == o.mirrored && caption == o.caption;
  }
};

std::vector<Item> epoch_items(MotionLoader& L, int64_t e) {
  L.start_epoch(e);
  std::vector<Item> out;
  Batch b;
  while (L.next(b))
    for (int i = 0; i < b.size(); ++i) out.push_back({b.clip[i], b.start[i], b.length[i], (bool)b.mirrored[i], b.captions[i]});
  return out;
}

}  // namespace

TEST(Loader, ShapesMasksAndWindowContents) {
  auto clips = make_clips(7);
  auto stats = clip_feature_stats(clips);
  LoaderConfig cfg;
  cfg.batch_size = 3;
  cfg.window = 64;
  cfg.seed = 11;
  MotionLoader L(&clips, stats, cfg);
  EXPECT_EQ(L.batches_per_epoch(), 3);
  Batch b;
  std::vector<int> seen;
  int batches = 0, mirrored = 0;
  while (L.next(b)) {
    ++batches;
    const int B = b.size();
    EXPECT_EQ(B, batches < 3 ? 3 : 1);
    ASSERT_EQ(b.x.shape(), (t2m::Shape{B, 64, kFeatureDim}));
    ASSERT_EQ(b.mask.shape(), (t2m::Shape{B, 64}));
    EXPECT_EQ(b.x.dtype(), t2m::DType::f32);
    const float* X = b.x.data<float>();
    const float* M = b.mask.data<float>();
    for (int i = 0; i < B; ++i) {
      const MotionClip& c = clips[b.clip[i]];
      seen.push_back(b.clip[i]);
      EXPECT_EQ(b.length[i], std::min(c.frames, 64));
      EXPECT_GE(b.start[i], 0);
      EXPECT_LE(b.start[i] + b.length[i], c.frames);
      mirrored += b.mirrored[i];
      // Reference window: raw features (mirrored when flagged), normalised by hand.
      std::vector<float> src = b.mirrored[i] ? mirror_features(c.features) : c.features;
      for (int t = 0; t < 64; ++t) {
        EXPECT_EQ(M[i * 64 + t], t < b.length[i] ? 1.0f : 0.0f);
        for (int d = 0; d < kFeatureDim; d += 7) {
          float got = X[((size_t)i * 64 + t) * kFeatureDim + d];
          if (t >= b.length[i]) {
            ASSERT_EQ(got, 0.0f);
          } else {
            float want = (src[(size_t)(b.start[i] + t) * kFeatureDim + d] - stats.mean[d]) / stats.std[d];
            ASSERT_NEAR(got, want, 1e-5) << "item " << i << " t " << t << " d " << d;
          }
        }
      }
      // Caption: a caption of the clip's labels, sides swapped when mirrored.
      EXPECT_FALSE(b.captions[i].empty());
      if (c.content == "wave-left-hand") {
        EXPECT_NE(b.captions[i].find(b.mirrored[i] ? "right" : "left"), std::string::npos) << b.captions[i];
      }
    }
  }
  EXPECT_EQ(batches, 3);
  std::sort(seen.begin(), seen.end());
  EXPECT_EQ(seen, (std::vector<int>{0, 1, 2, 3, 4, 5, 6}));  // every clip exactly once per epoch
  EXPECT_FALSE(L.next(b));
}

TEST(Loader, DeterministicPerSeedAndIndependentOfBatchSize) {
  auto clips = make_clips(40);
  auto stats = clip_feature_stats(clips);
  LoaderConfig cfg;
  cfg.seed = 5;
  cfg.batch_size = 4;
  MotionLoader a(&clips, stats, cfg), b(&clips, stats, cfg);
  auto ea = epoch_items(a, 0), eb = epoch_items(b, 0);
  EXPECT_EQ(ea, eb);
  cfg.batch_size = 7;
  MotionLoader c(&clips, stats, cfg);
  EXPECT_EQ(epoch_items(c, 0), ea);  // per-item draws depend on (seed, epoch, position) only
  // Same tensors bit for bit.
  a.start_epoch(3);
  b.start_epoch(3);
  Batch x, y;
  ASSERT_TRUE(a.next(x));
  ASSERT_TRUE(b.next(y));
  EXPECT_EQ(x.x.to_vector<float>(), y.x.to_vector<float>());
  EXPECT_EQ(x.mask.to_vector<float>(), y.mask.to_vector<float>());
  // Another epoch or another seed gives another order.
  EXPECT_NE(epoch_items(a, 1), ea);
  cfg.seed = 6;
  MotionLoader d(&clips, stats, cfg);
  EXPECT_NE(epoch_items(d, 0), ea);
  // Restarting an epoch replays it.
  EXPECT_EQ(epoch_items(a, 0), ea);
}

TEST(Loader, ShuffleIsAPermutationAndRoughlyUniform) {
  // Position of element 0 over 2000 shuffles of 10: each slot within 30% of 200.
  int slots[10] = {0};
  for (uint64_t s = 0; s < 2000; ++s) {
    auto p = shuffled_indices(10, s, 0);
    std::vector<int> q = p;
    std::sort(q.begin(), q.end());
    for (int i = 0; i < 10; ++i) ASSERT_EQ(q[i], i);
    slots[std::find(p.begin(), p.end(), 0) - p.begin()]++;
  }
  for (int c : slots) EXPECT_NEAR(c, 200, 60);
  EXPECT_TRUE(shuffled_indices(0, 1, 1).empty());
}

TEST(Loader, MirrorProbabilityAndParaphrases) {
  auto clips = make_clips(20);
  auto stats = clip_feature_stats(clips);
  LoaderConfig cfg;
  cfg.batch_size = 8;
  cfg.mirror_prob = 0.0;
  MotionLoader none(&clips, stats, cfg);
  for (auto& it : epoch_items(none, 0)) EXPECT_FALSE(it.mirrored);
  cfg.mirror_prob = 1.0;
  MotionLoader all(&clips, stats, cfg);
  for (auto& it : epoch_items(all, 0)) EXPECT_TRUE(it.mirrored);
  cfg.mirror_prob = 0.5;
  cfg.paraphrases = 3;
  cfg.seed = 9;
  MotionLoader half(&clips, stats, cfg);
  int m = 0, n = 0;
  for (int e = 0; e < 20; ++e)
    for (auto& it : epoch_items(half, e)) {
      m += it.mirrored;
      ++n;
      // With paraphrases = 3 the caption is one of the clip's first 3 (indices 0..2).
      const MotionClip& c = clips[it.clip];
      bool found = false;
      for (uint64_t k = 0; k < 3; ++k) found |= make_caption(c.content, c.style, 9, k, it.mirrored).text == it.caption;
      EXPECT_TRUE(found) << it.caption;
    }
  EXPECT_NEAR(m / double(n), 0.5, 0.08);
}

TEST(Loader, FixedCaptionsAndDropLast) {
  auto clips = make_clips(5);
  clips[1].caption = "a person waves the left hand, then someone bows";
  auto stats = clip_feature_stats(clips);
  LoaderConfig cfg;
  cfg.batch_size = 2;
  cfg.drop_last = true;
  cfg.mirror_prob = 1.0;
  MotionLoader L(&clips, stats, cfg);
  EXPECT_EQ(L.batches_per_epoch(), 2);
  auto items = epoch_items(L, 0);
  EXPECT_EQ(items.size(), 4u);
  for (auto& it : items)
    if (it.clip == 1) {
      EXPECT_EQ(it.caption, "a person waves the right hand, then someone bows");
    }
}

TEST(Loader, StatsWithMirrorsAreSymmetric) {
  auto clips = make_clips(6);
  auto s = clip_feature_stats(clips, true);
  // Mirror-symmetric statistics: the mean yaw velocity and lateral velocity are 0, left/right joints share std.
  EXPECT_NEAR(s.mean[kFeatRootYawVel], 0.0, 1e-6);
  EXPECT_NEAR(s.mean[kFeatRootVel + 1], 0.0, 1e-6);
  const int hl = kFeatJointVel + 3 * t2m::sim::kHandL, hr = kFeatJointVel + 3 * t2m::sim::kHandR;
  EXPECT_NEAR(s.std[hl], s.std[hr], 1e-5);
  auto u = clip_feature_stats(clips, false);
  EXPECT_GT(std::fabs(u.mean[kFeatRootYawVel]), 1e-4);  // the synthetic walks turn left on average
}

TEST(Loader, BadInputThrows) {
  auto clips = make_clips(3);
  auto stats = clip_feature_stats(clips);
  LoaderConfig cfg;
  std::vector<MotionClip> empty;
  EXPECT_THROW(MotionLoader(&empty, stats, cfg), t2m::Error);
  EXPECT_THROW(MotionLoader(nullptr, stats, cfg), t2m::Error);
  auto c2 = cfg;
  c2.batch_size = 0;
  EXPECT_THROW(MotionLoader(&clips, stats, c2), t2m::Error);
  c2 = cfg;
  c2.window = 0;
  EXPECT_THROW(MotionLoader(&clips, stats, c2), t2m::Error);
  c2 = cfg;
  c2.mirror_prob = 1.5;
  EXPECT_THROW(MotionLoader(&clips, stats, c2), t2m::Error);
  FeatureStats small{{0.f, 0.f}, {1.f, 1.f}};
  EXPECT_THROW(MotionLoader(&clips, small, cfg), t2m::Error);
  auto bad = clips;
  bad[1].features.pop_back();
  EXPECT_THROW(MotionLoader(&bad, stats, cfg), t2m::Error);
  bad = clips;
  bad[2].content = "moonwalk";
  EXPECT_THROW(MotionLoader(&bad, stats, cfg), t2m::Error);
}

TEST(Loader, LoadSplitClipsFromAManifest) {
  // A hand-made manifest whose clips all point at the committed 60-frame Bandai fixture.
  Manifest man;
  const std::string bvh = std::string(T2M_SOURCE_DIR) + "/tests/fixtures/bvh/bandai_walk_60.bvh";
  for (int t = 1; t <= 12; ++t) {
    ClipInfo c;
    c.name = "dataset-2_walk_normal_0" + std::string(t < 10 ? "0" : "") + std::to_string(t);
    c.dataset = 2;
    c.content_label = "walk";
    c.style_label = "normal";
    c.take = t;
    c.frames = 60;
    c.bvh_path = bvh;
    man.clips.push_back(c);
  }
  std::vector<std::string> names;
  for (auto& c : man.clips) names.push_back(c.name);
  auto splits = assign_splits(names);
  auto train = load_split_clips(man, splits, Split::train, 2);
  EXPECT_EQ(train.size(), clips_in(splits, Split::train).size());
  ASSERT_FALSE(train.empty());
  EXPECT_EQ(train[0].frames, 60);
  EXPECT_EQ(train[0].features.size(), 60u * kFeatureDim);
  EXPECT_EQ(train[0].content, "walk");
  man.clips[0].bvh_path = "/nonexistent.bvh";
  splits[man.clips[0].name] = Split::train;
  EXPECT_THROW(load_split_clips(man, splits, Split::train, 2), t2m::Error);
}
