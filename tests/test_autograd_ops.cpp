// test_autograd_ops.cpp — one table, one row per autograd op (ggml test-backend-ops style). For every row:
//   (a) forward: the ag:: op's value equals the plain tensor op's value (float32);
//   (b) gradient: gradcheck (central differences in float64) passes.
// Inputs are seeded pseudo-random; a layout flag makes an input non-contiguous: 't' = transposed view of a
// [.., n, m] tensor, 's' = every other column of a [.., 2n] tensor. The leaf is the base tensor and the view is
// taken with ag::transpose / ag::slice, so view backward is exercised on the way.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <ostream>
#include <set>

#include "autograd/autograd.h"
#include "tensor/ops.h"

namespace {

using namespace t2m;
using ag::Variable;
using VV = std::vector<Variable>;
using TV = std::vector<Tensor>;

enum class Dom { any, pos };

struct In {
  Shape shape;
  char layout = 'c';  // 'c' contiguous, 't' transposed view, 's' strided (step-2) slice of the last dim
  Dom dom = Dom::any;
};

struct Row {
  std::string name;
  std::vector<In> inputs;
  std::function<Variable(const VV&)> op;
  std::function<Tensor(const TV&)> ref;
};

// splitmix64-based uniform values, independent of tensor/rng.
double uniform(uint64_t& state, double lo, double hi) {
  uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return lo + (hi - lo) * ((double)(z >> 11) / 9007199254740992.0);
}

// The storage shape for an input of logical shape s under a layout.
Shape base_shape(const In& in) {
  Shape b = in.shape;
  if (in.layout == 't') std::swap(b[b.size() - 1], b[b.size() - 2]);
  if (in.layout == 's') b.back() *= 2;
  return b;
}

Tensor make_base(const In& in, uint64_t seed) {
  Shape b = base_shape(in);
  std::vector<double> v((size_t)shape_numel(b));
  for (auto& x : v) x = in.dom == Dom::pos ? uniform(seed, 0.5, 2.0) : uniform(seed, -2.0, 2.0);
  return Tensor::from_vector(v, b);
}

Tensor layout_view(const Tensor& t, char layout) {
  if (layout == 't') return t.transpose(-1, -2);
  if (layout == 's') return t.slice(-1, 0, t.size(-1), 2);
  return t;
}

Variable layout_view(const Variable& v, char layout) {
  if (layout == 't') return ag::transpose(v, -1, -2);
  if (layout == 's') return ag::slice(v, -1, 0, v.size(-1), 2);
  return v;
}

Tensor idx(std::vector<int64_t> v, Shape s) { return Tensor::from_vector(v, s); }
// A fixed 0/1 pattern (every third element set) in the dtype of `like`.
Tensor pattern_mask(const Shape& s, const Variable& like) {
  std::vector<double> v((size_t)shape_numel(s));
  for (size_t i = 0; i < v.size(); ++i) v[i] = (i % 3 == 0) ? 1.0 : 0.0;
  return Tensor::from_vector(v, s).to(like.dtype());
}
Tensor pattern_mask(const Shape& s, const Tensor& like) {
  std::vector<double> v((size_t)shape_numel(s));
  for (size_t i = 0; i < v.size(); ++i) v[i] = (i % 3 == 0) ? 1.0 : 0.0;
  return Tensor::from_vector(v, s).to(like.dtype());
}

#define AG(expr) [](const VV& v) -> Variable { return expr; }
#define REF(expr) [](const TV& t) -> Tensor { return expr; }

In P(Shape s, char l = 'c') { return In{std::move(s), l, Dom::pos}; }
In A(Shape s, char l = 'c') { return In{std::move(s), l, Dom::any}; }

std::vector<Row> rows() {
  return {
      // ---- binary, broadcasting ----
      {"add_same", {A({3, 4}), A({3, 4})}, AG(v[0] + v[1]), REF(add(t[0], t[1]))},
      {"add_bcast", {A({2, 3, 4}), A({3, 1})}, AG(ag::add(v[0], v[1])), REF(add(t[0], t[1]))},
      {"add_rank", {A({4}), A({2, 3, 4})}, AG(v[0] + v[1]), REF(add(t[0], t[1]))},
      {"add_transposed", {A({3, 4}, 't'), A({4})}, AG(v[0] + v[1]), REF(add(t[0], t[1]))},
      {"sub_bcast", {A({2, 1, 4}), A({3, 1})}, AG(v[0] - v[1]), REF(sub(t[0], t[1]))},
      {"mul_bcast", {A({2, 3, 1}), A({1, 3, 4})}, AG(v[0] * v[1]), REF(mul(t[0], t[1]))},
      {"mul_strided", {A({3, 4}, 's'), A({3, 4}, 't')}, AG(v[0] * v[1]), REF(mul(t[0], t[1]))},
      {"mul_size1", {A({1, 1}), A({1, 5})}, AG(v[0] * v[1]), REF(mul(t[0], t[1]))},
      {"div_bcast", {A({3, 4}), P({4})}, AG(v[0] / v[1]), REF(div(t[0], t[1]))},
      {"pow_tensor", {P({3, 4}), A({3, 1})}, AG(ag::pow(v[0], v[1])), REF(pow(t[0], t[1]))},
      {"maximum_bcast", {A({3, 4}), A({4})}, AG(ag::maximum(v[0], v[1])), REF(maximum(t[0], t[1]))},
      {"minimum_bcast", {A({2, 3}), A({2, 1})}, AG(ag::minimum(v[0], v[1])), REF(minimum(t[0], t[1]))},
      // ---- scalar forms ----
      {"add_scalar", {A({3, 4})}, AG(v[0] + 1.5), REF(add(t[0], 1.5))},
      {"scalar_add", {A({3, 4})}, AG(1.5 + v[0]), REF(add(t[0], 1.5))},
      {"sub_scalar", {A({3, 4})}, AG(v[0] - 0.5), REF(add(t[0], -0.5))},
      {"rsub_scalar", {A({3, 4})}, AG(2.0 - v[0]), REF(add(neg(t[0]), 2.0))},
      {"mul_scalar", {A({3, 4}, 't')}, AG(v[0] * -3.0), REF(mul(t[0], -3.0))},
      {"scalar_mul", {A({3, 4})}, AG(-3.0 * v[0]), REF(mul(t[0], -3.0))},
      {"div_scalar", {A({3, 4})}, AG(v[0] / 4.0), REF(mul(t[0], 0.25))},
      {"rdiv_scalar", {P({3, 4})}, AG(2.0 / v[0]), REF(mul(reciprocal(t[0]), 2.0))},
      {"pow_scalar3", {A({3, 4})}, AG(ag::pow(v[0], 3.0)), REF(pow(t[0], 3.0))},
      {"pow_scalar_half", {P({3, 4}, 's')}, AG(ag::pow(v[0], 0.5)), REF(pow(t[0], 0.5))},
      // ---- selection ----
      {"where_bcast", {A({3, 4}), A({4})},
       AG(ag::where(pattern_mask({3, 1}, v[0]), v[0], v[1])), REF(where(pattern_mask({3, 1}, t[0]), t[0], t[1]))},
      {"masked_fill", {A({3, 4}, 't')},
       AG(ag::masked_fill(v[0], pattern_mask({1, 4}, v[0]), -7.0)),
       REF(masked_fill(t[0], pattern_mask({1, 4}, t[0]), -7.0))},
      // ---- unary ----
      {"neg", {A({3, 4})}, AG(-v[0]), REF(neg(t[0]))},
      {"exp", {A({3, 4}, 't')}, AG(ag::exp(v[0])), REF(exp(t[0]))},
      {"log", {P({3, 4})}, AG(ag::log(v[0])), REF(log(t[0]))},
      {"sqrt", {P({3, 4})}, AG(ag::sqrt(v[0])), REF(sqrt(t[0]))},
      {"rsqrt", {P({3, 4}, 's')}, AG(ag::rsqrt(v[0])), REF(rsqrt(t[0]))},
      {"tanh", {A({3, 4})}, AG(ag::tanh(v[0])), REF(tanh(t[0]))},
      {"sigmoid", {A({3, 4})}, AG(ag::sigmoid(v[0])), REF(sigmoid(t[0]))},
      {"relu", {A({3, 4})}, AG(ag::relu(v[0])), REF(relu(t[0]))},
      {"abs", {A({3, 4}, 't')}, AG(ag::abs(v[0])), REF(abs(t[0]))},
      {"sin", {A({3, 4})}, AG(ag::sin(v[0])), REF(sin(t[0]))},
      {"cos", {A({3, 4})}, AG(ag::cos(v[0])), REF(cos(t[0]))},
      {"square", {A({3, 4})}, AG(ag::square(v[0])), REF(square(t[0]))},
      {"reciprocal", {P({3, 4})}, AG(ag::reciprocal(v[0])), REF(reciprocal(t[0]))},
      {"clamp", {A({4, 5})}, AG(ag::clamp(v[0], -0.7, 0.9)), REF(clamp(t[0], -0.7, 0.9))},
      // ---- reductions ----
      {"sum_all", {A({3, 4})}, AG(ag::sum(v[0])), REF(sum(t[0]))},
      {"sum_dim", {A({2, 3, 4})}, AG(ag::sum(v[0], {1})), REF(sum(t[0], {1}))},
      {"sum_dims_keep", {A({2, 3, 4})}, AG(ag::sum(v[0], {0, 2}, true)), REF(sum(t[0], {0, 2}, true))},
      {"sum_negdim_t", {A({3, 4}, 't')}, AG(ag::sum(v[0], {-1})), REF(sum(t[0], {-1}))},
      {"mean_all", {A({3, 4})}, AG(ag::mean(v[0])), REF(mean(t[0]))},
      {"mean_dims", {A({2, 3, 4})}, AG(ag::mean(v[0], {1, 2})), REF(mean(t[0], {1, 2}))},
      {"amax_all", {A({3, 4})}, AG(ag::amax(v[0])), REF(amax(t[0]))},
      {"amax_dim_keep", {A({2, 3, 4})}, AG(ag::amax(v[0], {1}, true)), REF(amax(t[0], {1}, true))},
      {"amin_dim", {A({3, 4}, 's')}, AG(ag::amin(v[0], {0})), REF(amin(t[0], {0}))},
      {"logsumexp", {A({3, 4})}, AG(ag::logsumexp(v[0], 1)), REF(logsumexp(t[0], 1))},
      {"logsumexp_keep", {A({2, 3, 4})}, AG(ag::logsumexp(v[0], 0, true)), REF(logsumexp(t[0], 0, true))},
      {"sum_to", {A({2, 3, 4})}, AG(ag::sum_to(v[0], {3, 1})), REF(sum_to(t[0], {3, 1}))},
      {"sign_times", {A({3, 4}), A({3, 4})}, AG(ag::sign(v[0]) * v[1]), REF(mul(sign(t[0]), t[1]))},
      {"max_values", {A({3, 5})}, AG(ag::max(v[0], 1).values), REF(max(t[0], 1).values)},
      {"softmax", {A({3, 4})}, AG(ag::softmax(v[0], 1)), REF(exp(sub(t[0], logsumexp(t[0], 1, true))))},
      {"softmax_dim0_t", {A({3, 4}, 't')}, AG(ag::softmax(v[0], 0)), REF(exp(sub(t[0], logsumexp(t[0], 0, true))))},
      {"log_softmax", {A({2, 3, 4})}, AG(ag::log_softmax(v[0], -1)), REF(sub(t[0], logsumexp(t[0], -1, true)))},
      // ---- matrix products ----
      {"matmul_2d", {A({3, 4}), A({4, 5})}, AG(ag::matmul(v[0], v[1])), REF(matmul(t[0], t[1]))},
      {"matmul_views", {A({3, 4}, 't'), A({4, 5}, 's')}, AG(ag::matmul(v[0], v[1])), REF(matmul(t[0], t[1]))},
      {"matmul_batched", {A({2, 3, 4}), A({4, 5})}, AG(ag::matmul(v[0], v[1])), REF(matmul(t[0], t[1]))},
      {"matmul_bcast", {A({2, 1, 3, 4}), A({3, 4, 2})}, AG(ag::matmul(v[0], v[1])), REF(matmul(t[0], t[1]))},
      {"matmul_dot", {A({4}), A({4})}, AG(ag::matmul(v[0], v[1])), REF(matmul(t[0], t[1]))},
      {"matmul_vec_mat", {A({4}), A({2, 4, 3})}, AG(ag::matmul(v[0], v[1])), REF(matmul(t[0], t[1]))},
      {"matmul_mat_vec", {A({2, 3, 4}), A({4})}, AG(ag::matmul(v[0], v[1])), REF(matmul(t[0], t[1]))},
      {"matmul_t_a", {A({4, 3}), A({4, 5})}, AG(ag::matmul_t(v[0], true, v[1], false)),
       REF(matmul_t(t[0], true, t[1], false))},
      {"matmul_t_b", {A({3, 4}), A({5, 4})}, AG(ag::matmul_t(v[0], false, v[1], true)),
       REF(matmul_t(t[0], false, t[1], true))},
      {"matmul_t_ab_batched", {A({2, 4, 3}), A({5, 4})}, AG(ag::matmul_t(v[0], true, v[1], true)),
       REF(matmul_t(t[0], true, t[1], true))},
      {"matmul_t_none_bcast", {A({3, 4}), A({2, 4, 2})}, AG(ag::matmul_t(v[0], false, v[1], false)),
       REF(matmul_t(t[0], false, t[1], false))},
      // ---- views and layout ----
      {"reshape", {A({2, 3, 4})}, AG(v[0].reshape({6, -1})), REF(t[0].reshape({6, -1}))},
      {"reshape_copy", {A({3, 4}, 't')}, AG(v[0].reshape({12})), REF(t[0].reshape({12}))},
      {"view", {A({2, 6})}, AG(v[0].view({3, 4})), REF(t[0].view({3, 4}))},
      {"transpose", {A({2, 3, 4})}, AG(v[0].transpose(0, 2)), REF(t[0].transpose(0, 2))},
      {"permute", {A({2, 3, 4})}, AG(v[0].permute({2, 0, 1})), REF(t[0].permute({2, 0, 1}))},
      {"slice_step", {A({5, 4})}, AG(v[0].slice(0, 1, 5, 2)), REF(t[0].slice(0, 1, 5, 2))},
      {"select", {A({3, 4})}, AG(v[0].select(1, 2)), REF(t[0].select(1, 2))},
      {"narrow", {A({3, 5}, 't')}, AG(v[0].narrow(1, 1, 2)), REF(t[0].narrow(1, 1, 2))},
      {"expand", {A({3, 1})}, AG(v[0].expand({2, 3, 4})), REF(t[0].expand({2, 3, 4}))},
      {"squeeze", {A({3, 1, 4})}, AG(v[0].squeeze(1)), REF(t[0].squeeze(1))},
      {"unsqueeze", {A({3, 4})}, AG(v[0].unsqueeze(0)), REF(t[0].unsqueeze(0))},
      {"flatten", {A({2, 3, 4})}, AG(v[0].flatten(1, 2)), REF(t[0].flatten(1, 2))},
      {"contiguous", {A({3, 4}, 't')}, AG(v[0].contiguous()), REF(t[0].contiguous())},
      // ---- joins ----
      {"concat0", {A({2, 3}), A({4, 3})}, AG(ag::concat({v[0], v[1]}, 0)), REF(concat({t[0], t[1]}, 0))},
      {"concat1_views", {A({3, 2}, 't'), A({3, 1})}, AG(ag::concat({v[0], v[1], v[0]}, -1)),
       REF(concat({t[0], t[1], t[0]}, -1))},
      {"stack", {A({2, 3}), A({2, 3}), A({2, 3})}, AG(ag::stack({v[0], v[1], v[2]}, 1)),
       REF(stack({t[0], t[1], t[2]}, 1))},
      {"split", {A({5, 3})}, AG(([&] { auto p = ag::split(v[0], {2, 3}, 0); return ag::concat({p[1] * 2.0, p[0]}, 0); })()),
       REF(([&] { auto p = split(t[0], {2, 3}, 0); return concat({mul(p[1], 2.0), p[0]}, 0); })())},
      {"chunk", {A({2, 7})}, AG(([&] { auto p = ag::chunk(v[0], 3, 1); return ag::concat({p[2], p[0], p[1]}, 1); })()),
       REF(([&] { auto p = chunk(t[0], 3, 1); return concat({p[2], p[0], p[1]}, 1); })())},
      // ---- indexing ----
      {"index_select0", {A({4, 3})}, AG(ag::index_select(v[0], 0, idx({2, 0, 2, 3}, {4}))),
       REF(index_select(t[0], 0, idx({2, 0, 2, 3}, {4})))},
      {"index_select1_t", {A({2, 3}, 't')}, AG(ag::index_select(v[0], 1, idx({1, 1, 0}, {3}))),
       REF(index_select(t[0], 1, idx({1, 1, 0}, {3})))},
      {"gather1", {A({3, 4})}, AG(ag::gather(v[0], 1, idx({0, 3, 3, 1, 2, 2}, {3, 2}))),
       REF(gather(t[0], 1, idx({0, 3, 3, 1, 2, 2}, {3, 2})))},
      {"gather0", {A({3, 2})}, AG(ag::gather(v[0], 0, idx({2, 0, 1, 1}, {2, 2}))),
       REF(gather(t[0], 0, idx({2, 0, 1, 1}, {2, 2})))},
      {"scatter_add", {A({3, 4}), A({3, 2})}, AG(ag::scatter_add(v[0], 1, idx({0, 3, 3, 3, 2, 0}, {3, 2}), v[1])),
       REF(scatter_add(t[0], 1, idx({0, 3, 3, 3, 2, 0}, {3, 2}), t[1]))},
      {"index_add", {A({4, 3}, 't'), A({3, 3})}, AG(ag::index_add(v[0], 0, idx({3, 0, 3}, {3}), v[1])),
       REF(index_add(t[0], 0, idx({3, 0, 3}, {3}), t[1]))},
      // ---- compositions ----
      {"shared_subexpr", {A({3, 4})}, AG(v[0] * v[0] + ag::exp(v[0]) * v[0]),
       REF(add(mul(t[0], t[0]), mul(exp(t[0]), t[0])))},
      {"mlp", {A({2, 3}), A({3, 4}), A({4})}, AG(ag::mean(ag::tanh(ag::matmul(v[0], v[1]) + v[2]), {1})),
       REF(mean(tanh(add(matmul(t[0], t[1]), t[2])), {1}))},
      // ---- size-0 dims ----
      {"zero_add", {A({0, 3}), A({3})}, AG(v[0] + v[1]), REF(add(t[0], t[1]))},
      {"zero_sum", {A({0, 3})}, AG(ag::sum(v[0], {0})), REF(sum(t[0], {0}))},
      {"zero_matmul_k", {A({3, 0}), A({0, 2})}, AG(ag::matmul(v[0], v[1])), REF(matmul(t[0], t[1]))},
      {"zero_concat", {A({0, 2}), A({3, 2})}, AG(ag::concat({v[0], v[1]}, 0)), REF(concat({t[0], t[1]}, 0))},
  };
}

void PrintTo(const Row& r, std::ostream* os) { *os << r.name; }

class AutogradOp : public ::testing::TestWithParam<Row> {};

TEST_P(AutogradOp, ForwardMatchesTensorOp) {
  const Row& row = GetParam();
  TV views;
  VV vars;
  uint64_t seed = 1;
  for (const In& in : row.inputs) {
    Tensor base = make_base(in, seed++).to(DType::f32);
    views.push_back(layout_view(base, in.layout));
    vars.push_back(layout_view(Variable(base, true), in.layout));
  }
  Tensor expect = row.ref(views);
  Variable got = row.op(vars);
  ASSERT_EQ(got.shape(), expect.shape()) << row.name;
  ASSERT_EQ(got.dtype(), DType::f32);
  EXPECT_TRUE(got.requires_grad()) << row.name << ": the result should be recorded on the tape";
  EXPECT_LE(max_abs_diff(got.data(), expect), 1e-5) << row.name;
}

TEST_P(AutogradOp, GradcheckFloat64) {
  const Row& row = GetParam();
  TV bases;
  uint64_t seed = 1;
  for (const In& in : row.inputs) bases.push_back(make_base(in, seed++));
  std::vector<char> layouts;
  for (const In& in : row.inputs) layouts.push_back(in.layout);
  auto f = [&](const VV& leaves) {
    VV xs;
    for (size_t i = 0; i < leaves.size(); ++i) xs.push_back(layout_view(leaves[i], layouts[i]));
    return row.op(xs);
  };
  ag::GradcheckResult r = ag::gradcheck(f, bases);
  EXPECT_TRUE(r.ok) << row.name << ": " << r.message;
  EXPECT_LT(r.max_abs_err, 1e-6) << row.name << ": " << r.message;
}

INSTANTIATE_TEST_SUITE_P(Table, AutogradOp, ::testing::ValuesIn(rows()),
                         [](const ::testing::TestParamInfo<Row>& info) { return info.param.name; });

// The table must cover every op: a row whose name is missing here fails the build of this list, not silently.
TEST(AutogradOpTable, NamesAreUniqueAndCoverAllFamilies) {
  std::vector<Row> rs = rows();
  std::set<std::string> names;
  for (const auto& r : rs) EXPECT_TRUE(names.insert(r.name).second) << "duplicate row " << r.name;
  for (const char* must : {"add_bcast", "sub_bcast", "mul_bcast", "div_bcast", "pow_tensor", "maximum_bcast",
                           "minimum_bcast", "where_bcast", "masked_fill", "exp", "log", "sqrt", "rsqrt", "tanh",
                           "sigmoid", "relu", "abs", "sin", "cos", "square", "reciprocal", "clamp", "sum_all",
                           "mean_all", "amax_all", "amin_dim", "logsumexp", "matmul_2d", "matmul_t_a", "reshape",
                           "transpose", "permute", "slice_step", "select", "narrow", "expand", "squeeze",
                           "unsqueeze", "flatten", "contiguous", "concat0", "stack", "split", "chunk",
                           "index_select0", "gather1", "softmax", "log_softmax", "scatter_add", "index_add", "sum_to"})
    EXPECT_TRUE(names.count(must)) << "missing row " << must;
}

}  // namespace
