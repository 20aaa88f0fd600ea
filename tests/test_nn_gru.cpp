// test_nn_gru.cpp — the GRU layer: values against a naive loop (both directions, with padding), padding carries
// the state exactly like a shorter sequence, float64 gradcheck of every input and parameter, the module's
// parameters and init, bad shapes.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "autograd/gradcheck.h"
#include "autograd/ops_join.h"
#include "autograd/ops_reduce.h"
#include "nn/gru.h"
#include "tensor/ops.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

using namespace t2m;
using t2m::testing::expect_error;

namespace {

Tensor randu(Shape s, uint64_t seed, DType dt = DType::f64, double lo = -1.0, double hi = 1.0) {
  Generator g(seed);
  return rand_uniform(s, g, lo, hi, dt);
}

double sigm(double v) { return 1.0 / (1.0 + std::exp(-v)); }

// The GRU equations written out per element in double. Returns output (B, T, H) and last (B, H) as vectors.
struct Naive {
  std::vector<double> out, last;
};
Naive naive_gru(const Tensor& x, const Tensor& h0, const Tensor& wih, const Tensor& whh, const Tensor& bih,
                const Tensor& bhh, const Tensor& mask, bool reverse) {
  const int64_t B = x.size(0), T = x.size(1), I = x.size(2), H = whh.size(1);
  Naive r;
  r.out.assign(B * T * H, 0.0);
  r.last.assign(B * H, 0.0);
  for (int64_t b = 0; b < B; ++b) {
    std::vector<double> h(H, 0.0);
    if (h0.defined())
      for (int64_t j = 0; j < H; ++j) h[j] = h0.at({b, j});
    for (int64_t s = 0; s < T; ++s) {
      const int64_t t = reverse ? T - 1 - s : s;
      if (mask.defined() && mask.at({b, t}) == 0.0) continue;  // padding: state carried, output 0
      std::vector<double> a(3 * H), c(3 * H);
      for (int64_t k = 0; k < 3 * H; ++k) {
        a[k] = bih.defined() ? bih.at({k}) : 0.0;
        c[k] = bhh.defined() ? bhh.at({k}) : 0.0;
        for (int64_t i = 0; i < I; ++i) a[k] += wih.at({k, i}) * x.at({b, t, i});
        for (int64_t j = 0; j < H; ++j) c[k] += whh.at({k, j}) * h[j];
      }
      std::vector<double> hn(H);
      for (int64_t j = 0; j < H; ++j) {
        const double rg = sigm(a[j] + c[j]), zg = sigm(a[H + j] + c[H + j]);
        const double ng = std::tanh(a[2 * H + j] + rg * c[2 * H + j]);
        hn[j] = (1 - zg) * ng + zg * h[j];
      }
      h = hn;
      for (int64_t j = 0; j < H; ++j) r.out[(b * T + t) * H + j] = h[j];
    }
    for (int64_t j = 0; j < H; ++j) r.last[b * H + j] = h[j];
  }
  return r;
}

Tensor right_padding_mask(const std::vector<int64_t>& lengths, int64_t T) {
  Tensor m = Tensor::zeros({(int64_t)lengths.size(), T});
  for (size_t b = 0; b < lengths.size(); ++b)
    for (int64_t t = 0; t < lengths[b]; ++t) m.set({(int64_t)b, t}, 1.0);
  return m;
}

}  // namespace

