// test_nn_layers.cpp — the basic nn modules: parameter names/shapes/init, values against naive loops, float64
// gradchecks through each module after Module::to(f64) (input and every parameter), train/eval behaviour and
// checkpoint round trips.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>

#include "autograd/gradcheck.h"
#include "autograd/ops_elementwise.h"
#include "autograd/ops_reduce.h"
#include "nn/checkpoint.h"
#include "nn/linear.h"
#include "nn/norm.h"
#include "tensor/ops.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

using namespace t2m;
using t2m::testing::expect_error;

namespace {

Tensor randn(const Shape& s, uint64_t seed, DType dt = DType::f64) {
  Generator g(seed);
  return rand_normal(s, g, 0.0, 1.0, dt);
}

using Fwd = std::function<ag::Variable(const ag::Variable&)>;

// Float64 gradcheck of fwd(x) with respect to x and every parameter of m. For the gradcheck, each parameter of
// the module is temporarily made a non-leaf alias (p = leaf * 1) of one of the gradcheck's leaves, so gradients
// through the module's own parameter handles reach the leaves the gradcheck inspects; restored afterwards.
void expect_module_gradcheck(nn::Module& m, const Fwd& fwd, const Tensor& x) {
  std::vector<ag::Variable> params = m.parameters();
  std::vector<Tensor> inputs{x};
  for (auto& p : params) {
    ASSERT_EQ(p.dtype(), DType::f64) << p.name();
    inputs.push_back(p.data().clone());
  }
  const std::vector<Tensor> saved(inputs.begin() + 1, inputs.end());
  ag::GradcheckResult r = ag::gradcheck(
      [&](const std::vector<ag::Variable>& v) {
        for (size_t i = 0; i < params.size(); ++i) {
          ag::Variable alias = ag::mul(v[i + 1], 1.0);
          params[i].impl()->data = alias.data();
          params[i].impl()->grad_fn = alias.grad_fn();
        }
        return fwd(v[0]);
      },
      inputs);
  for (size_t i = 0; i < params.size(); ++i) {
    params[i].impl()->grad_fn = nullptr;
    params[i].set_data(saved[i]);
    params[i].clear_grad();
  }
  EXPECT_TRUE(r.ok) << r.message;
}

// Save m's parameters, load them into fresh (differently initialised) `other`, compare every tensor.
void expect_roundtrip(const nn::Module& m, nn::Module& other, const std::string& file) {
  const std::string path = (std::filesystem::temp_directory_path() / file).string();
  nn::Checkpoint ck;
  m.save_to(ck, "mod.");
  ck.save(path);
  other.load_from(nn::Checkpoint::load(path), "mod.");
  auto a = m.named_parameters(), b = other.named_parameters();
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].first, b[i].first);
    EXPECT_EQ(max_abs_diff(a[i].second.data(), b[i].second.data()), 0.0) << a[i].first;
  }
  std::filesystem::remove(path);
}

std::vector<std::string> names(const nn::Module& m) {
  std::vector<std::string> out;
  for (auto& kv : m.named_parameters()) out.push_back(kv.first);
  return out;
}

}  // namespace

// ---- Linear ---------------------------------------------------------------------------------------------------

TEST(NnLinear, ParametersAndDefaultInit) {
  Generator g(7);
  nn::Linear lin(16, 5, true, g);
  EXPECT_EQ(names(lin), (std::vector<std::string>{"weight", "bias"}));
  EXPECT_EQ(lin.weight().shape(), (Shape{5, 16}));
  EXPECT_EQ(lin.bias().shape(), (Shape{5}));
  EXPECT_EQ(lin.weight().dtype(), DType::f32);
  // U(-1/sqrt(in), 1/sqrt(in)) = U(-0.25, 0.25), same seed -> same weights, weight drawn first.
  EXPECT_LE(amax(abs(lin.weight().data())).item(), 0.25);
  EXPECT_LE(amax(abs(lin.bias().data())).item(), 0.25);
  EXPECT_GT(amax(abs(lin.weight().data())).item(), 0.2);
  Generator g2(7);
  Tensor w_expected = rand_uniform({5, 16}, g2, -0.25, 0.25);
  EXPECT_EQ(max_abs_diff(lin.weight().data(), w_expected), 0.0);
  Generator g3(7);
  nn::Linear nob(16, 5, false, g3);
  EXPECT_EQ(names(nob), (std::vector<std::string>{"weight"}));
  EXPECT_FALSE(nob.bias().defined());
  EXPECT_EQ(nob.num_parameters(), 80);
}

