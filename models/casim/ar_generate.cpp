// ar_generate.cpp — loading the three frozen parts and decoding sampled codes to raw features.
#include "models/casim/ar_generate.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

namespace t2m::casim {

namespace {

std::string need(const std::string& path, const std::string& how) {
  if (!std::filesystem::is_regular_file(path)) throw Error("casim ar: missing " + path + " (make it with `" + how + "`)");
  return path;
}

}  // namespace

ArGenerator::ArGenerator(const std::string& dir, ArCond cond) {
  const std::string c = ar_cond_name(cond);
  ar_path_ = need(dir + "/casim_ar_" + c + ".t2mckpt", "t2m train casim --variant ar-" + c);
  const std::string vq_path = need(dir + "/casim_vq.t2mckpt", "t2m train casim --variant vq");
  text_ = std::make_unique<ArTextEncoder>(need(dir + "/text_encoder.t2mckpt", "t2m train text"));
  vq_ = load_vq(vq_path);
  ar_ = load_ar(ar_path_);
  if (ar_.model->config().cond != cond) throw Error("casim ar: " + ar_path_ + " is not an ar-" + c + " model");
  if (ar_.vq_crc != file_crc(vq_path))
    throw Error("casim ar: " + ar_path_ + " was trained on another tokenizer than " + vq_path +
                " (retrain it with `t2m train casim --variant ar-" + c + "`)");
}

int64_t ArGenerator::tokens_for_seconds(double seconds) const {
  const double t = std::round(seconds * 30.0 / (double)vq_.model->config().downsample());
  return std::clamp<int64_t>((int64_t)t, 1, ar_.model->config().max_motion);
}

std::vector<std::vector<float>> ArGenerator::generate(const std::vector<std::string>& captions,
                                                      const ArSampleOptions& opt, Generator& gen) const {
  const auto codes = sample_codes(*ar_.model, text_->encode(captions), opt, gen);
  std::vector<std::vector<float>> out;
  for (const auto& c : codes) {
    std::vector<float> f = vq_.model->detokenize(Tensor::from_vector(c, {1, (int64_t)c.size()})).to_vector<float>();
    data::denormalize_features(f, vq_.stats);
    out.push_back(std::move(f));
  }
  return out;
}

}  // namespace t2m::casim
