// test_ops_linalg.cpp — matmul / matmul_t against a naive double triple loop: 1-d cases, batching with
// broadcast (stride-0) batch dims, transposed / strided operands, empty dims, float and double, shape errors.
#include "test_tensor_util.h"

using namespace t2m;
using namespace t2m::testing;

namespace {

// Naive numpy-matmul reference on >= 1-d tensors (read through raw strides).
std::vector<double> ref_matmul(const Tensor& a, const Tensor& b, Shape& out_shape) {
  const Tensor a2 = a.dim() == 1 ? a.unsqueeze(0) : a;
  const Tensor b2 = b.dim() == 1 ? b.unsqueeze(1) : b;
  const int64_t M = a2.size(-2), K = a2.size(-1), N = b2.size(-1);
  const Shape ab(a2.shape().begin(), a2.shape().end() - 2), bb(b2.shape().begin(), b2.shape().end() - 2);
  const Shape batch = broadcast_shapes(ab, bb, "ref");
  out_shape = batch;
  if (a.dim() > 1) out_shape.push_back(M);
  if (b.dim() > 1) out_shape.push_back(N);
  std::vector<double> out;
  Shape full = batch;
  full.push_back(M);
  full.push_back(N);
  for_each_index(full, [&](const std::vector<int64_t>& i) {
    auto idx = [&](const Shape& tb, int64_t r, int64_t c) {
      std::vector<int64_t> j;
      for (size_t d = 0; d < tb.size(); ++d) j.push_back(tb[d] == 1 ? 0 : i[batch.size() - tb.size() + d]);
      j.push_back(r);
      j.push_back(c);
      return j;
    };
    double acc = 0;
    for (int64_t k = 0; k < K; ++k)
      acc += raw_get(a2, idx(ab, i[batch.size()], k)) * raw_get(b2, idx(bb, k, i[batch.size() + 1]));
    out.push_back(acc);
  });
  return out;
}

}  // namespace

TEST(OpsLinalg, MatmulShapesLayoutsDtypes) {
  const std::vector<std::pair<Shape, Shape>> cases = {
      {{5}, {5}},          {{3, 5}, {5, 4}},       {{5}, {5, 4}},          {{3, 5}, {5}},
      {{2, 3, 5}, {5, 4}}, {{5}, {2, 5, 4}},       {{2, 1, 3, 5}, {1, 4, 5, 6}}, {{4, 3, 5}, {4, 5, 2}},
      {{1, 5}, {5, 1}},    {{3, 1}, {1, 4}},       {{2, 3, 5}, {3, 1, 5, 2}},
  };
  uint32_t seed = 1;
  for (DType dt : {DType::f32, DType::f64})
    for (const auto& [sa, sb] : cases) {
      Tensor a0 = random_tensor(sa, dt, seed++), b0 = random_tensor(sb, dt, seed++);
      Shape os;
      const auto want = ref_matmul(a0, b0, os);
      for (const Tensor& a : layouts(a0))
        for (const Tensor& b : layouts(b0))
          expect_values(matmul(a, b), os, want, dt == DType::f32 ? 1e-5 : 1e-12,
                        shape_str(sa) + " x " + shape_str(sb));
    }
}

TEST(OpsLinalg, MatmulTransposeFlags) {
  for (DType dt : {DType::f32, DType::f64})
    for (bool ta : {false, true})
      for (bool tb : {false, true}) {
        // Stored shapes: a is [2, M, K] or [2, K, M]; b is [K, N] or [N, K].
        const int64_t M = 4, K = 6, N = 3;
        Tensor a0 = random_tensor(ta ? Shape{2, K, M} : Shape{2, M, K}, dt, 40 + ta);
        Tensor b0 = random_tensor(tb ? Shape{N, K} : Shape{K, N}, dt, 50 + tb);
        Shape os;
        const auto want = ref_matmul(ta ? a0.transpose(-1, -2) : a0, tb ? b0.transpose(-1, -2) : b0, os);
        EXPECT_EQ(shape_str(os), "[2, 4, 3]");
        for (const Tensor& a : layouts(a0))
          for (const Tensor& b : layouts(b0))
            expect_values(matmul_t(a, ta, b, tb), os, want, dt == DType::f32 ? 1e-5 : 1e-12);
      }
}

TEST(OpsLinalg, ExpandedAndSlicedOperands) {
  // A stride-0 expanded batch operand and a column-sliced operand (row stride > cols).
  Tensor w = random_tensor({1, 5, 3}, DType::f32, 60).expand({4, 5, 3});
  Tensor x = random_tensor({4, 2, 9}, DType::f32, 61).slice(2, 2, 7);  // [4, 2, 5], row stride 9
  Shape os;
  const auto want = ref_matmul(x, w, os);
  expect_values(matmul(x, w), os, want, 1e-5);
  // Every-other-column operand is neither row- nor column-major: copied internally.
  Tensor y = random_tensor({5, 8}, DType::f64, 62).slice(1, 0, 8, 2);  // [5, 4]
  Tensor z = random_tensor({3, 5}, DType::f64, 63);
  expect_values(matmul(z, y), {3, 4}, ref_matmul(z, y, os), 1e-12);
}

TEST(OpsLinalg, EmptyDims) {
  expect_values(matmul(Tensor::ones({3, 0}), Tensor::ones({0, 4})), {3, 4}, std::vector<double>(12, 0.0), 0);
  EXPECT_EQ(shape_str(matmul(Tensor::ones({0, 2}), Tensor::ones({2, 4})).shape()), "[0, 4]");
  EXPECT_EQ(shape_str(matmul(Tensor::ones({0, 2, 3}), Tensor::ones({3, 4})).shape()), "[0, 2, 4]");
  EXPECT_EQ(matmul(Tensor::ones({0}), Tensor::ones({0})).item(), 0.0);
}

TEST(OpsLinalg, Errors) {
  expect_error([&] { matmul(Tensor::zeros({2, 3}), Tensor::zeros({4, 5})); }, {"matmul", "[2, 3]", "[4, 5]"});
  expect_error([&] { matmul(Tensor::zeros({3}), Tensor::zeros({4})); }, {"matmul", "[3]", "[4]"});
  expect_error([&] { matmul(Tensor::zeros({2, 2, 3}), Tensor::zeros({3, 3, 4})); },
               {"matmul", "batch", "[2, 2, 3]", "[3, 3, 4]"});
  expect_error([&] { matmul(Tensor::zeros({2, 3}), Tensor::zeros({3, 4}, DType::f64)); }, {"matmul", "f32", "f64"});
  expect_error([&] { matmul(Tensor::scalar(1), Tensor::zeros({3})); }, {"matmul", "0-d"});
  expect_error([&] { matmul_t(Tensor::zeros({3}), true, Tensor::zeros({3, 2}), false); }, {"matmul_t", "[3]"});
  expect_error([&] { matmul_t(Tensor::zeros({2, 3}), true, Tensor::zeros({2, 3}), true); },
               {"matmul_t", "[2, 3]"});
}
