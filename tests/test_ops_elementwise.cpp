// test_ops_elementwise.cpp — binary/unary/scalar/comparison/where/in-place ops against naive double loops, on
// contiguous, strided, transposed, expanded (stride 0), size-1 and size-0 layouts, float and double.
#include <cmath>

#include "test_tensor_util.h"
#include "tensor/parallel.h"

using namespace t2m;
using namespace t2m::testing;

namespace {

// Reference broadcast: out[idx] = f(a[idx mapped], b[idx mapped]) using raw strided reads.
std::vector<double> ref_binary(const Tensor& a, const Tensor& b, const Shape& out,
                               const std::function<double(double, double)>& f) {
  std::vector<double> r;
  for_each_index(out, [&](const std::vector<int64_t>& i) {
    auto map = [&](const Tensor& t) {
      std::vector<int64_t> j(t.dim());
      for (int64_t d = 0; d < t.dim(); ++d) {
        const int64_t od = (int64_t)out.size() - t.dim() + d;
        j[d] = t.shape()[d] == 1 ? 0 : i[od];
      }
      return raw_get(t, j);
    };
    r.push_back(f(map(a), map(b)));
  });
  return r;
}

struct BinCase {
  const char* name;
  Tensor (*fn)(const Tensor&, const Tensor&);
  std::function<double(double, double)> ref;
  bool positive;  // inputs in [0.5, 2) (pow, div)
};

std::vector<BinCase> binary_cases() {
  return {
      {"add", &t2m::add, [](double x, double y) { return x + y; }, false},
      {"sub", &t2m::sub, [](double x, double y) { return x - y; }, false},
      {"mul", &t2m::mul, [](double x, double y) { return x * y; }, false},
      {"div", &t2m::div, [](double x, double y) { return x / y; }, true},
      {"pow", static_cast<Tensor (*)(const Tensor&, const Tensor&)>(&t2m::pow),
       [](double x, double y) { return std::pow(x, y); }, true},
      {"maximum", &t2m::maximum, [](double x, double y) { return std::max(x, y); }, false},
      {"minimum", &t2m::minimum, [](double x, double y) { return std::min(x, y); }, false},
      {"gt", static_cast<Tensor (*)(const Tensor&, const Tensor&)>(&t2m::gt),
       [](double x, double y) { return double(x > y); }, false},
      {"lt", static_cast<Tensor (*)(const Tensor&, const Tensor&)>(&t2m::lt),
       [](double x, double y) { return double(x < y); }, false},
      {"ge", &t2m::ge, [](double x, double y) { return double(x >= y); }, false},
      {"le", &t2m::le, [](double x, double y) { return double(x <= y); }, false},
      {"eq", &t2m::eq, [](double x, double y) { return double(x == y); }, false},
  };
}

const std::vector<std::pair<Shape, Shape>> kShapePairs = {
    {{3, 4}, {3, 4}},    {{3, 1}, {1, 4}},       {{2, 3, 4}, {4}}, {{5}, {}},
    {{0, 3}, {3}},       {{2, 1, 3}, {2, 5, 1}}, {{1}, {7}},       {{4, 3}, {4, 1}},
};

}  // namespace

TEST(OpsElementwise, BinaryAllLayoutsAndDtypes) {
  uint32_t seed = 1;
  for (DType dt : {DType::f32, DType::f64})
    for (const auto& c : binary_cases())
      for (const auto& [sa, sb] : kShapePairs) {
        const double lo = c.positive ? 0.5 : -2.0;
        Tensor a0 = random_tensor(sa, dt, seed++, lo, 2.0);
        Tensor b0 = random_tensor(sb, dt, seed++, lo, 2.0);
        if (std::string(c.name) == "eq" && a0.numel() > 0 && b0.numel() > 0)  // make some pairs equal
          raw_set(b0, std::vector<int64_t>(b0.dim(), 0), raw_get(a0, std::vector<int64_t>(a0.dim(), 0)));
        const Shape out = broadcast_shapes(sa, sb, "test");
        const auto want = ref_binary(a0, b0, out, c.ref);
        for (const Tensor& a : layouts(a0))
          for (const Tensor& b : layouts(b0)) {
            Tensor r = c.fn(a, b);
            EXPECT_TRUE(r.is_contiguous());
            EXPECT_EQ(r.dtype(), dt);
            expect_values(r, out, want, tol_for(dt) * 4,
                          std::string(c.name) + " " + shape_str(sa) + " " + shape_str(sb) + " " + dtype_name(dt));
          }
      }
}

