// test_bfm_fused.cpp — models/bfm/layer_norm_tanh.h: the fast float tanh against std::tanh, the fused op against
// the composition ag::tanh(ag::layer_norm(...)) (values and all gradients, float32), float64 gradcheck of every
// input, errors.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "autograd/autograd.h"
#include "autograd/ops_norm.h"
#include "models/bfm/layer_norm_tanh.h"
#include "tensor/ops.h"
#include "test_tensor_util.h"

namespace {

using namespace t2m;
using ag::Variable;
using VV = std::vector<Variable>;
using t2m::testing::expect_error;
using t2m::testing::random_tensor;

TEST(BfmLayerNormTanh, FastTanhAccuracy) {
  double worst = 0;
  for (double u = -12; u <= 12; u += 1e-3) worst = std::max(worst, std::abs(bfm::fast_tanh((float)u) - std::tanh(u)));
  EXPECT_LT(worst, 3e-7);
  EXPECT_EQ(bfm::fast_tanh(0.f), 0.f);
  EXPECT_EQ(bfm::fast_tanh(100.f), 1.f);
  EXPECT_EQ(bfm::fast_tanh(-100.f), -1.f);
}

TEST(BfmLayerNormTanh, MatchesCompositionFloat32) {
  const Tensor x = random_tensor({37, 24}, DType::f32, 1, -3, 3);
  const Tensor w = random_tensor({24}, DType::f32, 2, 0.5, 1.5), b = random_tensor({24}, DType::f32, 3);
  const Tensor g = random_tensor({37, 24}, DType::f32, 4);
  Variable x1(x, true), w1(w, true), b1(b, true), x2(x.clone(), true), w2(w.clone(), true), b2(b.clone(), true);
  const Variable y1 = bfm::layer_norm_tanh(x1, w1, b1);
  const Variable y2 = ag::tanh(ag::layer_norm(x2, w2, b2));
  EXPECT_LT(t2m::max_abs_diff(y1.data(), y2.data()), 1e-6);
  y1.backward(g);
  y2.backward(g);
  EXPECT_LT(t2m::max_abs_diff(x1.grad(), x2.grad()), 2e-5);
  EXPECT_LT(t2m::max_abs_diff(w1.grad(), w2.grad()), 2e-5);
  EXPECT_LT(t2m::max_abs_diff(b1.grad(), b2.grad()), 2e-5);
  // without affine parameters
  EXPECT_LT(t2m::max_abs_diff(bfm::layer_norm_tanh(Variable(x), Variable(), Variable()).data(),
                              ag::tanh(ag::layer_norm(Variable(x), Variable(), Variable())).data()),
            1e-6);
}

TEST(BfmLayerNormTanh, GradcheckFloat64) {
  ag::GradcheckResult r = ag::gradcheck([](const VV& v) { return bfm::layer_norm_tanh(v[0], v[1], v[2]); },
                                        {random_tensor({3, 5}, DType::f64, 5), random_tensor({5}, DType::f64, 6),
                                         random_tensor({5}, DType::f64, 7)});
  EXPECT_TRUE(r.ok) << r.message;
  r = ag::gradcheck([](const VV& v) { return bfm::layer_norm_tanh(v[0], Variable(), Variable()); },
                    {random_tensor({2, 2, 4}, DType::f64, 8)});
  EXPECT_TRUE(r.ok) << r.message;
}

TEST(BfmLayerNormTanh, Errors) {
  expect_error([] { bfm::layer_norm_tanh(Variable(Tensor::zeros({2, 0})), Variable(), Variable()); },
               {"layer_norm_tanh", "[2, 0]"});
  expect_error([] { bfm::layer_norm_tanh(Variable(Tensor::zeros({2, 3})), Variable(Tensor::ones({4})), Variable()); },
               {"layer_norm_tanh", "[4]"});
}

}  // namespace
