// test_module.cpp — the Module registry: names, order, train/eval, save/load strictness, dtype conversion.
#include <gtest/gtest.h>

#include "nn/module.h"

using namespace t2m;
using t2m::nn::Checkpoint;
using t2m::nn::Module;

namespace {

struct Affine : Module {
  ag::Variable w, b;
  Affine(int64_t in, int64_t out) {
    w = register_parameter("weight", Tensor::full({out, in}, 0.5));
    b = register_parameter("bias", Tensor::zeros({out}));
  }
};

struct Net : Module {
  std::shared_ptr<Affine> l0, l1;
  ag::Variable scale;
  Net() {
    scale = register_parameter("scale", Tensor::ones({1}));
    l0 = register_module("l0", std::make_shared<Affine>(3, 4));
    l1 = register_module("l1", std::make_shared<Affine>(4, 2));
  }
};

template <typename F>
std::string error_of(F f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Module, NamesComposeInRegistrationOrder) {
  Net n;
  std::vector<std::string> names;
  for (auto& kv : n.named_parameters()) names.push_back(kv.first);
  EXPECT_EQ(names, (std::vector<std::string>{"scale", "l0.weight", "l0.bias", "l1.weight", "l1.bias"}));
  EXPECT_EQ(n.num_parameters(), 1 + 12 + 4 + 8 + 2);
  for (auto& v : n.parameters()) EXPECT_TRUE(v.requires_grad());
}

TEST(Module, HandlesShareStateWithTheRegistry) {
  Net n;
  n.parameters()[1].data().fill_(2.0);
  EXPECT_EQ(n.l0->w.data().at({0, 0}), 2.0);
}

TEST(Module, TrainEvalRecurses) {
  Net n;
  n.eval();
  EXPECT_FALSE(n.is_training());
  EXPECT_FALSE(n.l1->is_training());
  n.train();
  EXPECT_TRUE(n.l0->is_training());
}

TEST(Module, DuplicateAndBadNamesThrow) {
  struct Dup : Module {
    Dup() {
      register_parameter("w", Tensor::zeros({1}));
      register_parameter("w", Tensor::zeros({1}));
    }
  };
  EXPECT_NE(error_of([] { Dup d; }).find("duplicate name 'w'"), std::string::npos);
  struct Dotted : Module {
    Dotted() { register_parameter("a.b", Tensor::zeros({1})); }
  };
  EXPECT_NE(error_of([] { Dotted d; }).find("a.b"), std::string::npos);
}

TEST(Module, SaveLoadRoundTripAndStrictness) {
  Net a, b;
  a.l1->b.data().set({1}, 7.0);
  a.scale.data().fill_(3.0);
  Checkpoint ck;
  a.save_to(ck, "model.");
  ck.put("optim.step", Tensor::zeros({1}));  // other prefixes are ignored
  b.load_from(ck, "model.");
  EXPECT_EQ(b.l1->b.data().at({1}), 7.0);
  EXPECT_EQ(b.scale.data().item(), 3.0);

  Checkpoint missing;
  a.l0->save_to(missing, "model.l0.");
  std::string m = error_of([&] { b.load_from(missing, "model."); });
  EXPECT_NE(m.find("model.scale"), std::string::npos) << m;

  Checkpoint extra = ck;
  extra.put("model.l2.weight", Tensor::zeros({1}));
  m = error_of([&] { b.load_from(extra, "model."); });
  EXPECT_NE(m.find("unexpected tensor 'model.l2.weight'"), std::string::npos) << m;

  Checkpoint wrong = ck;
  wrong.put("model.l0.weight", Tensor::zeros({3, 4}));
  m = error_of([&] { b.load_from(wrong, "model."); });
  EXPECT_NE(m.find("model.l0.weight"), std::string::npos) << m;
  EXPECT_NE(m.find("[3, 4]"), std::string::npos) << m;
  EXPECT_NE(m.find("[4, 3]"), std::string::npos) << m;
}

TEST(Module, ToDoubleConvertsEveryParameter) {
  Net n;
  n.to(DType::f64);
  for (auto& v : n.parameters()) EXPECT_EQ(v.dtype(), DType::f64);
  EXPECT_EQ(n.l0->w.dtype(), DType::f64);  // member handles follow
}
