// test_profiler.cpp — ag::Profiler: per-op forward / backward attribution, the buckets adding up to the total,
// mark(), the engine's own buckets, one profiler per thread, other threads not counted, the table.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "autograd/autograd.h"
#include "tensor/ops.h"

namespace {

using namespace t2m;
using ag::Variable;
using std::chrono::milliseconds;

Tensor vec(std::vector<double> v) { return Tensor::from_vector(v, {(int64_t)v.size()}).to(DType::f32); }

// An identity op whose forward result takes `fwd_ms` to make and whose backward takes `bwd_ms`.
Variable slow_identity(const Variable& x, int fwd_ms, int bwd_ms) {
  std::this_thread::sleep_for(milliseconds(fwd_ms));
  return ag::record("slow_identity", x.data().clone(), {x}, [bwd_ms](const Tensor& g, const std::vector<bool>&) {
    std::this_thread::sleep_for(milliseconds(bwd_ms));
    return std::vector<Tensor>{g};
  });
}

const ag::OpTime* find(const std::vector<ag::OpTime>& v, const std::string& op) {
  for (const auto& t : v)
    if (t.op == op) return &t;
  return nullptr;
}

double sum_of_buckets(const ag::Profiler& p) {
  double s = 0;
  for (const auto& t : p.ops()) s += t.total_ms();
  return s;
}

TEST(Profiler, AttributesForwardAndBackwardToTheOp) {
  Variable x = Variable::parameter(vec({1, 2, 3}), "x");
  ag::Profiler prof;
  Variable y = ag::sum(ag::exp(slow_identity(x, 30, 40)));
  y.backward();
  const auto ops = prof.ops();
  const ag::OpTime* slow = find(ops, "slow_identity");
  ASSERT_NE(slow, nullptr);
  EXPECT_EQ(slow->calls, 1);
  EXPECT_EQ(slow->bwd_calls, 1);
  EXPECT_GE(slow->fwd_ms, 30.0);
  EXPECT_GE(slow->bwd_ms, 40.0);
  for (const char* op : {"exp", "sum"}) {
    const ag::OpTime* t = find(ops, op);
    ASSERT_NE(t, nullptr) << op;
    EXPECT_EQ(t->calls, 1) << op;
    EXPECT_EQ(t->bwd_calls, 1) << op;
  }
  // The slowest bucket comes first, and the buckets add up to the total.
  EXPECT_EQ(ops.front().op, "slow_identity");
  EXPECT_NEAR(sum_of_buckets(prof), prof.total_ms(), 1e-6 * prof.total_ms());
  EXPECT_GE(prof.total_ms(), 70.0);
  EXPECT_NE(find(ops, "(engine)"), nullptr);
}

TEST(Profiler, MarkTakesTheTimeSinceTheLastEvent) {
  Variable x = Variable::parameter(vec({1, 2}), "x");
  ag::Profiler prof;
  Variable y = ag::sum(ag::mul(x, x));
  y.backward();
  std::this_thread::sleep_for(milliseconds(50));  // e.g. an optimizer step
  prof.mark("optimizer");
  Variable z = ag::neg(x);
  const auto ops = prof.ops();
  ASSERT_NE(find(ops, "optimizer"), nullptr);
  EXPECT_GE(find(ops, "optimizer")->fwd_ms, 50.0);
  ASSERT_NE(find(ops, "neg"), nullptr);
  EXPECT_LT(find(ops, "neg")->fwd_ms, 50.0);  // the sleep went to the mark, not to the next op
  EXPECT_NEAR(sum_of_buckets(prof), prof.total_ms(), 1e-6 * prof.total_ms());
}

TEST(Profiler, CountsOpsWithoutGradAndAccumulation) {
  Variable x = Variable::parameter(vec({1, 2, 3}), "x");
  ag::Profiler prof;
  {
    ag::NoGradGuard ng;
    ag::exp(x);
  }
  Variable y = ag::sum(ag::add(ag::exp(x), ag::exp(x)));  // x's gradient is summed from two uses
  y.backward();
  const auto ops = prof.ops();
  ASSERT_NE(find(ops, "exp"), nullptr);
  EXPECT_EQ(find(ops, "exp")->calls, 3);      // the no-grad one included
  EXPECT_EQ(find(ops, "exp")->bwd_calls, 2);  // only the recorded ones
  EXPECT_NE(find(ops, "(grad accumulate)"), nullptr);
}

TEST(Profiler, OnlyTheThreadThatStartedItAndOneAtATime) {
  Variable x = Variable::parameter(vec({1, 2}), "x");
  EXPECT_EQ(ag::Profiler::active(), nullptr);
  {
    ag::Profiler prof;
    EXPECT_EQ(ag::Profiler::active(), &prof);
    EXPECT_THROW(ag::Profiler second, Error);
    std::thread other([&] {
      EXPECT_EQ(ag::Profiler::active(), nullptr);
      ag::exp(x);
    });
    other.join();
    EXPECT_EQ(find(prof.ops(), "exp"), nullptr);
    ag::exp(x);
    EXPECT_NE(find(prof.ops(), "exp"), nullptr);
  }
  EXPECT_EQ(ag::Profiler::active(), nullptr);
  ag::Profiler again;  // the first one is gone
  EXPECT_TRUE(again.ops().empty());
}

TEST(Profiler, ByShapeKeepsEachInputShapeApart) {
  Variable a = Variable::parameter(vec({1, 2, 3}), "a"), b = Variable::parameter(vec({1, 2}), "b");
  ag::Profiler prof(/*by_shape=*/true);
  ag::sum(ag::add(ag::exp(a), ag::exp(a))).backward();
  ag::sum(ag::exp(b)).backward();
  const auto ops = prof.ops();
  ASSERT_NE(find(ops, "exp [3]"), nullptr);
  ASSERT_NE(find(ops, "exp [2]"), nullptr);
  EXPECT_EQ(find(ops, "exp [3]")->calls, 2);
  EXPECT_EQ(find(ops, "exp [3]")->bwd_calls, 2);
  EXPECT_EQ(find(ops, "exp [2]")->calls, 1);
  EXPECT_EQ(find(ops, "exp [2]")->bwd_calls, 1);
  EXPECT_NE(find(ops, "add [3] [3]"), nullptr);
  EXPECT_EQ(find(ops, "exp"), nullptr);
  EXPECT_NE(prof.table().find("add [3] [3]"), std::string::npos);
}

TEST(Profiler, TablePerStepWithTheRestSummed) {
  Variable x = Variable::parameter(vec({1, 2, 3}), "x");
  ag::Profiler prof;
  for (int step = 0; step < 2; ++step) {
    Variable y = ag::sum(ag::tanh(ag::exp(slow_identity(x, 5, 5))));
    y.backward();
    prof.mark("optimizer");
  }
  const std::string t = prof.table(2, 2);
  EXPECT_NE(t.find("slow_identity"), std::string::npos) << t;
  EXPECT_NE(t.find(" more)"), std::string::npos) << t;  // the buckets past the first two, in one row
  EXPECT_NE(t.find("total"), std::string::npos) << t;
  // "calls" per step: slow_identity ran once in each of the 2 steps.
  EXPECT_NE(t.find("slow_identity                      1.0       1.0"), std::string::npos) << t;
  EXPECT_THROW(prof.table(0), Error);
}

}  // namespace
