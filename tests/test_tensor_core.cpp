// test_tensor_core.cpp — Tensor creation, metadata, views (shared storage, strides), copies and their errors.
#include "test_tensor_util.h"

using namespace t2m;
using namespace t2m::testing;

TEST(TensorCore, CreationAndMetadata) {
  Tensor z = Tensor::zeros({2, 3});
  EXPECT_TRUE(z.defined());
  EXPECT_FALSE(Tensor().defined());
  EXPECT_EQ(z.dtype(), DType::f32);
  EXPECT_EQ(z.numel(), 6);
  EXPECT_EQ(z.dim(), 2);
  EXPECT_EQ(z.size(-1), 3);
  EXPECT_EQ(shape_str(z.strides()), "[3, 1]");
  EXPECT_TRUE(z.is_contiguous());
  expect_values(z, {2, 3}, std::vector<double>(6, 0.0), 0);
  expect_values(Tensor::ones({2}, DType::f64), {2}, {1, 1}, 0);
  expect_values(Tensor::full({3}, -2.5, DType::f64), {3}, {-2.5, -2.5, -2.5}, 0);
  Tensor s = Tensor::scalar(4.0);
  EXPECT_EQ(s.dim(), 0);
  EXPECT_EQ(s.numel(), 1);
  EXPECT_EQ(s.item(), 4.0);
  expect_values(Tensor::arange(4, DType::i64), {4}, {0, 1, 2, 3}, 0);
  expect_values(Tensor::from_vector(std::vector<int64_t>{5, -6}, {2, 1}), {2, 1}, {5, -6}, 0);
  EXPECT_EQ(dtype_size(DType::f32), 4u);
  EXPECT_EQ(dtype_size(DType::i64), 8u);
  EXPECT_STREQ(dtype_name(DType::f64), "f64");
  // Size-0 tensors are valid, with a valid storage.
  Tensor e = Tensor::empty({0, 5});
  EXPECT_TRUE(e.defined());
  EXPECT_EQ(e.numel(), 0);
  EXPECT_TRUE(e.is_contiguous());
  EXPECT_EQ(e.to_vector<float>().size(), 0u);
  // Storage is 64-byte aligned.
  for (int n : {1, 3, 17, 1000}) EXPECT_EQ(reinterpret_cast<uintptr_t>(Tensor::empty({n}).data<float>()) % 64, 0u);
}

TEST(TensorCore, AtSetItemToVector) {
  Tensor t = Tensor::zeros({2, 3}, DType::f64);
  t.set({1, 2}, 7.5);
  t.set({0, -1}, 1.5);
  EXPECT_EQ(t.at({1, 2}), 7.5);
  EXPECT_EQ(t.at({0, 2}), 1.5);
  EXPECT_EQ(t.to_vector<double>(), (std::vector<double>{0, 0, 1.5, 0, 0, 7.5}));
  EXPECT_EQ(t.to_vector<float>(), (std::vector<float>{0, 0, 1.5f, 0, 0, 7.5f}));
  EXPECT_EQ(t.transpose(0, 1).to_vector<double>(), (std::vector<double>{0, 0, 0, 0, 1.5, 7.5}));
  expect_error([&] { t.at({2, 0}); }, {"at", "2", "size 2"});
  expect_error([&] { t.at({0}); }, {"at", "[2, 3]"});
  expect_error([&] { t.item(); }, {"item", "[2, 3]"});
  expect_error([&] { t.data<float>(); }, {"data", "f64", "f32"});
}

