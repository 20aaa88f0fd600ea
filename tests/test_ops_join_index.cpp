// test_ops_join_index.cpp — concat/stack/split/chunk and index_select/gather/scatter_add/index_add/masked_fill
// against naive loops, on several layouts and both float dtypes; bounds and shape errors.
#include "test_tensor_util.h"

using namespace t2m;
using namespace t2m::testing;

TEST(OpsJoin, ConcatAndStack) {
  for (DType dt : {DType::f32, DType::f64}) {
    Tensor a0 = random_tensor({2, 3, 4}, dt, 1), b0 = random_tensor({2, 1, 4}, dt, 2);
    Tensor e0 = Tensor::zeros({2, 0, 4}, dt);
    for (const Tensor& a : layouts(a0))
      for (const Tensor& b : layouts(b0)) {
        Tensor c = concat({a, e0, b, a}, 1);
        std::vector<double> want;
        for_each_index({2, 7, 4}, [&](const std::vector<int64_t>& i) {
          if (i[1] < 3) want.push_back(raw_get(a0, i));
          else if (i[1] == 3) want.push_back(raw_get(b0, {i[0], 0, i[2]}));
          else want.push_back(raw_get(a0, {i[0], i[1] - 4, i[2]}));
        });
        expect_values(c, {2, 7, 4}, want, 0);
        for (int64_t d : {0, 1, 3, -1}) {
          Tensor s = stack({a, a0}, d);
          const int64_t dd = d < 0 ? d + 4 : d;
          Shape ss = a0.shape();
          ss.insert(ss.begin() + dd, 2);
          std::vector<double> w;
          for_each_index(ss, [&](const std::vector<int64_t>& i) {
            auto j = i;
            j.erase(j.begin() + dd);
            w.push_back(raw_get(a0, j));
          });
          expect_values(s, ss, w, 0);
        }
      }
  }
  expect_values(concat({Tensor::arange(2, DType::i64), Tensor::arange(3, DType::i64)}, 0), {5}, {0, 1, 0, 1, 2}, 0);
  expect_error([&] { concat({}, 0); }, {"concat", "empty"});
  expect_error([&] { concat({Tensor::zeros({2, 3}), Tensor::zeros({3, 3})}, 1); }, {"concat", "[2, 3]", "[3, 3]"});
  expect_error([&] { concat({Tensor::zeros({2}), Tensor::zeros({2}, DType::f64)}, 0); }, {"concat", "f32", "f64"});
  expect_error([&] { concat({Tensor::zeros({2})}, 1); }, {"concat", "1"});
  expect_error([&] { stack({Tensor::zeros({2}), Tensor::zeros({3})}, 0); }, {"stack", "[2]", "[3]"});
}

TEST(OpsJoin, SplitAndChunkAreViews) {
  Tensor a = Tensor::arange(20, DType::f64).view({4, 5});
  auto parts = split(a, {2, 0, 3}, 1);
  ASSERT_EQ(parts.size(), 3u);
  EXPECT_TRUE(parts[0].shares_storage(a));
  expect_values(parts[0], {4, 2}, {0, 1, 5, 6, 10, 11, 15, 16}, 0);
  EXPECT_EQ(shape_str(parts[1].shape()), "[4, 0]");
  expect_values(parts[2], {4, 3}, {2, 3, 4, 7, 8, 9, 12, 13, 14, 17, 18, 19}, 0);
  auto ch = chunk(a, 2, -1);  // 5 -> 3 + 2
  ASSERT_EQ(ch.size(), 2u);
  EXPECT_EQ(ch[0].size(1), 3);
  EXPECT_EQ(ch[1].size(1), 2);
  EXPECT_EQ(ch[1].at({3, 1}), 19.0);
  EXPECT_EQ(chunk(a, 3, 0).size(), 2u);  // 4 -> 2 + 2 (torch returns fewer chunks)
  EXPECT_EQ(chunk(a, 10, 0).size(), 4u);
  // Round trip: concat of the chunks gives the input back.
  expect_values(concat(chunk(a.transpose(0, 1), 2, 0), 0), {5, 4}, raw_values(a.transpose(0, 1)), 0);
  expect_error([&] { split(a, {2, 2}, 1); }, {"split", "[2, 2]", "[4, 5]"});
  expect_error([&] { chunk(a, 0, 0); }, {"chunk", "0"});
}

