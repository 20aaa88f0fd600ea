// loader.cpp — epoch order, per-item window / mirror / caption draws, batch assembly into Tensors.
#include "models/data/loader.h"

#include <omp.h>

#include <algorithm>
#include <cstring>

#include "models/data/captions.h"
#include "models/data/features.h"
#include "models/data/features_mirror.h"
#include "tensor/rng.h"

namespace t2m::data {

namespace {
// The Philox key of a (seed, stream) pair.
uint64_t stream_key(uint64_t seed, uint64_t stream) { return seed + stream * 0x9e3779b97f4a7c15ull; }
}  // namespace

void loader_random_bits(uint64_t seed, uint64_t stream, uint64_t counter, uint32_t out[4]) {
  philox4x32(stream_key(seed, stream), counter, out);
}

std::vector<int> shuffled_indices(int n, uint64_t seed, uint64_t stream) {
  if (n < 0) throw Error("shuffled_indices: n must be >= 0, got " + std::to_string(n));
  Generator gen(stream_key(seed, stream));
  std::vector<int64_t> p = randperm(n, gen);  // the project RNG: Fisher-Yates on Philox draws
  return std::vector<int>(p.begin(), p.end());
}

MotionLoader::MotionLoader(const std::vector<MotionClip>* clips, const FeatureStats& stats, const LoaderConfig& cfg)
    : clips_(clips), stats_(stats), cfg_(cfg) {
  if (!clips || clips->empty()) throw Error("MotionLoader: empty clip list");
  if (cfg.batch_size < 1) throw Error("MotionLoader: batch_size must be >= 1, got " + std::to_string(cfg.batch_size));
  if (cfg.window < 1) throw Error("MotionLoader: window must be >= 1, got " + std::to_string(cfg.window));
  if (!(cfg.mirror_prob >= 0.0 && cfg.mirror_prob <= 1.0))
    throw Error("MotionLoader: mirror_prob must be in [0, 1], got " + std::to_string(cfg.mirror_prob));
  if (cfg.paraphrases < 0) throw Error("MotionLoader: paraphrases must be >= 0, got " + std::to_string(cfg.paraphrases));
  if (stats.dim() != kFeatureDim || stats.std.size() != stats.mean.size())
    throw Error("MotionLoader: feature stats have dim " + std::to_string(stats.dim()) + ", expected " +
                std::to_string(kFeatureDim));
  for (size_t i = 0; i < clips->size(); ++i) {
    const auto& c = (*clips)[i];
    if (c.frames < 1 || c.features.size() != (size_t)c.frames * kFeatureDim)
      throw Error("MotionLoader: clip " + std::to_string(i) + " '" + c.name + "' has " + std::to_string(c.frames) +
                  " frames and " + std::to_string(c.features.size()) + " feature floats (need frames x " +
                  std::to_string(kFeatureDim) + ", frames >= 1)");
    if (c.caption.empty()) {
      caption_content(c.content);  // throws early on labels without captions
      caption_style(c.style);
    }
  }
  scratch_.resize((size_t)cfg.window * kFeatureDim);
  start_epoch(0);
}

int64_t MotionLoader::batches_per_epoch() const {
  const int64_t n = (int64_t)clips_->size(), b = cfg_.batch_size;
  return cfg_.drop_last ? n / b : (n + b - 1) / b;
}

void MotionLoader::start_epoch(int64_t e) {
  epoch_ = e;
  pos_ = 0;
  order_ = shuffled_indices((int)clips_->size(), cfg_.seed, 2 * (uint64_t)e);
}

bool MotionLoader::next(Batch& out) {
  const int64_t n = (int64_t)clips_->size();
  int64_t B = std::min<int64_t>(cfg_.batch_size, n - pos_);
  if (B <= 0 || (cfg_.drop_last && B < cfg_.batch_size)) return false;
  const int W = cfg_.window, D = kFeatureDim;
  out.x = Tensor::zeros({B, W, D}, DType::f32);
  out.mask = Tensor::zeros({B, W}, DType::f32);
  out.captions.assign(B, "");
  out.clip.assign(B, 0);
  out.start.assign(B, 0);
  out.length.assign(B, 0);
  out.mirrored.assign(B, 0);
  float* X = out.x.data<float>();
  float* M = out.mask.data<float>();
  for (int64_t b = 0; b < B; ++b) {
    const int64_t position = pos_ + b;
    const int ci = order_[position];
    const MotionClip& c = (*clips_)[ci];
    uint32_t r[4];
    loader_random_bits(cfg_.seed, 2 * (uint64_t)epoch_ + 1, (uint64_t)position, r);
    const int len = std::min(c.frames, W);
    const int start = c.frames > W ? (int)(r[0] % (uint32_t)(c.frames - W + 1)) : 0;
    const bool mirrored = cfg_.mirror_prob > 0 && (r[1] * 0x1.0p-32) < cfg_.mirror_prob;
    const float* src = c.features.data() + (size_t)start * D;
    if (mirrored) {
      mirror_feature_rows(src, scratch_.data(), len);
      src = scratch_.data();
    }
    float* dst = X + (size_t)b * W * D;
    for (int t = 0; t < len; ++t)
      for (int d = 0; d < D; ++d) dst[(size_t)t * D + d] = (src[(size_t)t * D + d] - stats_.mean[d]) / stats_.std[d];
    for (int t = 0; t < len; ++t) M[b * W + t] = 1.0f;
    std::string cap;
    if (!c.caption.empty()) {
      cap = mirrored ? swap_left_right(c.caption) : c.caption;
    } else {
      const uint64_t k = cfg_.paraphrases > 0 ? r[2] % (uint32_t)cfg_.paraphrases : r[2];
      cap = make_caption(c.content, c.style, cfg_.seed, k, mirrored).text;
    }
    out.captions[b] = std::move(cap);
    out.clip[b] = ci;
    out.start[b] = start;
    out.length[b] = len;
    out.mirrored[b] = mirrored;
  }
  pos_ += B;
  return true;
}

MotionClip make_motion_clip(const std::string& name, const std::string& content, const std::string& style,
                            const sim::Motion& m) {
  MotionClip c;
  c.name = name;
  c.content = content;
  c.style = style;
  c.frames = m.frames;
  c.features = motion_to_features(m);
  return c;
}

std::vector<MotionClip> load_split_clips(const Manifest& manifest, const std::map<std::string, Split>& splits,
                                         Split which, int threads) {
  std::vector<const ClipInfo*> chosen;
  for (const auto& c : manifest.clips) {
    auto it = splits.find(c.name);
    if (it != splits.end() && it->second == which) chosen.push_back(&c);
  }
  std::vector<MotionClip> out(chosen.size());
  std::vector<std::string> errors(chosen.size());
  const int nt = threads > 0 ? threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 4) num_threads(nt)
  for (int64_t i = 0; i < (int64_t)chosen.size(); ++i) {
    try {
      const ClipInfo& ci = *chosen[i];
      out[i] = make_motion_clip(ci.name, ci.content_label, ci.style_label, load_clip(ci));
    } catch (const std::exception& e) {
      errors[i] = e.what();
    }
  }
  for (size_t i = 0; i < errors.size(); ++i)
    if (!errors[i].empty()) throw Error("load_split_clips: clip '" + chosen[i]->name + "': " + errors[i]);
  return out;
}

FeatureStats clip_feature_stats(const std::vector<MotionClip>& clips, bool with_mirrors, double std_floor) {
  std::vector<const std::vector<float>*> v;
  std::vector<std::vector<float>> mirrors;
  if (with_mirrors) mirrors.reserve(clips.size());
  for (const auto& c : clips) {
    v.push_back(&c.features);
    if (with_mirrors) {
      mirrors.push_back(mirror_features(c.features));
      v.push_back(&mirrors.back());
    }
  }
  return compute_feature_stats(v, kFeatureDim, std_floor);
}

}  // namespace t2m::data
