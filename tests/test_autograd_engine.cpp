// test_autograd_engine.cpp — the tape itself: backward errors, no_grad, accumulation, shared sub-expressions,
// deep graphs, retain_grad/detach, non-smooth points, size-0 dims, bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <thread>

#include "autograd/autograd.h"
#include "tensor/ops.h"

namespace {

using namespace t2m;
using ag::Variable;

// float32 tensors (the default dtype of the engine).
Tensor vec(std::vector<double> v) { return Tensor::from_vector(v, {(int64_t)v.size()}).to(DType::f32); }
Tensor mat(std::vector<double> v, int64_t r, int64_t c) { return Tensor::from_vector(v, {r, c}).to(DType::f32); }
std::vector<double> values(const Tensor& t) { return t.to(DType::f64).to_vector<double>(); }

// Runs f and returns the t2m::Error message (fails the test when nothing or something else is thrown).
template <typename F>
std::string error_of(F f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "threw a non-t2m::Error: " << e.what();
    return {};
  }
  ADD_FAILURE() << "did not throw";
  return {};
}

TEST(AutogradEngine, BackwardTwiceThroughFreedGraphThrows) {
  Variable x = Variable::parameter(vec({1, 2, 3}), "x");
  Variable y = ag::sum(ag::exp(x));
  y.backward();
  std::string msg = error_of([&] { y.backward(); });
  EXPECT_NE(msg.find("graph already freed"), std::string::npos) << msg;
  EXPECT_NE(msg.find("retain_graph=true"), std::string::npos) << msg;
}

TEST(AutogradEngine, RetainGraphAllowsSecondBackwardAndAccumulates) {
  Variable x = Variable::parameter(vec({0.5, -1.0}), "x");
  Variable y = ag::sum(ag::exp(x));
  y.backward(Tensor(), /*retain_graph=*/true);
  y.backward();
  std::vector<double> g = values(x.grad());
  EXPECT_NEAR(g[0], 2 * std::exp(0.5), 1e-5);
  EXPECT_NEAR(g[1], 2 * std::exp(-1.0), 1e-5);
}

TEST(AutogradEngine, NonScalarWithoutSeedNamesShape) {
  Variable x = Variable::parameter(Tensor::ones({2, 3}));
  Variable y = x * 2.0;
  std::string msg = error_of([&] { y.backward(); });
  EXPECT_NE(msg.find("[2, 3]"), std::string::npos) << msg;
  EXPECT_NE(msg.find("not a scalar"), std::string::npos) << msg;
}

TEST(AutogradEngine, SeedGivesVectorJacobianProduct) {
  Variable x = Variable::parameter(vec({1, 2, 3}));
  Variable y = ag::square(x);
  y.backward(vec({1, 0.5, -1}));
  EXPECT_EQ(values(x.grad()), (std::vector<double>{2, 2, -6}));
  // Wrong seed shape / dtype.
  Variable z = ag::square(x);
  EXPECT_NE(error_of([&] { z.backward(vec({1, 2})); }).find("[2]"), std::string::npos);
  EXPECT_NE(error_of([&] { z.backward(vec({1, 2, 3}).to(DType::f64)); }).find("does not match"), std::string::npos);
}

TEST(AutogradEngine, BackwardOnConstantThrows) {
  Variable c(vec({1, 2}));
  std::string msg = error_of([&] { ag::sum(c).backward(); });
  EXPECT_NE(msg.find("does not require grad"), std::string::npos) << msg;
  EXPECT_NE(error_of([] { Variable().backward(); }).find("undefined"), std::string::npos);
}