TEST(OpsElementwise, ExpandedStrideZeroInputs) {
  for (DType dt : {DType::f32, DType::f64}) {
    Tensor row = random_tensor({1, 5}, dt, 11);
    Tensor a = row.expand({4, 5});  // stride 0 over dim 0
    EXPECT_EQ(a.strides()[0], 0);
    Tensor b = random_tensor({4, 5}, dt, 12).transpose(0, 1).contiguous().transpose(0, 1);
    Tensor r = mul(a, b);
    expect_values(r, {4, 5}, ref_binary(a, b, {4, 5}, [](double x, double y) { return x * y; }), tol_for(dt));
    Tensor s = Tensor::scalar(3.0, dt).expand({4, 5});
    expect_values(add(s, b), {4, 5}, ref_binary(s, b, {4, 5}, [](double x, double y) { return x + y; }),
                  tol_for(dt));
  }
}

TEST(OpsElementwise, LargeParallelMatchesSerial) {
  // Above kParallelGrain the op runs on several threads; results must equal the 1-thread run exactly.
  const int saved = get_num_threads();
  Tensor a = random_tensor({300, 257}, DType::f32, 5);
  Tensor b = random_tensor({257}, DType::f32, 6);
  Tensor at = a.transpose(0, 1).contiguous().transpose(0, 1);
  set_num_threads(1);
  const auto r1 = raw_values(sub(at, b)), e1 = raw_values(exp(a)), t1 = raw_values(t2m::tanh(at));
  set_num_threads(2);
  const auto r2 = raw_values(sub(at, b)), e2 = raw_values(exp(a)), t2 = raw_values(t2m::tanh(at));
  set_num_threads(saved);
  EXPECT_EQ(r1, r2);
  EXPECT_EQ(e1, e2);
  EXPECT_EQ(t1, t2);
  std::vector<double> tw;  // the transposed-layout operand (tiled copy path) gives the right values
  for (double v : raw_values(a)) tw.push_back(std::tanh(v));
  expect_values(t2m::tanh(at), {300, 257}, tw, 2e-6);
  expect_values(sub(at, b), {300, 257}, ref_binary(a, b, {300, 257}, [](double x, double y) { return x - y; }),
                2e-6);
}

TEST(OpsElementwise, Unary) {
  struct U {
    const char* name;
    std::function<Tensor(const Tensor&)> fn;
    std::function<double(double)> ref;
    double lo;
  };
  const std::vector<U> cases = {
      {"neg", [](const Tensor& x) { return neg(x); }, [](double x) { return -x; }, -2},
      {"exp", [](const Tensor& x) { return t2m::exp(x); }, [](double x) { return std::exp(x); }, -2},
      {"log", [](const Tensor& x) { return t2m::log(x); }, [](double x) { return std::log(x); }, 0.1},
      {"sqrt", [](const Tensor& x) { return t2m::sqrt(x); }, [](double x) { return std::sqrt(x); }, 0.1},
      {"rsqrt", [](const Tensor& x) { return rsqrt(x); }, [](double x) { return 1 / std::sqrt(x); }, 0.1},
      {"tanh", [](const Tensor& x) { return t2m::tanh(x); }, [](double x) { return std::tanh(x); }, -2},
      {"sigmoid", [](const Tensor& x) { return sigmoid(x); }, [](double x) { return 1 / (1 + std::exp(-x)); }, -2},
      {"relu", [](const Tensor& x) { return relu(x); }, [](double x) { return x > 0 ? x : 0; }, -2},
      {"abs", [](const Tensor& x) { return t2m::abs(x); }, [](double x) { return std::fabs(x); }, -2},
      {"sign", [](const Tensor& x) { return sign(x); }, [](double x) { return double((x > 0) - (x < 0)); }, -2},
      {"sin", [](const Tensor& x) { return t2m::sin(x); }, [](double x) { return std::sin(x); }, -2},
      {"cos", [](const Tensor& x) { return t2m::cos(x); }, [](double x) { return std::cos(x); }, -2},
      {"square", [](const Tensor& x) { return square(x); }, [](double x) { return x * x; }, -2},
      {"reciprocal", [](const Tensor& x) { return reciprocal(x); }, [](double x) { return 1 / x; }, 0.1},
      {"clamp", [](const Tensor& x) { return clamp(x, -0.5, 0.7); },
       [](double x) { return std::min(0.7, std::max(-0.5, x)); }, -2},
      {"add_s", [](const Tensor& x) { return add(x, 1.5); }, [](double x) { return x + 1.5; }, -2},
      {"mul_s", [](const Tensor& x) { return mul(x, -3.0); }, [](double x) { return -3 * x; }, -2},
      {"pow_2", [](const Tensor& x) { return t2m::pow(x, 2.0); }, [](double x) { return x * x; }, -2},
      {"pow_1.5", [](const Tensor& x) { return t2m::pow(x, 1.5); }, [](double x) { return std::pow(x, 1.5); }, 0.1},
      {"gt_s", [](const Tensor& x) { return gt(x, 0.25); }, [](double x) { return double(x > 0.25); }, -2},
      {"lt_s", [](const Tensor& x) { return lt(x, 0.25); }, [](double x) { return double(x < 0.25); }, -2},
  };
  uint32_t seed = 100;
  for (DType dt : {DType::f32, DType::f64})
    for (const auto& c : cases)
      for (const Shape& s : std::vector<Shape>{{3, 4}, {2, 1, 5}, {}, {0, 4}, {7}}) {
        Tensor a0 = random_tensor(s, dt, seed++, c.lo, 2.0);
        std::vector<double> want;
        for (double v : raw_values(a0)) want.push_back(c.ref(v));
        for (const Tensor& a : layouts(a0))
          expect_values(c.fn(a), s, want, tol_for(dt) * 2, std::string(c.name) + " " + shape_str(s));
      }
}

