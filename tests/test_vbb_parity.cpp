// test_vbb_parity.cpp — the VBB against PyTorch: tests/fixtures/vbb/vae_parity.t2mckpt (written once by
// tests/fixtures/make_vae_fixture.py from the anchor's own MotionVAE, tiny config, eval mode, fixed noise) holds
// the input, noise, every parameter, the outputs, the loss and every gradient. We load the weights by name
// (vbb_torch_name), run forward + the anchor's loss (MSE + 1e-4 KL) + backward in float32 and require relative
// error <= 1e-4 (max |ours - torch| / max |torch| per tensor) on every output and gradient. No Python needed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include "autograd/ops_elementwise.h"
#include "models/text2bfm/vbb.h"
#include "models/text2bfm/vbb_loss.h"
#include "nn/checkpoint.h"
#include "nn/loss_regression.h"
#include "tensor/ops.h"
#include "test_tensor_util.h"

using namespace t2m;
using namespace t2m::text2bfm;
using t2m::testing::expect_error;

namespace {

const std::string kFixture = std::string(T2M_SOURCE_DIR) + "/tests/fixtures/vbb/vae_parity.t2mckpt";

double rel_err(const Tensor& ours, const Tensor& ref) {
  EXPECT_EQ(ours.shape(), ref.shape());
  if (ours.shape() != ref.shape()) return 1e30;
  const double scale = std::max(max_abs_diff(ref, Tensor::zeros(ref.shape())), 1e-30);
  return max_abs_diff(ours.to(DType::f32), ref) / scale;
}

VbbConfig config_of(const nn::Checkpoint& ck) {
  const auto& c = ck.meta.at("config");
  VbbConfig cfg;
  cfg.in_dim = c.at("in_dim");
  cfg.width = c.at("width");
  cfg.latent = c.at("latent");
  cfg.levels = c.at("levels");
  cfg.depth = c.at("depth");
  cfg.growth = c.at("growth");
  cfg.groups = c.at("groups");
  cfg.dropout = c.at("dropout");
  return cfg;
}

}  // namespace

TEST(VbbParity, ForwardAndBackwardMatchPyTorch) {
  nn::Checkpoint ck = nn::Checkpoint::load(kFixture);
  VbbConfig cfg = config_of(ck);
  Generator g(1);
  Vbb vbb(cfg, g);
  vbb.eval();  // the fixture ran torch in eval mode: dropout off
  // Every parameter by its torch name; every torch parameter is used (no extra or missing names).
  std::set<std::string> torch_params;
  for (const auto& n : ck.names())
    if (n.rfind("param.", 0) == 0) torch_params.insert(n.substr(6));
  ASSERT_EQ(torch_params.size(), vbb.named_parameters().size());
  for (auto& [name, p] : vbb.named_parameters()) {
    const std::string tn = vbb_torch_name(name);
    ASSERT_TRUE(torch_params.count(tn)) << name << " -> " << tn;
    p.data().copy_(ck.expect("param." + tn, p.shape(), DType::f32));
  }
  const Tensor& x = ck.get("in.x");
  ag::Variable xv(x.clone(), true);
  VbbOutput o = vbb.forward(xv, ck.get("in.eps"), g);
  // As in the fixture, x is also the MSE target, so d loss / d x has the target path too.
  ag::Variable loss = ag::add(nn::mse_loss(o.z_hat, xv), ag::mul(vbb_prior_kl(o.mu, o.logvar), 1e-4));
  loss.backward();

  EXPECT_LE(rel_err(o.z_hat.data(), ck.get("out.rec")), 1e-4);
  EXPECT_LE(rel_err(o.mu.data(), ck.get("out.mu")), 1e-4);
  EXPECT_LE(rel_err(o.logvar.data(), ck.get("out.logvar")), 1e-4);
  EXPECT_LE(rel_err(loss.data().reshape({1}), ck.get("out.loss")), 1e-4);
  EXPECT_LE(rel_err(xv.grad(), ck.get("grad.x")), 1e-4);
  double worst = 0;
  std::string worst_name;
  for (auto& [name, p] : vbb.named_parameters()) {
    const double e = rel_err(p.grad(), ck.get("grad." + vbb_torch_name(name)));
    EXPECT_LE(e, 1e-4) << name;
    if (e > worst) worst = e, worst_name = name;
  }
  std::printf("parity: loss ours %.7f torch %.7f, worst gradient rel err %.2e (%s)\n", loss.item(),
              ck.get("out.loss").item(), worst, worst_name.c_str());
}

// The fixture is guarded by the checkpoint format: a truncated or corrupted copy fails with a clear error.
TEST(VbbParity, DamagedFixtureIsRejected) {
  std::ifstream in(kFixture, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 1000u);
  const auto dir = std::filesystem::temp_directory_path();
  const std::string cut = (dir / "vbb_parity_cut.t2mckpt").string(), flip = (dir / "vbb_parity_flip.t2mckpt").string();
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x40;
  std::ofstream(flip, std::ios::binary) << flipped;
  expect_error([&] { nn::Checkpoint::load(cut); }, {"checkpoint", "truncated"});
  expect_error([&] { nn::Checkpoint::load(flip); }, {"checkpoint", "checksum"});
  std::filesystem::remove(cut);
  std::filesystem::remove(flip);
}