TEST(NnLinear, MatchesNaiveOnLeadingDims) {
  Generator g(1);
  nn::Linear lin(6, 4, true, g);
  lin.to(DType::f64);
  const Tensor x = randn({2, 3, 6}, 2);
  Tensor y = lin(ag::Variable(x)).data();
  ASSERT_EQ(y.shape(), (Shape{2, 3, 4}));
  const Tensor& W = lin.weight().data();
  const Tensor& b = lin.bias().data();
  double worst = 0;
  for (int64_t i = 0; i < 2; ++i)
    for (int64_t t = 0; t < 3; ++t)
      for (int64_t o = 0; o < 4; ++o) {
        double acc = b.at({o});
        for (int64_t k = 0; k < 6; ++k) acc += x.at({i, t, k}) * W.at({o, k});
        worst = std::max(worst, std::fabs(acc - y.at({i, t, o})));
      }
  EXPECT_LT(worst, 1e-12);
  // float32 module on a strided (transposed) input agrees with the float64 result.
  Generator g2(1);
  nn::Linear lin32(6, 4, true, g2);
  const Tensor xt = x.to(DType::f32).transpose(0, 1);  // (3, 2, 6), not contiguous
  Tensor y32 = lin32(ag::Variable(xt)).data();
  EXPECT_LT(max_abs_diff(y32.to(DType::f64), y.transpose(0, 1)), 1e-5);
}

TEST(NnLinear, GradcheckFloat64WithAndWithoutBias) {
  for (bool bias : {true, false}) {
    Generator g(3);
    nn::Linear lin(4, 3, bias, g);
    lin.to(DType::f64);
    expect_module_gradcheck(lin, [&](const ag::Variable& x) { return lin(x); }, randn({2, 2, 4}, 4));
    expect_module_gradcheck(lin, [&](const ag::Variable& x) { return lin(x); }, randn({5, 4}, 5));
  }
}

TEST(NnLinear, BackwardFillsParameterGradsAndAccumulates) {
  Generator g(4);
  nn::Linear lin(3, 2, true, g);
  lin.to(DType::f64);
  ag::Variable x(randn({4, 3}, 6));
  ag::sum(lin(x)).backward();
  // d sum(xW^T + b) / db = N per output, dW[o][k] = sum_n x[n][k].
  EXPECT_EQ(lin.bias().grad().to_vector<double>(), (std::vector<double>{4.0, 4.0}));
  Tensor colsum = sum(x.data(), {0});
  EXPECT_LT(max_abs_diff(lin.weight().grad().select(0, 1), colsum), 1e-12);
  ag::sum(lin(x)).backward();
  EXPECT_EQ(lin.bias().grad().to_vector<double>(), (std::vector<double>{8.0, 8.0}));
  EXPECT_FALSE(x.grad().defined());
}

TEST(NnLinear, BadUseThrows) {
  Generator g(5);
  nn::Linear lin(4, 3, true, g);
  expect_error([&] { lin(ag::Variable(randn({2, 5}, 1, DType::f32))); }, {"linear", "[2, 5]", "[3, 4]"});
  expect_error([&] { lin(ag::Variable(randn({2, 4}, 1, DType::f64))); }, {"linear", "dtype"});
  expect_error([&] { nn::Linear(0, 3, true, g); }, {"Linear", "in = 0"});
  expect_error([&] { nn::linear(ag::Variable(randn({2, 4}, 1)), ag::Variable(randn({3, 4}, 2)),
                                ag::Variable(randn({4}, 3))); }, {"linear", "bias", "[4]"});
}

TEST(NnLinear, SaveLoadRoundTrip) {
  Generator g(8), g2(9);
  nn::Linear a(5, 3, true, g), b(5, 3, true, g2);
  EXPECT_GT(max_abs_diff(a.weight().data(), b.weight().data()), 0.0);
  expect_roundtrip(a, b, "t2m_test_linear.ckpt");
  const Tensor x = randn({2, 5}, 10, DType::f32);
  EXPECT_EQ(max_abs_diff(a(ag::Variable(x)).data(), b(ag::Variable(x)).data()), 0.0);
}

// ---- norms ----------------------------------------------------------------------------------------------------