TEST(OpsIndex, IndexSelect) {
  for (DType dt : {DType::f32, DType::f64, DType::i64}) {
    Tensor a0 = random_tensor({4, 3, 5}, dt, 3, -50, 50);
    Tensor idx = Tensor::from_vector(std::vector<int64_t>{2, 0, 2, 1}, {4});
    for (const Tensor& a : layouts(a0))
      for (int64_t d : {0, 1, 2}) {
        Tensor r = index_select(a, d, idx);
        Shape os = a0.shape();
        os[d] = 4;
        std::vector<double> w;
        for_each_index(os, [&](const std::vector<int64_t>& i) {
          auto j = i;
          j[d] = raw_get(idx, {i[d]});
          w.push_back(raw_get(a0, j));
        });
        expect_values(r, os, w, 0);
      }
    EXPECT_EQ(shape_str(index_select(a0, 1, Tensor::zeros({0}, DType::i64)).shape()), "[4, 0, 5]");
  }
  Tensor a = Tensor::zeros({3, 4});
  expect_error([&] { index_select(a, 1, Tensor::from_vector(std::vector<int64_t>{0, 4}, {2})); },
               {"index_select", "index 4", "size 4"});
  expect_error([&] { index_select(a, 0, Tensor::from_vector(std::vector<int64_t>{-1}, {1})); },
               {"index_select", "-1", "size 3"});
  expect_error([&] { index_select(a, 0, Tensor::zeros({2})); }, {"index_select", "int64", "f32"});
  expect_error([&] { index_select(a, 0, Tensor::zeros({1, 1}, DType::i64)); }, {"index_select", "[1, 1]"});
}

TEST(OpsIndex, GatherAndScatterAdd) {
  for (DType dt : {DType::f32, DType::f64}) {
    Tensor a0 = random_tensor({3, 4, 2}, dt, 4);
    for (int64_t d : {0, 1, 2}) {
      Shape is = {3, 5, 2};  // index shape: dim 1 bigger than the input's only when d == 1
      if (d != 1) is = {2, 3, 2};
      Tensor idx = random_tensor(is, DType::f64, 5 + (uint32_t)d, 0, (double)a0.shape()[d] - 0.01).to(DType::i64);
      for (const Tensor& a : layouts(a0)) {
        Tensor g = gather(a, d, idx);
        std::vector<double> w;
        for_each_index(is, [&](const std::vector<int64_t>& i) {
          auto j = i;
          j[d] = raw_get(idx, i);
          w.push_back(raw_get(a0, j));
        });
        expect_values(g, is, w, 0, "gather dim " + std::to_string(d));
        // scatter_add with src of the index shape; duplicates accumulate.
        Tensor src0 = random_tensor(is, dt, 6);
        for (const Tensor& src : layouts(src0)) {
          Tensor s = scatter_add(a, d, idx, src);
          std::vector<double> ref = raw_values(a0);
          for_each_index(is, [&](const std::vector<int64_t>& i) {
            auto j = i;
            j[d] = raw_get(idx, i);
            int64_t flat = 0;
            for (int64_t k = 0; k < 3; ++k) flat = flat * a0.shape()[k] + j[k];
            ref[flat] += raw_get(src0, i);
          });
          expect_values(s, a0.shape(), ref, tol_for(dt) * 4, "scatter_add dim " + std::to_string(d));
        }
      }
    }
  }
  Tensor a = Tensor::zeros({2, 3});
  Tensor bad = Tensor::from_vector(std::vector<int64_t>{0, 3}, {1, 2});
  expect_error([&] { gather(a, 1, bad); }, {"gather", "index 3", "size 3"});
  expect_error([&] { scatter_add(a, 1, bad, Tensor::ones({1, 2})); }, {"scatter_add", "index 3", "size 3"});
  expect_error([&] { gather(a, 1, Tensor::zeros({2}, DType::i64)); }, {"gather", "[2]", "[2, 3]"});
  expect_error([&] { scatter_add(a, 0, Tensor::zeros({2, 3}, DType::i64), Tensor::ones({1, 3})); },
               {"scatter_add", "[2, 3]", "[1, 3]"});
}