TEST(TensorCore, ViewsShareStorage) {
  Tensor a = Tensor::arange(24, DType::f64).view({2, 3, 4});
  Tensor t = a.transpose(0, 2);  // [4, 3, 2]
  EXPECT_TRUE(t.shares_storage(a));
  EXPECT_EQ(shape_str(t.shape()), "[4, 3, 2]");
  EXPECT_FALSE(t.is_contiguous());
  EXPECT_EQ(t.at({3, 1, 1}), a.at({1, 1, 3}));
  Tensor p = a.permute({1, 2, 0});
  EXPECT_EQ(p.at({2, 3, 1}), a.at({1, 2, 3}));
  Tensor sl = a.slice(2, 1, 4, 2);  // indices 1, 3
  EXPECT_EQ(shape_str(sl.shape()), "[2, 3, 2]");
  EXPECT_EQ(sl.at({1, 2, 1}), a.at({1, 2, 3}));
  EXPECT_EQ(a.slice(1, -2, 100).size(1), 2);  // clamps, negative start
  EXPECT_EQ(a.slice(1, 2, 1).size(1), 0);     // empty
  Tensor se = a.select(1, -1);
  EXPECT_EQ(shape_str(se.shape()), "[2, 4]");
  EXPECT_EQ(se.at({1, 0}), a.at({1, 2, 0}));
  Tensor n = a.narrow(2, 1, 2);
  EXPECT_EQ(n.at({0, 0, 1}), a.at({0, 0, 2}));
  // Writing through a view changes the parent.
  sl.set({0, 0, 0}, -1.0);
  EXPECT_EQ(a.at({0, 0, 1}), -1.0);
  // unsqueeze / squeeze / flatten
  Tensor u = a.unsqueeze(1);
  EXPECT_EQ(shape_str(u.shape()), "[2, 1, 3, 4]");
  EXPECT_EQ(shape_str(a.unsqueeze(-1).shape()), "[2, 3, 4, 1]");
  EXPECT_EQ(shape_str(u.squeeze(1).shape()), "[2, 3, 4]");
  EXPECT_EQ(shape_str(a.squeeze(0).shape()), "[2, 3, 4]");  // size != 1: unchanged
  EXPECT_EQ(shape_str(a.flatten(1).shape()), "[2, 12]");
  EXPECT_EQ(shape_str(a.flatten().shape()), "[24]");
  EXPECT_EQ(shape_str(Tensor::scalar(1).flatten().shape()), "[1]");
}

TEST(TensorCore, ExpandGivesStrideZero) {
  Tensor a = Tensor::from_vector(std::vector<float>{1, 2, 3}, {3, 1});
  Tensor e = a.expand({2, 3, 4});
  EXPECT_EQ(shape_str(e.strides()), "[0, 1, 0]");
  EXPECT_TRUE(e.shares_storage(a));
  EXPECT_EQ(e.at({1, 2, 3}), 3.0);
  EXPECT_EQ(shape_str(a.expand({-1, 5}).shape()), "[3, 5]");
  Tensor c = e.contiguous();
  EXPECT_FALSE(c.shares_storage(a));
  EXPECT_EQ(c.to_vector<float>()[4], 2.0f);
  expect_error([&] { a.expand({4, 4}); }, {"expand", "[3, 1]", "[4, 4]"});
  expect_error([&] { a.expand({4}); }, {"expand"});
}

TEST(TensorCore, ViewAndReshape) {
  Tensor a = Tensor::arange(12, DType::f64).view({3, 4});
  EXPECT_EQ(shape_str(a.view({2, -1}).shape()), "[2, 6]");
  EXPECT_TRUE(a.view({4, 3}).shares_storage(a));
  // A column slice keeps rows contiguous inside: [3, 2] -> [3, 2, 1] / [3, 1, 2] views work.
  Tensor s = a.slice(1, 0, 2);
  Tensor v = s.view({3, 1, 2});
  EXPECT_TRUE(v.shares_storage(a));
  EXPECT_EQ(v.at({2, 0, 1}), 9.0);
  // Transposed [4, 3] cannot be flattened as a view; reshape copies.
  Tensor t = a.transpose(0, 1);
  expect_error([&] { t.view({12}); }, {"view", "[4, 3]", "[12]"});
  Tensor r = t.reshape({12});
  EXPECT_FALSE(r.shares_storage(a));
  expect_values(r, {12}, {0, 4, 8, 1, 5, 9, 2, 6, 10, 3, 7, 11}, 0);
  // Splitting a strided dim is a view: [4, 3] (strides [1, 4]) -> [2, 2, 3].
  Tensor w = t.view({2, 2, 3});
  EXPECT_TRUE(w.shares_storage(a));
  EXPECT_EQ(w.at({1, 0, 2}), a.at({2, 2}));
  // Every layout, every reshape: values follow row-major order.
  Tensor base = random_tensor({2, 3, 4}, DType::f32, 3);
  const auto want = raw_values(base);
  for (const Tensor& x : layouts(base)) {
    expect_values(x.reshape({4, 6}), {4, 6}, want, 0);
    expect_values(x.reshape({-1}), {24}, want, 0);
    expect_values(x.flatten(0, 1), {6, 4}, want, 0);
  }
  expect_error([&] { a.view({5, -1}); }, {"view", "[3, 4]", "[5, -1]"});
  expect_error([&] { a.view({-1, -1}); }, {"view", "-1"});
  expect_error([&] { a.reshape({7}); }, {"reshape", "[3, 4]", "[7]"});
  EXPECT_EQ(shape_str(Tensor::zeros({0, 4}).reshape({-1, 2}).shape()), "[0, 2]");
}

