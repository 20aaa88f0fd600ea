// test_gradcheck.cpp — the gradient checker itself: it passes correct gradients, catches wrong ones (and names
// the offending input and element), honours its tolerances, and rejects bad use.
#include <gtest/gtest.h>

#include <cmath>

#include "autograd/autograd.h"
#include "tensor/ops.h"

namespace {

using namespace t2m;
using ag::Variable;
using VV = std::vector<Variable>;

Tensor vec(std::vector<double> v) { return Tensor::from_vector(v, {(int64_t)v.size()}); }

// sin with a deliberately wrong backward: scale * cos(a), and element `bad` (if >= 0) gets 0.
Variable sin_with_backward(const Variable& a, double scale, int64_t bad) {
  Tensor ta = a.data();
  return ag::record("bad_sin", t2m::sin(ta), {a}, [ta, scale, bad](const Tensor& g, const std::vector<bool>&) {
    Tensor d = t2m::mul(t2m::mul(g, t2m::cos(ta)), scale).contiguous();
    if (bad >= 0) d.set({bad}, 0.0);
    return std::vector<Tensor>{d};
  });
}

TEST(Gradcheck, PassesACorrectGradient) {
  auto f = [](const VV& v) { return ag::sum(v[0] * ag::sin(v[1]), {0}); };
  Tensor x = Tensor::from_vector(std::vector<double>{0.1, -0.4, 0.9, 1.3, -1.1, 0.5}, {2, 3});
  Tensor y = Tensor::from_vector(std::vector<double>{0.7, 0.2, -0.3, 0.8, 1.9, -2.0}, {2, 3});
  ag::GradcheckResult r = ag::gradcheck(f, {x, y});
  EXPECT_TRUE(r.ok) << r.message;
  EXPECT_LT(r.max_abs_err, 1e-8) << r.message;
  EXPECT_NE(r.message.find("ok"), std::string::npos);
  // The caller's tensors are not modified (the checker works on float64 copies).
  EXPECT_EQ(x.at({0, 0}), 0.1);
}

TEST(Gradcheck, CatchesAScaledGradient) {
  auto f = [](const VV& v) { return sin_with_backward(v[0], 1.01, -1); };
  ag::GradcheckResult r = ag::gradcheck(f, {vec({0.3, 0.1, -0.5})});
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("FAILED"), std::string::npos) << r.message;
  EXPECT_NEAR(r.max_rel_err, 0.01, 1e-4);  // 1% wrong everywhere
  EXPECT_EQ(r.input, 0);
}

TEST(Gradcheck, NamesTheOffendingElement) {
  auto f = [](const VV& v) { return v[1] * sin_with_backward(v[0], 1.0, 3); };
  ag::GradcheckResult r = ag::gradcheck(f, {vec({0.3, 0.1, -0.5, 0.8, 1.2}), vec({1.5, 1.5, 1.5, 1.5, 1.5})});
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.input, 0);
  EXPECT_EQ(r.element, 3);
  EXPECT_EQ(r.analytic, 0.0);
  EXPECT_NE(r.numeric, 0.0);
}

TEST(Gradcheck, ToleranceIsAParameter) {
  auto f = [](const VV& v) { return sin_with_backward(v[0], 1.01, -1); };
  ag::GradcheckOptions loose;
  loose.rtol = 0.05;
  EXPECT_TRUE(ag::gradcheck(f, {vec({0.3, 0.1, -0.5})}, loose).ok);
}

TEST(Gradcheck, MissingGradientIsAnError) {
  // A function that ignores one input has zero gradient there; one that depends on it but records no node fails.
  auto ignores = [](const VV& v) { return v[0] * 2.0; };
  EXPECT_TRUE(ag::gradcheck(ignores, {vec({1, 2}), vec({3})}).ok);
  auto detached = [](const VV& v) { return v[0] * v[1].detach(); };
  ag::GradcheckResult r = ag::gradcheck(detached, {vec({1, 2}), vec({3, 4})});
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.input, 1);
}

TEST(Gradcheck, RejectsBadUse) {
  auto f = [](const VV& v) { return v[0]; };
  EXPECT_THROW(ag::gradcheck(f, {}), Error);
  EXPECT_THROW(ag::gradcheck(f, {Tensor::zeros({2}, DType::i64)}), Error);
  auto to_f32 = [](const VV& v) { return Variable(v[0].data().to(DType::f32)); };
  EXPECT_THROW(ag::gradcheck(to_f32, {vec({1.0})}), Error);
}

}  // namespace
