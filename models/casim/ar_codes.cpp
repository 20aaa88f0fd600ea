// ar_codes.cpp — tokenizing a split (and its mirror) and the JSON cache.
#include "models/casim/ar_codes.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "models/data/features_mirror.h"
#include "nn/checkpoint.h"

namespace t2m::casim {

using json = nlohmann::json;

CodeSet build_code_set(const VqVae& vq, const data::FeatureStats& stats, const std::vector<data::MotionClip>& clips) {
  const int64_t D = vq.config().feature_dim, f = vq.config().downsample();
  CodeSet s;
  s.codes = vq.config().codebook.codes;
  for (const auto& c : clips) {
    const int64_t T = (c.frames / f) * f;
    if (T < f) continue;
    std::vector<float> x(c.features.begin(), c.features.begin() + T * D);
    for (int m = 0; m < 2; ++m) {
      std::vector<float> v = m ? data::mirror_features(x) : x;
      data::normalize_features(v, stats);
      CodeItem it{c.name, c.content, c.style, m == 1, vq.tokenize(Tensor::from_vector(v, {1, T, D})).to_vector<int64_t>()};
      s.items.push_back(std::move(it));
    }
  }
  return s;
}

void save_code_set(const CodeSet& s, const std::string& path) {
  json items = json::array();
  for (const auto& it : s.items)
    items.push_back({{"clip", it.clip}, {"content", it.content}, {"style", it.style}, {"mirrored", it.mirrored ? 1 : 0},
                     {"codes", it.codes}});
  const json j = {{"format", "t2m-casim-codes-1"}, {"vq_crc", s.vq_crc}, {"codes", s.codes}, {"items", items}};
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  nn::write_file_atomic(path, j.dump() + "\n");
}

CodeSet load_code_set(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error("code set " + path + ": cannot read");
  std::stringstream ss;
  ss << f.rdbuf();
  CodeSet s;
  try {
    const json j = json::parse(ss.str());
    if (j.at("format") != "t2m-casim-codes-1") throw Error("code set " + path + ": wrong format");
    s.vq_crc = j.at("vq_crc"), s.codes = j.at("codes");
    for (const auto& e : j.at("items")) {
      CodeItem it{e.at("clip"), e.at("content"), e.at("style"), e.at("mirrored").get<int>() != 0,
                  e.at("codes").get<std::vector<int64_t>>()};
      for (int64_t c : it.codes)
        if (c < 0 || c >= s.codes) throw Error("code set " + path + ": code " + std::to_string(c) + " out of range");
      s.items.push_back(std::move(it));
    }
  } catch (const json::exception& e) {
    throw Error("code set " + path + ": malformed (" + e.what() + ")");
  }
  return s;
}

CodeSet ensure_code_set(const std::string& path, uint32_t vq_crc, const std::function<CodeSet()>& make) {
  if (std::filesystem::exists(path)) {
    CodeSet s = load_code_set(path);
    if (s.vq_crc == vq_crc) return s;
  }
  CodeSet s = make();
  s.vq_crc = vq_crc;
  save_code_set(s, path);
  return s;
}

}  // namespace t2m::casim
