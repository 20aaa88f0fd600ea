// vbb.cpp — the VBB encoder/decoder stacks (anchor MotionVAE), the reparameterisation and the name map to torch.
#include "models/text2bfm/vbb.h"

#include <string>

#include "autograd/ops_elementwise.h"
#include "autograd/ops_shape.h"
#include "autograd/ops_unary.h"

namespace t2m::text2bfm {
namespace {

[[noreturn]] void fail(const std::string& what) { throw Error("vbb: " + what); }

std::shared_ptr<nn::Conv1d> causal_conv(int64_t cin, int64_t cout, int64_t k, int64_t stride, Generator& gen) {
  nn::Conv1dOptions o;
  o.stride = stride;
  o.mode = nn::Conv1dPad::causal;
  return std::make_shared<nn::Conv1d>(cin, cout, k, o, gen);
}

}  // namespace

void VbbConfig::validate() const {
  auto pos = [](const char* name, int64_t v) {
    if (v < 1) fail(std::string(name) + " must be >= 1, got " + std::to_string(v));
  };
  pos("in_dim", in_dim);
  pos("width", width);
  pos("latent", latent);
  if (depth < 0) fail("depth must be >= 0, got " + std::to_string(depth));
  pos("growth", growth);
  pos("groups", groups);
  if (levels < 0 || levels > 6) fail("levels must be in 0..6, got " + std::to_string(levels));
  if (width % groups != 0)
    fail("width " + std::to_string(width) + " is not divisible by groups " + std::to_string(groups));
  if (!(dropout >= 0.0 && dropout < 1.0)) fail("dropout must be in [0, 1), got " + std::to_string(dropout));
}

VbbConfig VbbConfig::with_compression(int64_t factor, int64_t in_dim) {
  VbbConfig c;
  c.in_dim = in_dim;
  if (factor == 1) c.levels = 0;
  else if (factor == 4) c.levels = 2;
  else if (factor == 8) c.levels = 3;
  else if (factor == 16) c.levels = 4;
  else fail("compression must be 1, 4, 8 or 16, got " + std::to_string(factor));
  c.validate();
  return c;
}

ResStack::ResStack(const VbbConfig& cfg, bool reverse, Generator& gen) {
  std::vector<int64_t> dil(cfg.depth);
  int64_t d = 1;
  for (int64_t i = 0; i < cfg.depth; ++i, d *= cfg.growth) dil[reverse ? cfg.depth - 1 - i : i] = d;
  for (int64_t i = 0; i < cfg.depth; ++i)
    blocks_.push_back(register_module(
        std::to_string(i), std::make_shared<nn::ResConvBlock>(cfg.width, dil[i], gen, cfg.groups, cfg.dropout)));
}

ag::Variable ResStack::forward(const ag::Variable& x, Generator& gen) const {
  ag::Variable h = x;
  for (const auto& b : blocks_) h = b->forward(h, gen);
  return h;
}

VbbEncoder::VbbEncoder(const VbbConfig& cfg, Generator& gen) {
  cfg.validate();
  in_ = register_module("0", causal_conv(cfg.in_dim, cfg.width, 3, 1, gen));
  for (int64_t l = 0; l < cfg.levels; ++l) {
    down_.push_back(register_module(std::to_string(2 + 2 * l), causal_conv(cfg.width, cfg.width, 4, 2, gen)));
    res_.push_back(register_module(std::to_string(3 + 2 * l), std::make_shared<ResStack>(cfg, false, gen)));
  }
  out_ = register_module(std::to_string(2 + 2 * cfg.levels), causal_conv(cfg.width, 2 * cfg.latent, 3, 1, gen));
}

// x (B, in_dim, Tz) -> (B, 2*latent, Tz / 2^L)
ag::Variable VbbEncoder::forward(const ag::Variable& x, Generator& gen) const {
  ag::Variable h = ag::relu(in_->forward(x));
  for (size_t l = 0; l < down_.size(); ++l) h = res_[l]->forward(down_[l]->forward(h), gen);
  return out_->forward(h);
}

VbbDecoder::VbbDecoder(const VbbConfig& cfg, Generator& gen) {
  cfg.validate();
  const int64_t L = cfg.levels;
  in_ = register_module("0", causal_conv(cfg.latent, cfg.width, 3, 1, gen));
  for (int64_t l = 0; l < L; ++l) {
    res_.push_back(register_module(std::to_string(2 + 3 * l), std::make_shared<ResStack>(cfg, true, gen)));
    up_.push_back(register_module(std::to_string(3 + 3 * l), std::make_shared<nn::Upsample1d>(2)));
    up_conv_.push_back(register_module(std::to_string(4 + 3 * l), causal_conv(cfg.width, cfg.width, 3, 1, gen)));
  }
  post_ = register_module(std::to_string(2 + 3 * L), causal_conv(cfg.width, cfg.width, 3, 1, gen));
  out_ = register_module(std::to_string(4 + 3 * L), causal_conv(cfg.width, cfg.in_dim, 3, 1, gen));
}

// m (B, latent, Tm) -> (B, in_dim, Tm * 2^L)
ag::Variable VbbDecoder::forward(const ag::Variable& m, Generator& gen) const {
  ag::Variable h = ag::relu(in_->forward(m));
  for (size_t l = 0; l < res_.size(); ++l)
    h = up_conv_[l]->forward(up_[l]->forward(res_[l]->forward(h, gen)));
  return out_->forward(ag::relu(post_->forward(h)));
}

Vbb::Vbb(const VbbConfig& cfg, Generator& gen) : cfg_(cfg) {
  cfg_.validate();
  enc_ = register_module("enc", std::make_shared<VbbEncoder>(cfg_, gen));
  dec_ = register_module("dec", std::make_shared<VbbDecoder>(cfg_, gen));
}

// Text2BFM Eq 3: q_φ(m | z) = N(mu, diag(exp(logvar))).  z (B, Tz, in_dim) -> mu, logvar (B, latent, Tm)
VbbPosterior Vbb::encode(const ag::Variable& z, Generator& gen) const {
  if (!z.defined() || z.dim() != 3 || z.size(2) != cfg_.in_dim)
    fail("z must be (B, Tz, " + std::to_string(cfg_.in_dim) + "), got " +
         (z.defined() ? shape_str(z.shape()) : std::string("undefined")));
  const int64_t Tz = z.size(1), c = cfg_.compression();
  if (Tz < 1 || Tz % c != 0)
    fail("Tz = " + std::to_string(Tz) + " must be a positive multiple of the compression " + std::to_string(c));
  ag::Variable h = enc_->forward(ag::transpose(z, 1, 2), gen);
  return {ag::narrow(h, 1, 0, cfg_.latent), ag::narrow(h, 1, cfg_.latent, cfg_.latent)};
}

ag::Variable Vbb::reparameterize(const ag::Variable& mu, const ag::Variable& logvar, const Tensor& eps) {
  if (!eps.defined() || eps.shape() != mu.shape())
    fail("eps must have mu's shape " + shape_str(mu.shape()) + ", got " +
         (eps.defined() ? shape_str(eps.shape()) : std::string("undefined")));
  return ag::add(mu, ag::mul(ag::Variable(eps.to(mu.dtype())), ag::exp(ag::mul(logvar, 0.5))));
}

// Text2BFM Eq 4: ẑ = D_θ(m).  m (B, latent, Tm) -> (B, Tm * 2^L, in_dim)
ag::Variable Vbb::decode(const ag::Variable& m, Generator& gen) const {
  if (!m.defined() || m.dim() != 3 || m.size(1) != cfg_.latent || m.size(2) < 1)
    fail("m must be (B, " + std::to_string(cfg_.latent) + ", Tm), got " +
         (m.defined() ? shape_str(m.shape()) : std::string("undefined")));
  return ag::transpose(dec_->forward(m, gen), 1, 2);
}

VbbOutput Vbb::forward(const ag::Variable& z, Generator& gen) const {
  VbbPosterior q = encode(z, gen);
  Tensor eps = rand_normal(q.mu.shape(), gen, 0.0, 1.0, q.mu.dtype());
  ag::Variable m = reparameterize(q.mu, q.logvar, eps);
  return {decode(m, gen), q.mu, q.logvar, m};
}

VbbOutput Vbb::forward(const ag::Variable& z, const Tensor& eps, Generator& gen) const {
  VbbPosterior q = encode(z, gen);
  ag::Variable m = reparameterize(q.mu, q.logvar, eps);
  return {decode(m, gen), q.mu, q.logvar, m};
}

// Ours "enc.0.weight" -> torch "enc.0.conv.weight"; "enc.3.1.c1.bias" -> "enc.3.1.c1.conv.bias". Only the
// causal convs (top-level stack entries and the residual blocks' c1) sit inside torch's CausalConv1d wrapper.
std::string vbb_torch_name(const std::string& ours) {
  std::vector<std::string> parts;
  size_t start = 0;
  for (size_t i = 0; i <= ours.size(); ++i)
    if (i == ours.size() || ours[i] == '.') {
      parts.push_back(ours.substr(start, i - start));
      start = i + 1;
    }
  const size_t n = parts.size();
  const bool top_conv = n == 3 && (parts[0] == "enc" || parts[0] == "dec");
  const bool res_c1 = n == 5 && parts[3] == "c1";
  std::string out;
  for (size_t i = 0; i < n; ++i) {
    if (i) out += '.';
    if ((top_conv || res_c1) && i == n - 1) out += "conv.";
    out += parts[i];
  }
  return out;
}

}  // namespace t2m::text2bfm
