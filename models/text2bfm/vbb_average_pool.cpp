// vbb_average_pool.cpp — the hand-set weights of the average-pooling VBB (see vbb_average_pool.h).
#include "models/text2bfm/vbb_average_pool.h"

#include <map>
#include <string>

#include "autograd/no_grad.h"

namespace t2m::text2bfm {
namespace {

[[noreturn]] void fail(const std::string& m) { throw Error("vbb average pool: " + m); }

// A zero conv weight (cout, cin, k) with w[o][i][tap] = v for each (o, i, v).
struct ConvSetter {
  std::map<std::string, ag::Variable> params;
  void zero(const std::string& conv) {
    for (const char* p : {".weight", ".bias"}) params.at(conv + p).data().fill_(0.0);
  }
  void set(const std::string& conv, int64_t o, int64_t i, int64_t tap, float v) {
    Tensor& w = params.at(conv + ".weight").data();
    const int64_t cin = w.size(1), k = w.size(2);
    w.data<float>()[(o * cin + i) * k + tap] = v;
  }
};

}  // namespace

std::unique_ptr<Vbb> make_average_pooling_vbb(int64_t in_dim, int64_t compression, int64_t width) {
  if (in_dim < 1) fail("in_dim must be >= 1, got " + std::to_string(in_dim));
  if (compression != 1 && compression != 4 && compression != 8 && compression != 16)
    fail("compression must be 1, 4, 8 or 16, got " + std::to_string(compression));
  VbbConfig cfg = VbbConfig::with_compression(compression, in_dim);
  if (width < 2 * in_dim || width % cfg.groups != 0)
    fail("width must be >= 2 in_dim = " + std::to_string(2 * in_dim) + " and a multiple of " +
         std::to_string(cfg.groups) + ", got " + std::to_string(width));
  cfg.width = width;
  cfg.latent = in_dim;
  cfg.depth = 0;
  cfg.dropout = 0.0;
  Generator gen(0);
  auto vbb = std::make_unique<Vbb>(cfg, gen);
  init_vbb_as_average_pooling(*vbb);
  vbb->eval();
  return vbb;
}

void init_vbb_as_average_pooling(Vbb& vbb) {
  const VbbConfig& cfg = vbb.config();
  if (cfg.latent != cfg.in_dim)
    fail("latent " + std::to_string(cfg.latent) + " must equal in_dim " + std::to_string(cfg.in_dim));
  if (cfg.width < 2 * cfg.in_dim)
    fail("width must be >= 2 in_dim = " + std::to_string(2 * cfg.in_dim) + ", got " + std::to_string(cfg.width));
  ag::NoGradGuard ng;
  ConvSetter s;
  for (auto& [name, v] : vbb.named_parameters()) {
    if (!v.data().is_contiguous() || v.data().dtype() != DType::f32) fail("parameter " + name + " is not f32 contiguous");
    s.params.emplace(name, v);
    if (name.size() > 9 && name.compare(name.size() - 9, 9, "c2.weight") == 0) v.data().fill_(0.0);
    if (name.size() > 7 && name.compare(name.size() - 7, 7, "c2.bias") == 0) v.data().fill_(0.0);
  }
  const int64_t d = cfg.in_dim, L = cfg.levels;
  const int64_t last3 = 2;  // the current frame's tap of a causal k3 conv
  // Encoder: enc.0 z -> [z, −z] (then ReLU), enc.{2+2l} mean of taps 2, 3 (frames 2j, 2j+1), enc.{2+2L} -> mu, logvar.
  s.zero("enc.0");
  for (int64_t k = 0; k < d; ++k) {
    s.set("enc.0", k, k, last3, 1.f);
    s.set("enc.0", d + k, k, last3, -1.f);
  }
  for (int64_t l = 0; l < L; ++l) {
    const std::string c = "enc." + std::to_string(2 + 2 * l);
    s.zero(c);
    for (int64_t o = 0; o < 2 * d; ++o) {
      s.set(c, o, o, 2, 0.5f);
      s.set(c, o, o, 3, 0.5f);
    }
  }
  const std::string eo = "enc." + std::to_string(2 + 2 * L);
  s.zero(eo);
  for (int64_t k = 0; k < d; ++k) {
    s.set(eo, k, k, last3, 1.f);
    s.set(eo, k, d + k, last3, -1.f);
  }
  s.params.at(eo + ".bias").data().narrow(0, d, d).fill_(-30.0);
  // Decoder: dec.0 m -> [m, −m] (ReLU), identities through the upsampling convs and dec.{2+3L}, dec.{4+3L} subtracts.
  s.zero("dec.0");
  for (int64_t k = 0; k < d; ++k) {
    s.set("dec.0", k, k, last3, 1.f);
    s.set("dec.0", d + k, k, last3, -1.f);
  }
  std::vector<std::string> ident;
  for (int64_t l = 0; l < L; ++l) ident.push_back("dec." + std::to_string(4 + 3 * l));
  ident.push_back("dec." + std::to_string(2 + 3 * L));
  for (const auto& c : ident) {
    s.zero(c);
    for (int64_t o = 0; o < 2 * d; ++o) s.set(c, o, o, last3, 1.f);
  }
  const std::string dout = "dec." + std::to_string(4 + 3 * L);
  s.zero(dout);
  for (int64_t k = 0; k < d; ++k) {
    s.set(dout, k, k, last3, 1.f);
    s.set(dout, k, d + k, last3, -1.f);
  }
}

}  // namespace t2m::text2bfm
