// test_text2bfm_compose.cpp — Text2BFM-Compose: clause splitting, Eq 19 blend weights, Eq 18-19 concatenation.
#include <gtest/gtest.h>

#include "models/text2bfm/compose.h"

using namespace t2m;
using text2bfm::compose_latents;
using text2bfm::overlap_blend_weights;
using text2bfm::split_clauses;

TEST(ComposeClauses, SplitsOnThenAfterThatAndCommas) {
  using V = std::vector<std::string>;
  EXPECT_EQ(split_clauses("A person walks forward, then waves with the right hand"),
            (V{"a person walks forward", "waves with the right hand"}));
  EXPECT_EQ(split_clauses("walk then run after that sit down"), (V{"walk", "run", "sit down"}));
  EXPECT_EQ(split_clauses("jump, kick; dance. bow"), (V{"jump", "kick", "dance", "bow"}));
  EXPECT_EQ(split_clauses("walks and then waves"), (V{"walks", "waves"}));
  EXPECT_EQ(split_clauses("walks, and waves"), (V{"walks", "waves"}));
  EXPECT_EQ(split_clauses("a person walks and waves"), (V{"a person walks and waves"}));  // no separator
  EXPECT_EQ(split_clauses("walk,, then ,"), (V{"walk"}));                                // empty clauses dropped
  EXPECT_EQ(split_clauses("after the walk, sit"), (V{"after the walk", "sit"}));         // "after" alone stays
  EXPECT_TRUE(split_clauses("").empty());
  EXPECT_TRUE(split_clauses(" , then ").empty());
}

TEST(ComposeBlend, Eq19Weights) {
  EXPECT_TRUE(overlap_blend_weights(0).empty());
  const auto r = overlap_blend_weights(3);
  ASSERT_EQ(r.size(), 3u);
  EXPECT_DOUBLE_EQ(r[0], 0.25);
  EXPECT_DOUBLE_EQ(r[1], 0.5);
  EXPECT_DOUBLE_EQ(r[2], 0.75);
  const auto r1 = overlap_blend_weights(1);
  EXPECT_DOUBLE_EQ(r1[0], 0.5);
  EXPECT_THROW(overlap_blend_weights(-1), Error);
}

namespace {
// (T, d) with entry (t, k) = base + t + 0.01 k.
Tensor seg(int64_t T, int64_t d, float base) {
  Tensor s = Tensor::empty({T, d});
  for (int64_t t = 0; t < T; ++t)
    for (int64_t k = 0; k < d; ++k) s.set({t, k}, base + t + 0.01 * k);
  return s;
}
}  // namespace

TEST(ComposeBlend, Eq18ConcatenationAndEq19Overlap) {
  const Tensor a = seg(5, 2, 0), b = seg(6, 2, 100), c = seg(4, 2, 200);
  // O = 0: plain concatenation (Eq 18).
  const Tensor p = compose_latents({a, b}, 0);
  ASSERT_EQ(p.shape(), (Shape{11, 2}));
  EXPECT_FLOAT_EQ(p.at({4, 1}), a.at({4, 1}));
  EXPECT_FLOAT_EQ(p.at({5, 0}), b.at({0, 0}));
  // O = 2 over three segments: 5 + 6 + 4 - 2 * 2 rows.
  const int64_t O = 2;
  const Tensor z = compose_latents({a, b, c}, O);
  ASSERT_EQ(z.shape(), (Shape{11, 2}));
  for (int64_t t = 0; t < 3; ++t) EXPECT_FLOAT_EQ(z.at({t, 1}), a.at({t, 1}));
  const auto rho = overlap_blend_weights(O);
  for (int64_t o = 1; o <= O; ++o)  // rows 3, 4: z~_o = (1 - rho_o) a_{T-O+o} + rho_o b_o (1-based)
    for (int64_t k = 0; k < 2; ++k)
      EXPECT_NEAR(z.at({3 + o - 1, k}), (1 - rho[o - 1]) * a.at({5 - O + o - 1, k}) + rho[o - 1] * b.at({o - 1, k}),
                  1e-4);
  EXPECT_FLOAT_EQ(z.at({5, 0}), b.at({2, 0}));  // b's middle rows 2..3 unchanged
  EXPECT_FLOAT_EQ(z.at({6, 0}), b.at({3, 0}));
  EXPECT_NEAR(z.at({7, 0}), (1 - rho[0]) * b.at({4, 0}) + rho[0] * c.at({0, 0}), 1e-4);
  EXPECT_NEAR(z.at({8, 0}), (1 - rho[1]) * b.at({5, 0}) + rho[1] * c.at({1, 0}), 1e-4);
  EXPECT_FLOAT_EQ(z.at({9, 0}), c.at({2, 0}));
  EXPECT_FLOAT_EQ(z.at({10, 1}), c.at({3, 1}));
  // A single segment is returned as is, whatever O.
  EXPECT_EQ(compose_latents({a}, 3).shape(), (Shape{5, 2}));
}

TEST(ComposeBlend, RefusesBadSegments) {
  EXPECT_THROW(compose_latents({}, 1), Error);
  EXPECT_THROW(compose_latents({seg(4, 2, 0), seg(4, 3, 0)}, 1), Error);   // widths differ
  EXPECT_THROW(compose_latents({seg(4, 2, 0), seg(3, 2, 0), seg(4, 2, 0)}, 2), Error);  // middle < 2 O
  EXPECT_THROW(compose_latents({seg(1, 2, 0), seg(4, 2, 0)}, 2), Error);   // end < O
  EXPECT_THROW(compose_latents({seg(4, 2, 0), seg(4, 2, 0)}, -1), Error);
  EXPECT_THROW(compose_latents({Tensor::zeros({4})}, 0), Error);
}