TEST(AutogradEngine, NoGradRecordsNothing) {
  Variable x = Variable::parameter(vec({1, 2}));
  {
    ag::NoGradGuard g;
    EXPECT_FALSE(ag::GradMode::is_enabled());
    Variable y = ag::exp(x) * x;
    EXPECT_FALSE(y.requires_grad());
    EXPECT_EQ(y.grad_fn(), nullptr);
    EXPECT_TRUE(y.is_leaf());
    {
      ag::NoGradGuard nested;
    }
    EXPECT_FALSE(ag::GradMode::is_enabled()) << "a nested guard must restore 'off', not 'on'";
    // Thread-local: another thread still records.
    bool other_records = false;
    std::thread t([&] { other_records = ag::exp(x).grad_fn() != nullptr; });
    t.join();
    EXPECT_TRUE(other_records);
  }
  EXPECT_TRUE(ag::GradMode::is_enabled());
  Variable z = ag::exp(x);
  ASSERT_NE(z.grad_fn(), nullptr);
  EXPECT_EQ(z.grad_fn()->op, "exp");
}

TEST(AutogradEngine, AccumulatesAcrossBackwardCallsUntilZeroGrad) {
  Variable x = Variable::parameter(vec({1, -2, 3}), "x");
  auto loss = [&] { return ag::sum(x * x); };
  loss().backward();
  EXPECT_EQ(values(x.grad()), (std::vector<double>{2, -4, 6}));
  loss().backward();
  EXPECT_EQ(values(x.grad()), (std::vector<double>{4, -8, 12}));
  const void* mem = x.grad().data<float>();
  x.zero_grad();
  EXPECT_EQ(values(x.grad()), (std::vector<double>{0, 0, 0}));
  EXPECT_EQ(x.grad().data<float>(), mem) << "zero_grad keeps the buffer";
  loss().backward();
  EXPECT_EQ(values(x.grad()), (std::vector<double>{2, -4, 6}));
  x.clear_grad();
  EXPECT_FALSE(x.grad().defined());
}

// zero_grad() only marks the buffer stale: the next gradient replaces it (no zeroing pass). Checked without
// reading .grad() in between (reading materialises the zeros): a leaf used twice in one graph, two backward calls,
// and a parameter that gets no gradient after zero_grad() all read as if zeroed eagerly.
TEST(AutogradEngine, LazyZeroGradOverwritesThenAccumulates) {
  Variable x = Variable::parameter(vec({1, -2, 3}), "x");
  Variable unused = Variable::parameter(vec({5, 6}), "unused");
  (ag::sum(x * x) + ag::sum(unused)).backward();
  ag::sum(x * x).backward();
  x.zero_grad();
  unused.zero_grad();
  ag::sum(x * x + x).backward();  // x twice: adopt or copy, then add
  ag::sum(x * 2.0).backward();
  EXPECT_EQ(values(x.grad()), (std::vector<double>{5, -1, 9}));
  EXPECT_EQ(values(unused.grad()), (std::vector<double>{0, 0}));
  x.zero_grad();
  x.zero_grad();
  ag::sum(x * 3.0).backward();
  EXPECT_EQ(values(x.grad()), (std::vector<double>{3, 3, 3}));
}

TEST(AutogradEngine, SharedSubExpressionSumsAllPaths) {
  // y = b*b + b with b = exp(x): dy/dx = (2b + 1) * b.
  Variable x = Variable::parameter(vec({0.3, -0.7}));
  Variable b = ag::exp(x);
  Variable y = ag::sum(b * b + b);
  y.backward();
  std::vector<double> g = values(x.grad());
  for (int i = 0; i < 2; ++i) {
    double bi = std::exp(i == 0 ? 0.3 : -0.7);
    EXPECT_NEAR(g[i], (2 * bi + 1) * bi, 1e-5);
  }
  // The same leaf as both inputs of one op.
  Variable a = Variable::parameter(vec({1.5}));
  ag::sum(a + a).backward();
  EXPECT_EQ(values(a.grad()), (std::vector<double>{2}));
}

TEST(AutogradEngine, GradsDoNotAliasEachOther) {
  // add's backward hands the same tensor to both inputs; accumulating into one must not change the other.
  Variable a = Variable::parameter(vec({1, 2}));
  Variable b = Variable::parameter(vec({3, 4}));
  ag::sum(a + b).backward();
  ag::sum(a * 3.0).backward();
  EXPECT_EQ(values(a.grad()), (std::vector<double>{4, 4}));
  EXPECT_EQ(values(b.grad()), (std::vector<double>{1, 1}));
}