TEST(NnGru, ModuleParametersAndInit) {
  Generator g(1);
  nn::GRU gru(5, 4, g);
  auto named = gru.named_parameters();
  ASSERT_EQ(named.size(), 4u);
  EXPECT_EQ(named[0].first, "weight_ih");
  EXPECT_EQ(named[1].first, "weight_hh");
  EXPECT_EQ(named[2].first, "bias_ih");
  EXPECT_EQ(named[3].first, "bias_hh");
  EXPECT_EQ(gru.weight_ih().shape(), (Shape{12, 5}));
  EXPECT_EQ(gru.weight_hh().shape(), (Shape{12, 4}));
  EXPECT_EQ(gru.bias_ih().shape(), (Shape{12}));
  EXPECT_EQ(gru.num_parameters(), 12 * 5 + 12 * 4 + 24);
  for (auto& [name, p] : named) {
    EXPECT_LE(amax(abs(p.data())).item(), 0.5) << name;  // U(-1/sqrt(4), 1/sqrt(4))
    EXPECT_GT(amax(abs(p.data())).item(), 0.3) << name;
  }
  Generator g2(1);
  nn::GRU same(5, 4, g2);
  EXPECT_EQ(max_abs_diff(same.weight_hh().data(), gru.weight_hh().data()), 0.0);
}

TEST(NnGru, ForwardMatchesNaiveLoop) {
  Generator g(2);
  nn::GRU gru(3, 4, g);
  Tensor x = randu({2, 5, 3}, 3, DType::f32, -2.0, 2.0);
  Tensor h0 = randu({2, 4}, 4, DType::f32);
  for (bool reverse : {false, true}) {
    for (bool with_h0 : {false, true}) {
      nn::GRUOutput o = gru.forward(ag::Variable(x), Tensor(), with_h0 ? ag::Variable(h0) : ag::Variable(), reverse);
      ASSERT_EQ(o.output.shape(), (Shape{2, 5, 4}));
      ASSERT_EQ(o.last.shape(), (Shape{2, 4}));
      Naive want = naive_gru(x, with_h0 ? h0 : Tensor(), gru.weight_ih().data(), gru.weight_hh().data(),
                             gru.bias_ih().data(), gru.bias_hh().data(), Tensor(), reverse);
      auto got = o.output.data().to_vector<float>();
      for (size_t i = 0; i < got.size(); ++i) EXPECT_NEAR(got[i], want.out[i], 1e-5) << i;
      auto last = o.last.data().to_vector<float>();
      for (size_t i = 0; i < last.size(); ++i) EXPECT_NEAR(last[i], want.last[i], 1e-5) << i;
      // last = output at the final step read (T-1 forward, 0 reverse).
      EXPECT_EQ(max_abs_diff(o.last.data(), o.output.data().select(1, reverse ? 0 : 4)), 0.0);
    }
  }
}

TEST(NnGru, PaddingCarriesStateLikeAShorterSequence) {
  Generator g(5);
  nn::GRU gru(3, 4, g);
  const int64_t T = 6;
  const std::vector<int64_t> lengths = {6, 3, 1};
  Tensor x = randu({3, T, 3}, 6);
  Tensor mask = right_padding_mask(lengths, T);
  gru.to(DType::f64);
  for (bool reverse : {false, true}) {
    nn::GRUOutput o = gru.forward(ag::Variable(x), mask, ag::Variable(), reverse);
    Naive want = naive_gru(x, Tensor(), gru.weight_ih().data(), gru.weight_hh().data(), gru.bias_ih().data(),
                           gru.bias_hh().data(), mask, reverse);
    auto got = o.output.data().to_vector<double>();
    for (size_t i = 0; i < got.size(); ++i) EXPECT_NEAR(got[i], want.out[i], 1e-12) << i;
    for (int64_t b = 0; b < 3; ++b) {
      // The same item alone, cut to its length: identical final state (pack_padded_sequence semantics).
      Tensor xb = x.select(0, b).slice(0, 0, lengths[b]).unsqueeze(0).contiguous();
      nn::GRUOutput ob = gru.forward(ag::Variable(xb), Tensor(), ag::Variable(), reverse);
      EXPECT_LT(max_abs_diff(ob.last.data().select(0, 0), o.last.data().select(0, b)), 1e-14) << b << reverse;
      for (int64_t t = lengths[b]; t < T; ++t)
        EXPECT_EQ(amax(abs(o.output.data().select(0, b).select(0, t))).item(), 0.0);
    }
  }
}

