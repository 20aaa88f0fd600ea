// ar_checkpoint.cpp — save/load of the tokenizer and GPT files.
#include "models/casim/ar_checkpoint.h"

#include <fstream>
#include <iterator>

#include "nn/checkpoint.h"

namespace t2m::casim {

namespace {

nn::Checkpoint read_kind(const std::string& path, const char* format) {
  nn::Checkpoint ck = nn::Checkpoint::load(path);
  if (!ck.meta.contains("format") || ck.meta["format"] != format || !ck.meta.contains("config"))
    throw Error("checkpoint " + path + ": not a " + format + " file (format " +
                (ck.meta.contains("format") ? ck.meta["format"].dump() : std::string("missing")) + ")");
  return ck;
}

}  // namespace

void save_vq(const VqBundle& b, const std::string& path) {
  nn::Checkpoint ck;
  ck.meta = {{"format", "t2m-casim-vq-1"}, {"config", b.model->config().to_json()}, {"train", b.train}};
  b.model->save_to(ck, "model.");
  const int64_t D = (int64_t)b.stats.mean.size();
  ck.put("feature_mean", Tensor::from_vector(b.stats.mean, {D}));
  ck.put("feature_std", Tensor::from_vector(b.stats.std, {D}));
  ck.save(path);
}

VqBundle load_vq(const std::string& path) {
  const nn::Checkpoint ck = read_kind(path, "t2m-casim-vq-1");
  VqBundle b;
  const VqVaeConfig cfg = VqVaeConfig::from_json(ck.meta["config"]);
  Generator g(0);
  b.model = std::make_shared<VqVae>(cfg, g);
  b.model->load_from(ck, "model.");
  b.model->eval();
  b.stats.mean = ck.expect("feature_mean", {cfg.feature_dim}, DType::f32).to_vector<float>();
  b.stats.std = ck.expect("feature_std", {cfg.feature_dim}, DType::f32).to_vector<float>();
  if (ck.meta.contains("train")) b.train = ck.meta["train"];
  return b;
}

void save_ar(const ArBundle& b, const std::string& path) {
  nn::Checkpoint ck;
  ck.meta = {{"format", "t2m-casim-ar-1"}, {"config", b.model->config().to_json()}, {"vq_crc", b.vq_crc},
             {"train", b.train}};
  b.model->save_to(ck, "model.");
  ck.save(path);
}

ArBundle load_ar(const std::string& path) {
  const nn::Checkpoint ck = read_kind(path, "t2m-casim-ar-1");
  ArBundle b;
  Generator g(0);
  b.model = std::make_shared<ArGpt>(ArGptConfig::from_json(ck.meta["config"]), g);
  b.model->load_from(ck, "model.");
  b.model->eval();
  b.vq_crc = ck.meta.value("vq_crc", 0u);
  if (ck.meta.contains("train")) b.train = ck.meta["train"];
  return b;
}

uint32_t file_crc(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error("cannot read " + path);
  const std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  return nn::crc32c(bytes.data(), bytes.size());
}

}  // namespace t2m::casim