TEST(AutogradEngine, NonLeafSumsInPlaceOnlyWhenUnshared) {
  // y = sum(1 * (p + (q + 3p))): the outer add's backward hands one (contiguous) tensor to p and to (q + 3p),
  // whose add hands it on to q. p then gets 3 g from the inner product while q's gradient, the same tensor, is
  // still pending. The engine sums a node's gradients in place only when it holds the only handle on them, so
  // q's stays 1.
  Variable x = Variable::parameter(vec({0.2, -0.4}));
  Variable p = ag::exp(x), q = ag::exp(x * 2.0);
  p.retain_grad();
  q.retain_grad();
  ag::sum((p + (q + p * 3.0)) * 1.0).backward();
  EXPECT_EQ(values(p.grad()), (std::vector<double>{4, 4}));
  EXPECT_EQ(values(q.grad()), (std::vector<double>{1, 1}));
  std::vector<double> g = values(x.grad());
  for (int i = 0; i < 2; ++i) {
    const double xi = i == 0 ? 0.2 : -0.4;
    EXPECT_NEAR(g[i], 4 * std::exp(xi) + 2 * std::exp(2 * xi), 1e-5);
  }
}

TEST(AutogradEngine, DeepChainDoesNotOverflowTheStack) {
  const int n = 10000;
  Variable x = Variable::parameter(Tensor::full({1}, 0.5, DType::f64));
  Variable y = x;
  for (int i = 0; i < n; ++i) y = y * 1.0001 + 0.0;  // 2 ops per step: 20,000 nodes
  ag::sum(y).backward();
  EXPECT_NEAR(x.grad().item(), std::pow(1.0001, n), 1e-9 * std::pow(1.0001, n));
  // A deeper graph that is dropped without backward: destruction must not recurse either.
  Variable z = x;
  for (int i = 0; i < 100000; ++i) z = z + 1.0;
  EXPECT_DOUBLE_EQ(z.item(), 0.5 + 100000);
  z = Variable();
  SUCCEED();
}

TEST(AutogradEngine, GraphDoesNotKeepUnsavedIntermediatesAlive) {
  // h = x * 2 is consumed only by ops that save nothing (add_scalar, sum): once the caller drops h, its memory is
  // freed although the graph through it lives on.
  Variable x = Variable::parameter(vec({1, 2, 3}));
  Variable h = x * 2.0;
  std::weak_ptr<Storage> h_mem = h.data().storage();
  Variable y = ag::sum(h + 1.0);
  h = Variable();
  EXPECT_TRUE(h_mem.expired());
  y.backward();
  EXPECT_EQ(values(x.grad()), (std::vector<double>{2, 2, 2}));
  // An input an op saves stays alive until backward releases it.
  Variable e = ag::exp(x);  // exp saves its output
  std::weak_ptr<Storage> e_mem = e.data().storage();
  Variable z = ag::sum(ag::exp(e));  // the outer exp saves its own output, not e; sum saves nothing
  e = Variable();
  EXPECT_FALSE(e_mem.expired()) << "the inner exp saved its output for backward";
  z.backward();
  EXPECT_TRUE(e_mem.expired()) << "backward without retain_graph frees saved tensors";
}

TEST(AutogradEngine, BackwardFromALeaf) {
  Variable x = Variable::parameter(vec({1, 2}));
  x.backward(vec({3, 4}));
  EXPECT_EQ(values(x.grad()), (std::vector<double>{3, 4}));
}

TEST(AutogradEngine, NonLeafGradOnlyWithRetainGrad) {
  Variable x = Variable::parameter(vec({1, 2}));
  Variable h = x * 3.0;
  Variable k = x * 2.0;
  k.retain_grad();
  ag::sum(h * k).backward();
  EXPECT_FALSE(h.grad().defined());
  ASSERT_TRUE(k.grad().defined());
  EXPECT_EQ(values(k.grad()), (std::vector<double>{3, 6}));  // d(h*k)/dk = h
  EXPECT_EQ(values(x.grad()), (std::vector<double>{12, 24}));  // d(6 x^2)/dx = 12 x
}

