// go_diffuser_checkpoint.cpp — save/load of the go-diffuser bundle.
#include "models/promotion/go_diffuser_checkpoint.h"

#include "models/data/features.h"
#include "nn/checkpoint.h"

namespace t2m::promotion {

namespace {
const char* kFormat = "t2m-promotion-go-1";
}

void save_go_checkpoint(const GoBundle& b, const std::string& path) {
  nn::Checkpoint ck;
  ck.meta = {{"format", kFormat}, {"config", b.model->config().to_json()}, {"train", b.train}};
  b.model->save_to(ck, "model.");
  ck.put("feature_mean", Tensor::from_vector(b.stats.mean, {(int64_t)b.stats.mean.size()}));
  ck.put("feature_std", Tensor::from_vector(b.stats.std, {(int64_t)b.stats.std.size()}));
  ck.save(path);
}

GoBundle load_go_checkpoint(const std::string& path) {
  const nn::Checkpoint ck = nn::Checkpoint::load(path);
  if (ck.meta.value("format", std::string()) != kFormat)
    throw Error("go checkpoint " + path + ": not a go-diffuser file (format '" +
                ck.meta.value("format", std::string()) + "', expected " + kFormat + ")");
  if (!ck.meta.contains("config")) throw Error("go checkpoint " + path + ": meta has no config");
  const GoDiffuserConfig cfg = GoDiffuserConfig::from_json(ck.meta.at("config"));
  GoBundle b;
  Generator g(0);
  b.model = std::make_shared<GoDiffuser>(cfg, g);
  b.model->load_from(ck, "model.");
  b.model->eval();
  b.stats.mean = ck.expect("feature_mean", {data::kFeatureDim}, DType::f32).to_vector<float>();
  b.stats.std = ck.expect("feature_std", {data::kFeatureDim}, DType::f32).to_vector<float>();
  b.train = ck.meta.value("train", nlohmann::json::object());
  return b;
}

}  // namespace t2m::promotion