TEST(OpsElementwise, SigmoidStableAtExtremes) {
  Tensor x = Tensor::from_vector(std::vector<float>{-1000.f, -80.f, 0.f, 80.f, 1000.f}, {5});
  expect_values(sigmoid(x), {5}, {0.0, 1.0 / (1.0 + std::exp(80.0)), 0.5, 1.0, 1.0}, 1e-6);
  for (double v : raw_values(sigmoid(x))) EXPECT_FALSE(std::isnan(v));
}

TEST(OpsElementwise, NanPropagates) {
  const double nan = std::nan("");
  Tensor a = Tensor::from_vector(std::vector<double>{nan, 1.0, 2.0}, {3});
  Tensor b = Tensor::from_vector(std::vector<double>{0.0, nan, 1.0}, {3});
  expect_values(maximum(a, b), {3}, {nan, nan, 2.0}, 0);
  expect_values(minimum(a, b), {3}, {nan, nan, 1.0}, 0);
  expect_values(relu(a), {3}, {nan, 1.0, 2.0}, 0);
  expect_values(clamp(a, 0, 1.5), {3}, {nan, 1.0, 1.5}, 0);
}

TEST(OpsElementwise, Where) {
  for (DType dt : {DType::f32, DType::f64})
    for (DType ct : {DType::f32, DType::f64, DType::i64}) {
      Tensor cond = Tensor::from_vector(std::vector<double>{1, 0, 0, 2}, {4, 1}).to(ct);
      Tensor a0 = random_tensor({4, 3}, dt, 7), b0 = random_tensor({3}, dt, 8);
      for (const Tensor& a : layouts(a0)) {
        Tensor r = where(cond, a, b0);
        std::vector<double> want;
        for_each_index({4, 3}, [&](const std::vector<int64_t>& i) {
          want.push_back(raw_get(cond, {i[0], 0}) != 0 ? raw_get(a0, i) : raw_get(b0, {i[1]}));
        });
        expect_values(r, {4, 3}, want, 0);
      }
    }
}

TEST(OpsElementwise, InPlace) {
  for (DType dt : {DType::f32, DType::f64}) {
    Tensor d0 = random_tensor({3, 4}, dt, 21), s0 = random_tensor({4}, dt, 22);
    std::vector<double> want;
    for_each_index({3, 4}, [&](const std::vector<int64_t>& i) {
      want.push_back(raw_get(d0, i) + 0.5 * raw_get(s0, {i[1]}));
    });
    for (Tensor dc : {d0.clone(), strided_copy(d0), transposed_copy(d0)}) {
      add_(dc, s0, 0.5);
      expect_values(dc, {3, 4}, want, tol_for(dt));
      mul_(dc, 2.0);
      std::vector<double> w2;
      for (double v : want) w2.push_back(2 * v);
      expect_values(dc, {3, 4}, w2, tol_for(dt));
    }
    // add_ writes through a view into the parent.
    Tensor parent = Tensor::zeros({4, 4}, dt);
    Tensor col = parent.select(1, 2);
    add_(col, Tensor::ones({4}, dt));
    EXPECT_EQ(parent.at({3, 2}), 1.0);
    EXPECT_EQ(parent.at({3, 1}), 0.0);
  }
}

TEST(OpsElementwise, Errors) {
  Tensor a = Tensor::zeros({2, 3}), b = Tensor::zeros({4});
  expect_error([&] { add(a, b); }, {"add", "[2, 3]", "[4]"});
  expect_error([&] { mul(a, Tensor::zeros({2, 3}, DType::f64)); }, {"mul", "f32", "f64"});
  expect_error([&] { sub(Tensor::zeros({2}, DType::i64), Tensor::zeros({2}, DType::i64)); }, {"sub", "i64"});
  expect_error([&] { t2m::exp(Tensor::zeros({2}, DType::i64)); }, {"exp", "i64"});
  expect_error([&] { clamp(a, 1.0, 0.0); }, {"clamp"});
  expect_error([&] { where(Tensor::ones({5}), a, a); }, {"where", "[5]"});
  Tensor d = Tensor::zeros({3});
  expect_error([&] { add_(d, Tensor::zeros({2, 3})); }, {"add_", "[2, 3]", "[3]"});
  expect_error([&] { add(Tensor(), a); }, {"add", "undefined"});
}
