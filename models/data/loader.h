// loader.h — training batches of fixed-length feature windows with captions.
//
// A MotionClip holds one clip's raw (unnormalised) features [frames, kFeatureDim] and its labels. The loader
// walks the clips in epochs: every epoch visits every clip once, in an order shuffled by the seed and the epoch
// number; each visit is one batch item:
//   - window: W = cfg.window frames starting at a random frame in [0, frames - W] when frames >= W; a shorter
//     clip is taken whole from frame 0 and padded with zeros (mask 0) up to W;
//   - mirroring (cfg.mirror_prob): the window's features are mirrored in feature space (mirror_feature_rows) and
//     the caption's left/right words swapped;
//   - caption: clip.caption if set (e.g. composed "A, then B" clips), else make_caption(content, style, seed, k)
//     with k uniform in [0, cfg.paraphrases) (cfg.paraphrases == 0: k is any 32-bit value);
//   - normalisation with the FeatureStats given (train split only; see features_norm.h).
// Batch: x (B, W, D) float32, mask (B, W) float32 (1 = real frame, 0 = padding), plus per-item captions and
// bookkeeping. The last batch of an epoch is smaller unless cfg.drop_last.
// Determinism: the order is t2m::randperm (Fisher-Yates on Philox4x32-10, tensor/rng.h) with a Generator keyed by
// (seed, epoch), and each item's window/mirror/caption draws are Philox blocks keyed by (seed, epoch) at counter
// = position in the epoch: the same seed gives the same batches, the per-item choices do not depend on the batch
// size, and the only state is (epoch, position).
// Memory: the loader keeps a pointer to the clips (they must outlive it) and one scratch window; next() allocates
// only the output tensors.
// Errors: t2m::Error for an empty clip list, clips with frames < 1 or features not frames x kFeatureDim,
// batch_size < 1, window < 1, mirror_prob outside [0, 1], stats of the wrong dimension.
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "models/data/dataset.h"
#include "models/data/features_norm.h"
#include "models/data/splits.h"
#include "tensor/tensor.h"

namespace t2m::data {

struct MotionClip {
  std::string name;              // "dataset-2_walk_active_001" (or "A+B" for compositions)
  std::string content, style;    // labels used for captions (ignored when caption is set)
  std::string caption;           // fixed caption ("" = generate from the labels)
  int frames = 0;
  std::vector<float> features;   // [frames, kFeatureDim], raw (unnormalised)
};

struct LoaderConfig {
  int batch_size = 32;
  int window = 64;               // frames per item (30 fps: 64 frames = 2.1 s)
  double mirror_prob = 0.5;      // 0 disables mirroring augmentation
  int paraphrases = 0;           // 0: any caption; k > 0: one of the first k paraphrases of the clip
  uint64_t seed = 0;
  bool drop_last = false;
};

struct Batch {
  Tensor x;                      // (B, W, D) float32, normalised, zero in padding
  Tensor mask;                   // (B, W) float32, 1 = valid frame
  std::vector<std::string> captions;
  std::vector<int> clip;         // index into the clip list
  std::vector<int> start;        // first frame of the window in the clip
  std::vector<int> length;       // valid frames (<= W)
  std::vector<uint8_t> mirrored;
  int size() const { return (int)captions.size(); }
};

class MotionLoader {
 public:
  MotionLoader(const std::vector<MotionClip>* clips, const FeatureStats& stats, const LoaderConfig& cfg);
  int64_t batches_per_epoch() const;
  int64_t epoch() const { return epoch_; }
  // Starts (or restarts) epoch e: reshuffles, resets the position.
  void start_epoch(int64_t e);
  // Fills `out` with the next batch of the current epoch; false (out untouched) when the epoch is over.
  bool next(Batch& out);
  // The clip order of the current epoch.
  const std::vector<int>& order() const { return order_; }

 private:
  const std::vector<MotionClip>* clips_;
  FeatureStats stats_;
  LoaderConfig cfg_;
  int64_t epoch_ = 0;
  int64_t pos_ = 0;
  std::vector<int> order_;
  std::vector<float> scratch_;   // one window [W, D] for mirroring
};

// Philox4x32-10 bits for (seed, stream, counter): a pure function of its arguments.
void loader_random_bits(uint64_t seed, uint64_t stream, uint64_t counter, uint32_t out[4]);
// Permutation of 0..n-1: t2m::randperm with a Generator keyed by (seed, stream).
std::vector<int> shuffled_indices(int n, uint64_t seed, uint64_t stream);

// A clip from a motion: features computed with motion_to_features.
MotionClip make_motion_clip(const std::string& name, const std::string& content, const std::string& style,
                            const sim::Motion& m);
// Loads (load_clip + motion_to_features, OpenMP over clips) the manifest clips assigned to split `which`.
// Clips the split map does not list are skipped. threads <= 0: OpenMP default.
std::vector<MotionClip> load_split_clips(const Manifest& manifest, const std::map<std::string, Split>& splits,
                                         Split which, int threads = 0);
// Feature statistics over a clip list (use the train clips). with_mirrors: the mirrored features count too (the
// distribution the loader sees with mirror augmentation; makes mean/std left/right symmetric).
FeatureStats clip_feature_stats(const std::vector<MotionClip>& clips, bool with_mirrors = true,
                                double std_floor = kDefaultStdFloor);

}  // namespace t2m::data
