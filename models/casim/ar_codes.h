// ar_codes.h — the motion-token sequences of a split, made once with the frozen tokenizer and cached, which the
// GPT trains on (the "code sequences of the train split" of T2M-GPT's second stage).
//
// build_code_set(vq, stats, clips): for every clip (frames trimmed to a multiple of 4; clips shorter than 4 frames
// are skipped) the normalised features are tokenized whole, and so is their left/right mirror (mirror_features;
// its caption is made with mirrored = true): 2 sequences per clip.
// File (JSON, atomic): {"format": "t2m-casim-codes-1", "vq_crc": CRC-32C of the tokenizer file, "codes": K,
//   "items": [{"clip": name, "content", "style", "mirrored": 0/1, "codes": [...]}, ...]}.
// ensure_code_set(path, vq_crc, make): loads the file when its vq_crc matches, else calls make() and writes it.
// Errors (t2m::Error naming the path): unreadable or malformed file, wrong format; a code outside [0, codes).
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "models/casim/vq_vae.h"
#include "models/data/features_norm.h"
#include "models/data/loader.h"

namespace t2m::casim {

struct CodeItem {
  std::string clip, content, style;
  bool mirrored = false;
  std::vector<int64_t> codes;
};

struct CodeSet {
  uint32_t vq_crc = 0;
  int64_t codes = 0;  // K
  std::vector<CodeItem> items;
};

CodeSet build_code_set(const VqVae& vq, const data::FeatureStats& stats, const std::vector<data::MotionClip>& clips);
void save_code_set(const CodeSet& s, const std::string& path);
CodeSet load_code_set(const std::string& path);
CodeSet ensure_code_set(const std::string& path, uint32_t vq_crc, const std::function<CodeSet()>& make);

}  // namespace t2m::casim
