// diffusion_checkpoint.cpp — save/load of the CASIM-MDM bundle.
#include "models/casim/diffusion_checkpoint.h"

#include "nn/checkpoint.h"

namespace t2m::casim {

using json = nlohmann::json;

void save_diffusion_checkpoint(const DiffusionBundle& b, const std::string& path) {
  if (!b.model) throw Error("casim diffusion checkpoint " + path + ": no model");
  const int64_t F = b.model->config().feature_dim;
  if (b.stats.dim() != F) throw Error("casim diffusion checkpoint " + path + ": feature stats of the wrong size");
  nn::Checkpoint ck;
  ck.meta = {{"format", "t2m-casim-diff-1"},
             {"config", b.model->config().to_json()},
             {"window", b.window},
             {"sampler", {{"steps", b.sampler.steps}, {"eta", b.sampler.eta}, {"guidance", b.sampler.guidance}}},
             {"train", b.train}};
  b.model->save_to(ck, "model.");
  ck.put("feature_mean", Tensor::from_vector(b.stats.mean, {F}));
  ck.put("feature_std", Tensor::from_vector(b.stats.std, {F}));
  ck.save(path);
}

DiffusionBundle load_diffusion_checkpoint(const std::string& path) {
  const nn::Checkpoint ck = nn::Checkpoint::load(path);
  const std::string who = "casim diffusion checkpoint " + path;
  if (!ck.meta.is_object() || ck.meta.value("format", "") != "t2m-casim-diff-1")
    throw Error(who + ": not a CASIM diffusion checkpoint (format t2m-casim-diff-1)");
  DiffusionBundle b;
  DenoiserConfig cfg;
  try {
    cfg = DenoiserConfig::from_json(ck.meta.at("config"));
    b.window = ck.meta.at("window").get<int64_t>();
    const json& s = ck.meta.at("sampler");
    b.sampler.steps = s.at("steps").get<int64_t>();
    b.sampler.eta = s.at("eta").get<double>();
    b.sampler.guidance = s.at("guidance").get<double>();
    b.train = ck.meta.value("train", json::object());
  } catch (const json::exception& e) {
    throw Error(who + ": malformed meta: " + e.what());
  } catch (const Error& e) {
    throw Error(who + ": " + e.what());
  }
  if (b.window < 1 || b.sampler.steps < 1) throw Error(who + ": window and sampler steps must be >= 1");
  const int64_t F = cfg.feature_dim;
  const Tensor m = ck.expect("feature_mean", {F}, DType::f32).contiguous();
  const Tensor sd = ck.expect("feature_std", {F}, DType::f32).contiguous();
  b.stats.mean.assign(m.data<float>(), m.data<float>() + F);
  b.stats.std.assign(sd.data<float>(), sd.data<float>() + F);
  for (float v : b.stats.std)
    if (!(v > 0)) throw Error(who + ": feature_std has a value <= 0");
  Generator g(0);
  b.model = std::make_shared<CasimDenoiser>(cfg, g);
  b.model->load_from(ck, "model.");
  b.model->eval();
  return b;
}

}  // namespace t2m::casim
