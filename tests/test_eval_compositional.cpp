// test_eval_compositional.cpp — Table 2's metrics (models/eval/compositional.h) on hand-made embeddings and
// features, the Compose clause bounds and the prompt builder (models/text2bfm/compose_eval.h).
#include <gtest/gtest.h>

#include <cmath>

#include "models/data/features.h"
#include "models/eval/compositional.h"
#include "models/text/tokenizer.h"
#include "models/text2bfm/compose.h"
#include "models/text2bfm/compose_eval.h"

using namespace t2m;

namespace {

Tensor mat(const std::vector<std::vector<double>>& r) {
  std::vector<double> v;
  for (const auto& row : r) v.insert(v.end(), row.begin(), row.end());
  return Tensor::from_vector(v, {(int64_t)r.size(), (int64_t)r[0].size()});
}

}  // namespace

TEST(Compositional, OrderCorrectNeedsEverySegmentOnItsOwnClause) {
  const Tensor clause = mat({{1, 0, 0}, {0, 1, 0}, {0, 0, 1}});
  EXPECT_TRUE(eval::order_correct(mat({{0.9, 0.1, 0}, {0.2, 0.7, 0.1}, {0, 0.3, 0.8}}), clause));
  // Segments 1 and 2 swapped: assigned (0, 2, 1), not increasing.
  EXPECT_FALSE(eval::order_correct(mat({{0.9, 0.1, 0}, {0, 0.3, 0.8}, {0.2, 0.7, 0.1}}), clause));
  // Increasing but skips a clause (0, 2, 2 is not strictly increasing; 0, 1, 1 neither).
  EXPECT_FALSE(eval::order_correct(mat({{1, 0, 0}, {0, 0.4, 0.6}, {0, 0, 1}}), clause));
  // Cosine similarity: scale of the clause vector does not matter.
  EXPECT_TRUE(eval::order_correct(mat({{1, 0.2}, {0.1, 1}}), mat({{10, 0}, {0, 0.5}})));
  // Exact tie between clauses: the lower index wins, so segment 1 loses.
  EXPECT_FALSE(eval::order_correct(mat({{1, 0}, {1, 1}}), mat({{1, 0}, {0, 1}})));
  EXPECT_THROW(eval::order_correct(mat({{1, 0}}), clause), Error);
}

TEST(Compositional, SegmentMmDistIsTheMeanPairDistance) {
  const Tensor s = mat({{1, 0}, {0, 1}}), c = mat({{0, 0}, {3, 5}});
  EXPECT_NEAR(eval::segment_mm_dist(s, c), (1.0 + 5.0) / 2, 1e-12);
}

TEST(Compositional, TransitionScoreIsEq20) {
  constexpr int F = data::kFeatureDim;
  const int64_t T = 6;
  std::vector<float> f((size_t)T * F, 0.f);
  // Boundary at frame 2: pose jump of joint 0 by (0.3, 0.4, 0) m -> 0.5; velocity jump 0.1 m/frame -> 3 m/s.
  for (int64_t t = 2; t < T; ++t) f[t * F + data::kFeatLocalPos] = 0.3f, f[t * F + data::kFeatLocalPos + 1] = 0.4f;
  f[2 * F + data::kFeatJointVel + 5] = 0.1f;
  // Boundary at frame 4: nothing changes from frame 3 to 4 except a contact flag (not counted).
  f[4 * F + data::kFeatContact] = 1.f;
  const double want = ((0.5 + 3.0) + 0.0) / 2;
  EXPECT_NEAR(eval::transition_score(f, {0, 2, 4, 6}), want, 1e-6);
  EXPECT_EQ(eval::transition_score(f, {0, 6}), 0.0);  // N = 1: no boundary
  EXPECT_THROW(eval::transition_score(f, {0, 4, 4, 6}), Error);
  EXPECT_THROW(eval::transition_score(f, {0, 7}), Error);
  EXPECT_THROW(eval::transition_score(std::vector<float>(10, 0.f), {0, 1}), Error);
}

TEST(Compositional, UniformAndComposeBounds) {
  EXPECT_EQ(eval::segment_bounds_uniform(10, 3), (std::vector<int64_t>{0, 3, 6, 10}));
  EXPECT_THROW(eval::segment_bounds_uniform(2, 3), Error);
  // T = 180, N = 2, O = 4, c = 8: per = 92, T_n = 96; the blend of boundary 1 is latents [92, 96) -> bound 94.
  EXPECT_EQ(text2bfm::compose_bounds(180, 2, 4, 8), (std::vector<int64_t>{0, 94, 180}));
  // N = 3, T = 270: per = ceil(278 / 3) = 93, T_n = 96: blends at [92, 96) and [184, 188).
  EXPECT_EQ(text2bfm::compose_bounds(270, 3, 4, 8), (std::vector<int64_t>{0, 94, 186, 270}));
  // The bounds agree with compose_latents: mark each segment's rows with its index and blend.
  const int64_t T = 270, N = 3, O = 4, Tn = 96;
  std::vector<Tensor> segs;
  for (int64_t n = 0; n < N; ++n) segs.push_back(Tensor::full({Tn, 1}, double(n)));
  const Tensor z = text2bfm::compose_latents(segs, O);
  const auto b = text2bfm::compose_bounds(T, N, O, 8);
  for (int64_t n = 0; n < N; ++n) {
    EXPECT_EQ(z.at({b[n] + (n ? O / 2 : 0), 0}), float(n));  // just past a blend: pure segment n
    EXPECT_EQ(z.at({b[n + 1] - 1 - (n + 1 < N ? O / 2 : 0), 0}), float(n));
  }
  EXPECT_EQ(text2bfm::compose_bounds(5, 3, 4, 8).size(), 4u);  // clamped: every segment keeps >= 1 frame
}

TEST(Compositional, PromptsFromClipsSplitBackIntoTheirClauses) {
  std::vector<data::MotionClip> clips(4);
  const char* content[] = {"walk", "run", "bow", "walk"};
  for (int i = 0; i < 4; ++i) clips[i].name = std::string("c").append(std::to_string(i)), clips[i].content = content[i], clips[i].style = "normal";
  const auto p = text2bfm::make_compose_prompts(clips, 3, 5, 1);
  ASSERT_EQ(p.size(), 5u);
  for (const auto& x : p) {
    ASSERT_EQ(x.clauses.size(), 3u);
    std::vector<std::string> norm;
    for (const auto& c : x.clauses) norm.push_back(text::normalize(c));
    EXPECT_EQ(text2bfm::split_clauses(x.prompt), norm);
    EXPECT_NE(x.prompt.find(", then "), std::string::npos);
  }
  EXPECT_EQ(text2bfm::make_compose_prompts(clips, 3, 5, 1)[2].prompt, p[2].prompt);  // deterministic
  EXPECT_THROW(text2bfm::make_compose_prompts(clips, 4, 1, 1), Error);  // only 3 distinct labels
  EXPECT_THROW(text2bfm::make_compose_prompts(clips, 1, 1, 1), Error);
}