TEST(TensorCore, CopiesAndConversion) {
  Tensor a = random_tensor({3, 5}, DType::f64, 9);
  const auto want = raw_values(a);
  for (const Tensor& x : layouts(a)) {
    Tensor c = x.clone();
    EXPECT_TRUE(c.is_contiguous());
    EXPECT_FALSE(c.shares_storage(x));
    expect_values(c, {3, 5}, want, 0);
    Tensor f = x.to(DType::f32);
    EXPECT_EQ(f.dtype(), DType::f32);
    expect_values(f, {3, 5}, want, 1e-7);
    expect_values(x.contiguous(), {3, 5}, want, 0);
  }
  EXPECT_TRUE(a.contiguous().shares_storage(a));
  EXPECT_TRUE(a.to(DType::f64).shares_storage(a));
  // copy_ with broadcast and conversion into a non-contiguous destination.
  Tensor dst = Tensor::zeros({5, 3}, DType::f32).transpose(0, 1);  // [3, 5]
  dst.copy_(Tensor::from_vector(std::vector<double>{1, 2, 3, 4, 5}, {5}));
  expect_values(dst, {3, 5}, {1, 2, 3, 4, 5, 1, 2, 3, 4, 5, 1, 2, 3, 4, 5}, 0);
  // Overlapping copy_ (a transpose of itself) reads the old values.
  Tensor sq = Tensor::arange(4, DType::f64).view({2, 2});
  sq.copy_(sq.transpose(0, 1));
  expect_values(sq, {2, 2}, {0, 2, 1, 3}, 0);
  // fill_ on a strided view touches only the view.
  Tensor g = Tensor::zeros({2, 4}, DType::i64);
  Tensor col = g.slice(1, 0, 4, 2);
  col.fill_(3);
  expect_values(g, {2, 4}, {3, 0, 3, 0, 3, 0, 3, 0}, 0);
  Tensor fl = Tensor::from_vector(std::vector<double>{2.7, -2.7}, {2}).to(DType::i64);
  expect_values(fl, {2}, {2, -2}, 0);
  expect_error([&] { dst.copy_(Tensor::zeros({4})); }, {"copy_", "[4]", "[3, 5]"});
}

TEST(TensorCore, BadArguments) {
  Tensor a = Tensor::zeros({2, 3});
  expect_error([&] { Tensor::zeros({2, -1}); }, {"empty", "[2, -1]"});
  expect_error([&] { Tensor::from_vector(std::vector<float>{1, 2, 3}, {2, 2}); }, {"from_vector", "[2, 2]"});
  expect_error([&] { a.transpose(0, 2); }, {"transpose", "2"});
  expect_error([&] { a.permute({0, 0}); }, {"permute", "repeated"});
  expect_error([&] { a.permute({0}); }, {"permute", "[2, 3]"});
  expect_error([&] { a.select(1, 3); }, {"select", "3", "size 3"});
  expect_error([&] { a.narrow(1, 2, 2); }, {"narrow", "size 3"});
  expect_error([&] { a.slice(0, 0, 2, 0); }, {"slice", "step"});
  expect_error([&] { a.unsqueeze(4); }, {"unsqueeze", "4"});
  expect_error([&] { a.flatten(1, 0); }, {"flatten"});
  expect_error([&] { a.size(2); }, {"size", "2"});
  expect_error([&] { Tensor::arange(-1); }, {"arange", "-1"});
  expect_error([&] { broadcast_shapes({2, 3}, {4}, "myop"); }, {"myop", "[2, 3]", "[4]"});
  expect_error([&] { wrap_dim(-4, 3, "myop"); }, {"myop", "-4"});
  EXPECT_EQ(wrap_dim(-1, 3, "x"), 2);
  EXPECT_EQ(shape_str(broadcast_shapes({2, 1, 4}, {3, 1}, "x")), "[2, 3, 4]");
  EXPECT_EQ(shape_str(broadcast_shapes({}, {0}, "x")), "[0]");
  EXPECT_EQ(shape_str(contiguous_strides({2, 0, 3})), "[3, 3, 1]");
  EXPECT_EQ(shape_numel({}), 1);
}