TEST(AutogradEngine, DetachCutsTheGraph) {
  Variable x = Variable::parameter(vec({2, 3}));
  Variable d = x.detach();
  EXPECT_FALSE(d.requires_grad());
  EXPECT_TRUE(d.data().shares_storage(x.data()));
  ag::sum(d * x).backward();  // only the x path: grad = d
  EXPECT_EQ(values(x.grad()), (std::vector<double>{2, 3}));
}

TEST(AutogradEngine, ConstantInputsGetNoGrad) {
  Variable x = Variable::parameter(mat({1, 2, 3, 4}, 2, 2));
  Variable c(mat({1, 0, 0, 1}, 2, 2));
  ag::sum(ag::matmul(x, c)).backward();
  EXPECT_FALSE(c.grad().defined());
  EXPECT_EQ(values(x.grad()), (std::vector<double>{1, 1, 1, 1}));
  EXPECT_EQ(x.grad().dtype(), DType::f32);
}

TEST(AutogradEngine, TiesAndKinks) {
  // amax splits ties evenly; max(dim) sends the gradient to the first maximum only.
  Variable x = Variable::parameter(vec({1, 3, 3, 2}));
  ag::amax(x).backward();
  EXPECT_EQ(values(x.grad()), (std::vector<double>{0, 0.5, 0.5, 0}));
  x.clear_grad();
  ag::sum(ag::max(x, 0).values).backward();
  EXPECT_EQ(values(x.grad()), (std::vector<double>{0, 1, 0, 0}));
  // maximum/minimum split ties between a and b.
  Variable a = Variable::parameter(vec({1, 2})), b = Variable::parameter(vec({1, 3}));
  ag::sum(ag::maximum(a, b)).backward();
  EXPECT_EQ(values(a.grad()), (std::vector<double>{0.5, 0}));
  EXPECT_EQ(values(b.grad()), (std::vector<double>{0.5, 1}));
  // relu'(0) = abs'(0) = 0; clamp passes the gradient on its (inclusive) bounds.
  Variable z = Variable::parameter(vec({0, -1, 1, 2}));
  ag::sum(ag::relu(z) + ag::abs(z) + ag::clamp(z, -1, 1)).backward();
  EXPECT_EQ(values(z.grad()), (std::vector<double>{1, -1 + 1, 1 + 1 + 1, 1 + 1}));
}

TEST(AutogradEngine, WhereAndMaskedFillRouteGradients) {
  Variable a = Variable::parameter(vec({1, 2, 3})), b = Variable::parameter(vec({4, 5, 6}));
  Tensor cond = vec({1, 0, 1});
  ag::sum(ag::where(cond, a, b) * 2.0 + ag::masked_fill(a, cond, 9.0)).backward();
  EXPECT_EQ(values(a.grad()), (std::vector<double>{2, 1, 2}));
  EXPECT_EQ(values(b.grad()), (std::vector<double>{0, 2, 0}));
}

TEST(AutogradEngine, SoftmaxIsStableAndMatchesHandValues) {
  // softmax([1000, 1001]) = [1, e] / (1 + e); naive exp would overflow float32.
  const double p0 = 1.0 / (1.0 + std::exp(1.0)), p1 = 1.0 - p0;
  Variable x = Variable::parameter(vec({1000.0, 1001.0}));
  Variable y = ag::softmax(x, 0);
  EXPECT_NEAR(values(y.data())[0], p0, 1e-6);
  EXPECT_NEAR(values(y.data())[1], p1, 1e-6);
  Variable ls = ag::log_softmax(x, 0);
  EXPECT_NEAR(values(ls.data())[0], std::log(p0), 1e-5);
  // d/dx of -log_softmax(x)[1] = softmax(x) - onehot(1)
  ag::sum(ag::select(ls, 0, 1) * -1.0).backward();
  EXPECT_NEAR(values(x.grad())[0], p0, 1e-6);
  EXPECT_NEAR(values(x.grad())[1], p1 - 1.0, 1e-6);
}