TEST(NnGru, GradcheckFloat64AllInputs) {
  const int64_t B = 2, T = 3, I = 3, H = 2;
  std::vector<Tensor> inputs = {randu({B, T, I}, 11, DType::f64, -1.5, 1.5), randu({B, H}, 12),
                                randu({3 * H, I}, 13), randu({3 * H, H}, 14), randu({3 * H}, 15), randu({3 * H}, 16)};
  const Tensor mask = right_padding_mask({3, 2}, T).to(DType::f64);
  for (bool reverse : {false, true})
    for (bool masked : {false, true}) {
      auto f = [&](const std::vector<ag::Variable>& v) {
        nn::GRUOutput o = nn::gru(v[0], v[1], v[2], v[3], v[4], v[5], masked ? mask : Tensor(), reverse);
        return ag::concat({o.output.flatten(), o.last.flatten()}, 0);
      };
      ag::GradcheckResult r = ag::gradcheck(f, inputs);
      EXPECT_TRUE(r.ok) << "reverse " << reverse << " masked " << masked << ": " << r.message;
    }
  // Without biases and h0.
  auto f2 = [&](const std::vector<ag::Variable>& v) {
    return nn::gru(v[0], ag::Variable(), v[1], v[2], ag::Variable(), ag::Variable()).last;
  };
  ag::GradcheckResult r2 = ag::gradcheck(f2, {inputs[0], inputs[2], inputs[3]});
  EXPECT_TRUE(r2.ok) << r2.message;
}

TEST(NnGru, BackwardReachesModuleParameters) {
  Generator g(21);
  nn::GRU gru(3, 5, g);
  Tensor x = randu({4, 7, 3}, 22, DType::f32);
  nn::GRUOutput o = gru.forward(ag::Variable(x), right_padding_mask({7, 5, 2, 1}, 7));
  ag::sum(o.last).backward();
  for (auto& [name, p] : gru.named_parameters()) {
    ASSERT_TRUE(p.grad().defined()) << name;
    EXPECT_GT(amax(abs(p.grad())).item(), 0.0) << name;
  }
}

TEST(NnGru, BadShapesThrow) {
  Generator g(31);
  nn::GRU gru(3, 4, g);
  expect_error([&] { gru.forward(ag::Variable(Tensor::zeros({2, 3}))); }, {"gru: x must be", "[2, 3]"});
  expect_error([&] { gru.forward(ag::Variable(Tensor::zeros({2, 0, 3}))); }, {"gru: x", "T >= 1", "[2, 0, 3]"});
  expect_error([&] { gru.forward(ag::Variable(Tensor::zeros({2, 5, 4}))); }, {"gru: weight_ih", "[12, 4]", "[12, 3]"});
  expect_error([&] { gru.forward(ag::Variable(Tensor::zeros({2, 5, 3})), Tensor::ones({2, 4})); },
               {"gru: mask", "[2, 5]", "[2, 4]"});
  expect_error([&] { gru.forward(ag::Variable(Tensor::zeros({2, 5, 3})), Tensor::ones({2, 5}, DType::i64)); },
               {"gru: mask", "i64"});
  expect_error([&] { gru.forward(ag::Variable(Tensor::zeros({2, 5, 3})), Tensor(), ag::Variable(Tensor::zeros({3, 4}))); },
               {"gru: h0", "[2, 4]", "[3, 4]"});
  ag::Variable x(Tensor::zeros({1, 2, 3}));
  expect_error([&] { nn::gru(x, {}, ag::Variable(Tensor::zeros({6, 3})), ag::Variable(Tensor::zeros({6, 3})), {}, {}); },
               {"gru: weight_hh must be (3H, H)", "[6, 3]"});
  expect_error([&] {
    nn::gru(x, {}, ag::Variable(Tensor::zeros({6, 3})), ag::Variable(Tensor::zeros({6, 2})),
            ag::Variable(Tensor::zeros({5})), {});
  }, {"gru: biases", "[6]", "[5]"});
  expect_error([&] { nn::GRU bad(0, 4, g); }, {"gru", "input = 0"});
  expect_error([&] { nn::GRU bad(3, 0, g); }, {"gru", "hidden = 0"});
}