TEST(TensorCore, LargeTransposedCopiesTiled) {
  // Transposed layouts big enough for the tiled copy path (odd sizes: partial tiles), batched, converting,
  // and above the parallel grain.
  for (const Shape& s : std::vector<Shape>{{3, 70, 45}, {2, 300, 129}, {17, 16}}) {
    Tensor a = random_tensor(s, DType::f64, 31);
    Tensor t = a.transpose(-1, -2);
    const auto want = raw_values(t);
    Shape ts = t.shape();
    expect_values(t.contiguous(), ts, want, 0);
    expect_values(t.to(DType::f32), ts, want, 1e-7);
    Tensor dst = Tensor::zeros(ts, DType::f64);
    dst.copy_(t);
    expect_values(dst, ts, want, 0);
  }
  // Broadcast batch dim (stride 0) on a transposed source.
  Tensor m = random_tensor({40, 33}, DType::f32, 32);
  Tensor e = m.transpose(0, 1).unsqueeze(0).expand({3, 33, 40});
  Tensor c = e.contiguous();
  for_each_index({3, 33, 40}, [&](const std::vector<int64_t>& i) {
    ASSERT_EQ(raw_get(c, i), raw_get(m, {i[2], i[1]}));
  });
}

TEST(TensorCore, ViewStridesPropertyOverLayouts) {
  // For many layouts (permutes, slices, size-1 dims) and target shapes: whenever view succeeds it must share
  // storage and show the row-major values; reshape must always give them.
  Tensor base = random_tensor({4, 1, 6, 2}, DType::f64, 33);
  std::vector<Tensor> srcs;
  for (const auto& perm : std::vector<std::vector<int64_t>>{{0, 1, 2, 3}, {2, 1, 0, 3}, {0, 2, 1, 3}, {3, 2, 1, 0}})
    srcs.push_back(base.permute(perm));
  srcs.push_back(base.slice(2, 0, 6, 2));
  srcs.push_back(base.slice(0, 1, 3));
  srcs.push_back(base.slice(3, 0, 1));
  int views = 0;
  for (const Tensor& s : srcs) {
    const auto want = raw_values(s);
    const int64_t n = s.numel();
    for (const Shape& target : std::vector<Shape>{{n}, {1, n}, {n, 1}, {2, -1}, {-1, 2}, {2, 1, -1, 1},
                                                  {s.size(0), -1}, {-1, s.size(-1)}, {s.size(0), s.size(1), -1}}) {
      if (n % 2 && (target == Shape{2, -1} || target == Shape{-1, 2} || target == Shape{2, 1, -1, 1})) continue;
      Tensor r = s.reshape(target);
      expect_values(r, r.shape(), want, 0, shape_str(s.shape()) + " -> " + shape_str(target));
      try {
        Tensor v = s.view(target);
        ++views;
        EXPECT_TRUE(v.shares_storage(s));
        expect_values(v, v.shape(), want, 0, "view " + shape_str(s.shape()) + " -> " + shape_str(target));
      } catch (const Error&) {
        EXPECT_FALSE(s.is_contiguous()) << "a contiguous tensor can always be viewed";
      }
    }
  }
  EXPECT_GT(views, 20);
}