TEST(OpsIndex, IndexAddIsIndexSelectBackward) {
  for (DType dt : {DType::f32, DType::f64}) {
    Tensor a0 = random_tensor({3, 4, 2}, dt, 7);
    Tensor idx = Tensor::from_vector(std::vector<int64_t>{1, 3, 1, 0, 1}, {5});
    for (int64_t d : {0, 1, 2}) {
      if (d != 1) idx = Tensor::from_vector(std::vector<int64_t>{1, 0, 1}, {3});
      else idx = Tensor::from_vector(std::vector<int64_t>{1, 3, 1, 0, 1}, {5});
      Shape ss = a0.shape();
      ss[d] = idx.numel();
      Tensor src0 = random_tensor(ss, dt, 8);
      for (const Tensor& a : layouts(a0))
        for (const Tensor& src : layouts(src0)) {
          Tensor r = index_add(a, d, idx, src);
          std::vector<double> ref = raw_values(a0);
          for_each_index(ss, [&](const std::vector<int64_t>& i) {
            auto j = i;
            j[d] = raw_get(idx, {i[d]});
            int64_t flat = 0;
            for (int64_t k = 0; k < 3; ++k) flat = flat * a0.shape()[k] + j[k];
            ref[flat] += raw_get(src0, i);
          });
          expect_values(r, a0.shape(), ref, tol_for(dt) * 4, "index_add dim " + std::to_string(d));
        }
    }
  }
  Tensor a = Tensor::zeros({3, 2});
  expect_error([&] { index_add(a, 0, Tensor::from_vector(std::vector<int64_t>{3}, {1}), Tensor::ones({1, 2})); },
               {"index_add", "index 3", "size 3"});
  expect_error([&] { index_add(a, 0, Tensor::from_vector(std::vector<int64_t>{0}, {1}), Tensor::ones({2, 2})); },
               {"index_add", "[2, 2]", "[1, 2]"});
}

TEST(OpsIndex, MaskedFill) {
  for (DType dt : {DType::f32, DType::f64})
    for (DType mt : {DType::f32, DType::i64}) {
      Tensor a0 = random_tensor({3, 4}, dt, 9);
      Tensor mask = Tensor::from_vector(std::vector<double>{0, 1, 0, 1}, {4}).to(mt);
      for (const Tensor& a : layouts(a0)) {
        std::vector<double> w;
        for_each_index({3, 4}, [&](const std::vector<int64_t>& i) {
          w.push_back(i[1] % 2 ? -1e9 : raw_get(a0, i));
        });
        expect_values(masked_fill(a, mask, -1e9), {3, 4}, w, tol_for(dt));
      }
    }
  expect_error([&] { masked_fill(Tensor::zeros({3}), Tensor::zeros({2, 3}), 1.0); }, {"masked_fill", "[2, 3]", "[3]"});
}

TEST(OpsIndex, ExpandedStrideZeroInputs) {
  // Inputs with stride-0 dims (expand) go through every join/index op and give the materialised result.
  Tensor row = random_tensor({1, 4}, DType::f64, 11);
  Tensor e = row.expand({3, 4});
  Tensor m = e.contiguous();
  ASSERT_EQ(e.strides()[0], 0);
  Tensor idx = Tensor::from_vector(std::vector<int64_t>{3, 0}, {2});
  expect_values(index_select(e, 1, idx), {3, 2}, raw_values(index_select(m, 1, idx)), 0);
  Tensor gi = Tensor::from_vector(std::vector<int64_t>{1, 0, 2, 3, 3, 1}, {3, 2});
  expect_values(gather(e, 1, gi), {3, 2}, raw_values(gather(m, 1, gi)), 0);
  expect_values(concat({e, m}, 0), {6, 4}, raw_values(concat({m, m}, 0)), 0);
  Tensor mask = Tensor::from_vector(std::vector<int64_t>{1, 0, 0}, {3, 1}).expand({3, 4});
  expect_values(masked_fill(e, mask, 5.0), {3, 4}, raw_values(masked_fill(m, mask.contiguous(), 5.0)), 0);
  expect_values(index_add(e, 0, Tensor::from_vector(std::vector<int64_t>{2}, {1}), row), {3, 4},
                raw_values(index_add(m, 0, Tensor::from_vector(std::vector<int64_t>{2}, {1}), row)), 0);
  EXPECT_NEAR(raw_values(index_add(m, 0, Tensor::from_vector(std::vector<int64_t>{2}, {1}), row))[8],
              2 * raw_get(row, {0, 0}), 1e-15);
}