TEST(AutogradEngine, ZeroSizeDims) {
  Variable x = Variable::parameter(Tensor::zeros({0, 3}));
  Variable w = Variable::parameter(vec({1, 2, 3}));
  Variable y = ag::sum(x * w);
  EXPECT_EQ(y.item(), 0.0);
  y.backward();
  EXPECT_EQ(x.grad().shape(), (Shape{0, 3}));
  EXPECT_EQ(values(w.grad()), (std::vector<double>{0, 0, 0}));
  Variable m = ag::mean(x, {0});
  m.backward(Tensor::ones({3}));
  EXPECT_EQ(x.grad().shape(), (Shape{0, 3}));
}

// A custom op whose backward returns `grads` (or throws when `throw_msg` is set).
Variable custom_op(const Variable& x, std::vector<Tensor> grads, std::string throw_msg = {}) {
  return ag::record("custom", x.data().clone(), {x}, [grads, throw_msg](const Tensor&, const std::vector<bool>&) {
    if (!throw_msg.empty()) throw Error(throw_msg);
    return grads;
  });
}

TEST(AutogradEngine, BrokenBackwardIsReportedWithTheOpName) {
  Variable x = Variable::parameter(vec({1, 2}));
  std::string msg = error_of([&] { ag::sum(custom_op(x, {}, "boom")).backward(); });
  EXPECT_NE(msg.find("backward of op 'custom': boom"), std::string::npos) << msg;
  msg = error_of([&] { ag::sum(custom_op(x, {vec({1, 2, 3})})).backward(); });
  EXPECT_NE(msg.find("'custom'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("[3]"), std::string::npos) << msg;
  msg = error_of([&] { ag::sum(custom_op(x, {vec({1, 2}), vec({1, 2})})).backward(); });
  EXPECT_NE(msg.find("returned 2 gradients for 1 inputs"), std::string::npos) << msg;
  msg = error_of([&] { ag::sum(custom_op(x, {vec({1, 2}).to(DType::f64)})).backward(); });
  EXPECT_NE(msg.find("f64"), std::string::npos) << msg;
}

TEST(AutogradEngine, AnomalyModeNamesTheOpWithANonFiniteGradient) {
  Variable x = Variable::parameter(vec({0, 4}));
  ag::sum(ag::sqrt(x)).backward();  // d sqrt(x)/dx at 0 is inf: allowed when anomaly mode is off
  EXPECT_TRUE(std::isinf(values(x.grad())[0]));
  EXPECT_EQ(values(x.grad())[1], 0.25);
  ag::DetectAnomalyGuard guard;
  std::string msg = error_of([&] { ag::sum(ag::sqrt(x) * 2.0).backward(); });
  EXPECT_NE(msg.find("op 'sqrt' produced a non-finite gradient"), std::string::npos) << msg;
  Variable y = Variable::parameter(vec({1, 4}));
  ag::sum(ag::sqrt(y)).backward();  // finite: no error
  EXPECT_EQ(values(y.grad())[1], 0.25);
}

TEST(AutogradEngine, BadInputThrowsT2mError) {
  Variable a = Variable::parameter(Tensor::ones({2, 3})), b = Variable::parameter(Tensor::ones({4}));
  error_of([&] { ag::add(a, b); });
  error_of([&] { ag::matmul(a, a); });
  error_of([&] { ag::concat({}, 0); });
  error_of([&] { ag::sum(a, {2}); });
  error_of([&] { ag::index_select(a, 0, Tensor::from_vector(std::vector<int64_t>{5}, {1})); });
  EXPECT_NE(error_of([] { (void)Variable(Tensor()); }).find("undefined"), std::string::npos);
  EXPECT_NE(error_of([] { (void)Variable(Tensor::zeros({2}, DType::i64), true); }).find("int64"), std::string::npos);
  Variable y = a * 2.0;
  EXPECT_NE(error_of([&] { y.set_requires_grad(false); }).find("not a leaf"), std::string::npos);
  EXPECT_NE(error_of([] { Variable().shape(); }).find("undefined"), std::string::npos);
  // A failed op leaves earlier graphs usable.
  ag::sum(a * a).backward();
  EXPECT_EQ(values(a.grad()), (std::vector<double>(6, 2.0)));
}

}  // namespace