TEST(NnNorm, ParametersInitAndAffineOff) {
  nn::LayerNorm ln(8);
  EXPECT_EQ(names(ln), (std::vector<std::string>{"weight", "bias"}));
  EXPECT_EQ(ln.weight().data().to_vector<float>(), std::vector<float>(8, 1.0f));
  EXPECT_EQ(ln.bias().data().to_vector<float>(), std::vector<float>(8, 0.0f));
  EXPECT_EQ(nn::LayerNorm(8, false).num_parameters(), 0);
  EXPECT_EQ(names(nn::LayerNorm(8, true, 1e-5, false)), (std::vector<std::string>{"weight"}));
  EXPECT_EQ(names(nn::RMSNorm(8)), (std::vector<std::string>{"weight"}));
  EXPECT_EQ(nn::RMSNorm(8, false).num_parameters(), 0);
  nn::GroupNorm gn(4, 8);
  EXPECT_EQ(names(gn), (std::vector<std::string>{"weight", "bias"}));
  EXPECT_EQ(nn::GroupNorm(4, 8, false).num_parameters(), 0);
  expect_error([] { nn::GroupNorm(3, 8); }, {"GroupNorm", "8", "3"});
  expect_error([] { nn::LayerNorm(0); }, {"LayerNorm", "0"});
}

TEST(NnNorm, ValuesNormaliseRows) {
  // Without affine: each row has mean 0 and (biased) variance 1 - eps-ish; RMSNorm rows have mean square 1.
  const Tensor x = randn({3, 16}, 11, DType::f32);
  Tensor y = nn::LayerNorm(16, false, 0.0)(ag::Variable(x)).data().to(DType::f64);
  Tensor m = mean(y, {1}), v = mean(square(y), {1});
  EXPECT_LT(amax(abs(m)).item(), 1e-6);
  EXPECT_LT(amax(abs(add(v, -1.0))).item(), 1e-5);
  Tensor r = nn::RMSNorm(16, false, 0.0)(ag::Variable(x)).data().to(DType::f64);
  EXPECT_LT(amax(abs(add(mean(square(r), {1}), -1.0))).item(), 1e-5);
  // GroupNorm over (B, C, T): each (b, group) block of C/G x T values is normalised.
  const Tensor xg = randn({2, 4, 5}, 12, DType::f32);
  Tensor yg = nn::GroupNorm(2, 4, false, 0.0)(ag::Variable(xg)).data().to(DType::f64).view({2, 2, 10});
  EXPECT_LT(amax(abs(mean(yg, {2}))).item(), 1e-6);
  EXPECT_LT(amax(abs(add(mean(square(yg), {2}), -1.0))).item(), 1e-5);
}

TEST(NnNorm, GradcheckFloat64ThroughModules) {
  Generator g(13);
  nn::LayerNorm ln(5);
  ln.to(DType::f64);
  // Non-trivial affine parameters so their gradients are checked away from the init.
  ln.weight().data().copy_(randn({5}, 14));
  ln.bias().data().copy_(randn({5}, 15));
  expect_module_gradcheck(ln, [&](const ag::Variable& x) { return ln(x); }, randn({2, 3, 5}, 16));
  nn::RMSNorm rn(4);
  rn.to(DType::f64);
  rn.weight().data().copy_(randn({4}, 17));
  expect_module_gradcheck(rn, [&](const ag::Variable& x) { return rn(x); }, randn({3, 4}, 18));
  nn::GroupNorm gn(2, 4);
  gn.to(DType::f64);
  gn.weight().data().copy_(randn({4}, 19));
  gn.bias().data().copy_(randn({4}, 20));
  expect_module_gradcheck(gn, [&](const ag::Variable& x) { return gn(x); }, randn({2, 4, 3}, 21));
  nn::LayerNorm plain(3, false);
  expect_module_gradcheck(plain, [&](const ag::Variable& x) { return plain(x); }, randn({2, 3}, 22));
}

TEST(NnNorm, SaveLoadRoundTrip) {
  nn::GroupNorm a(2, 4), b(2, 4);
  a.weight().data().copy_(randn({4}, 23, DType::f32));
  a.bias().data().copy_(randn({4}, 24, DType::f32));
  expect_roundtrip(a, b, "t2m_test_groupnorm.ckpt");
  nn::LayerNorm la(6), lb(6);
  la.weight().data().copy_(randn({6}, 25, DType::f32));
  expect_roundtrip(la, lb, "t2m_test_layernorm.ckpt");
  nn::LayerNorm wrong(7);
  nn::Checkpoint ck;
  la.save_to(ck, "mod.");
  expect_error([&] { wrong.load_from(ck, "mod."); }, {"mod.weight", "[6]", "[7]"});
}
