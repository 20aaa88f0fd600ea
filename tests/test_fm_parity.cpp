// test_fm_parity.cpp — the flow-matching generator against PyTorch (the anchor's FlowTransformer in
// ../shared/anchor/torch_ref.py): tests/fixtures/fm/fm_parity.t2mckpt (made by tests/fixtures/make_fm_fixture.py)
// holds two tiny configs with inputs, every parameter, the forward values, the Eq 15 loss and every parameter
// gradient. We load the weights by name, run the same training-step loss in float32 and require
// max|ours - torch| <= 1e-4 * max|torch| for every tensor (forward and backward). Our parameter names are the
// anchor's; the one name only we have (null_ctx, the CFG null condition) is not in the fixture and is checked to
// get no gradient when nothing is dropped. Also: a damaged fixture gives a clear error.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "autograd/variable.h"
#include "models/text2bfm/generator.h"
#include "nn/checkpoint.h"
#include "nn/loss_flow.h"
#include "tensor/ops.h"
#include "tensor/parallel.h"
#include "test_tensor_util.h"
#include "test_scratch_dir.h"

using namespace t2m;
using namespace t2m::text2bfm;

namespace {

const std::string kFixture = std::string(T2M_SOURCE_DIR) + "/tests/fixtures/fm/fm_parity.t2mckpt";

// max|a - b| / max|b|: the error relative to the tensor's scale (elementwise relative error is meaningless for
// entries near 0).
double rel_err(const Tensor& ours, const Tensor& ref) {
  const Tensor a = ours.to(DType::f64), b = ref.to(DType::f64);
  EXPECT_EQ(a.shape(), b.shape());
  const double scale = amax(abs(b)).item();
  return amax(abs(sub(a, b))).item() / std::max(scale, 1e-30);
}

FlowGeneratorConfig config_of(const nlohmann::json& c) {
  FlowGeneratorConfig f;
  f.latent = c["latent"], f.width = c["width"], f.depth = c["depth"], f.heads = c["heads"], f.ctx_dim = c["ctx_dim"];
  f.adapter = TextAdapterConfig{.tok_dim = c["tok_dim"], .width = c["ad_width"], .depth = c["ad_depth"],
                                .heads = c["ad_heads"], .ctx_dim = c["ctx_dim"], .max_len = 77};
  return f;
}

void check_case(const nn::Checkpoint& ck, const std::string& key, int threads) {
  set_num_threads(threads);
  const std::string p = key + ".";
  Generator g(1);
  FlowGenerator gen(config_of(ck.meta["cases"][key]["cfg"]), g);
  int loaded = 0;
  for (auto& [name, v] : gen.named_parameters()) {
    if (name == "null_ctx") continue;  // ours only
    v.data().copy_(ck.expect(p + "param." + name, v.shape(), DType::f32));
    ++loaded;
  }
  // every torch parameter was used: fixture names = ours minus null_ctx
  int in_fixture = 0;
  for (const auto& n : ck.names()) in_fixture += n.rfind(p + "param.", 0) == 0;
  EXPECT_EQ(loaded, in_fixture) << key;

  const Tensor x0 = ck.get(p + "in.x0"), x1 = ck.get(p + "in.x1"), t = ck.get(p + "in.t");
  ag::Variable tok(ck.get(p + "in.tok").clone(), true);
  const nn::FlowPoint fp = nn::flow_interpolate(ag::Variable(x0), ag::Variable(x1), ag::Variable(t));
  EXPECT_LE(rel_err(fp.x_t.data(), ck.get(p + "out.xt")), 1e-6) << key;
  const ag::Variable v = gen.forward(fp.x_t, t, tok);
  EXPECT_LE(rel_err(v.data(), ck.get(p + "out.v")), 1e-4) << key << " forward v";
  ag::Variable loss = nn::flow_matching_loss(v, ag::Variable(x0), ag::Variable(x1));
  EXPECT_LE(rel_err(loss.data().view({1}), ck.get(p + "out.loss")), 1e-5) << key << " loss";
  gen.zero_grad();
  loss.backward();
  EXPECT_LE(rel_err(tok.grad(), ck.get(p + "grad.tok")), 1e-4) << key << " grad.tok";
  double worst = 0;
  std::string worst_name;
  for (auto& [name, prm] : gen.named_parameters()) {
    if (name == "null_ctx") {
      EXPECT_TRUE(!prm.grad().defined() || amax(abs(prm.grad())).item() == 0.0);
      continue;
    }
    ASSERT_TRUE(prm.grad().defined()) << key << " " << name;
    const double e = rel_err(prm.grad(), ck.get(p + "grad." + name));
    EXPECT_LE(e, 1e-4) << key << " grad." << name;
    if (e > worst) worst = e, worst_name = name;
  }
  std::printf("[fm parity %s, %d thread(s)] worst parameter-gradient error %.2e (%s)\n", key.c_str(), threads, worst,
              worst_name.c_str());
}

}  // namespace

TEST(FmParity, ConfigWithInputProjectionMatchesTorch) {
  const nn::Checkpoint ck = nn::Checkpoint::load(kFixture);
  check_case(ck, "a", 1);
  check_case(ck, "a", 2);
}

TEST(FmParity, ConfigWithIdentityInputMatchesTorch) {
  const nn::Checkpoint ck = nn::Checkpoint::load(kFixture);
  check_case(ck, "b", 1);
  Generator g(1);
  FlowGenerator gen(config_of(ck.meta["cases"]["b"]["cfg"]), g);
  for (auto& [name, v] : gen.named_parameters()) EXPECT_NE(name.rfind("text.inp", 0), 0u) << name;
}

TEST(FmParity, DamagedFixtureGivesAClearError) {
  std::ifstream in(kFixture, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 1000u);
  const std::string path = (t2m::test::scratch_root() / "fm_parity_damaged.t2mckpt").string();
  std::string bad = bytes;
  bad[bytes.size() / 2] ^= 0x5a;
  std::ofstream(path, std::ios::binary) << bad;
  t2m::testing::expect_error([&] { nn::Checkpoint::load(path); }, {path, "checksum"});
  std::ofstream(path, std::ios::binary) << bytes.substr(0, bytes.size() - 100);
  t2m::testing::expect_error([&] { nn::Checkpoint::load(path); }, {path});
  // a fixture tensor of the wrong shape is named
  const nn::Checkpoint ck = nn::Checkpoint::load(kFixture);
  t2m::testing::expect_error([&] { ck.expect("a.param.x_in.weight", {3, 3}, DType::f32); }, {"a.param.x_in.weight"});
}
