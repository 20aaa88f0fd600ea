// retrieval_model.h — a text–motion retrieval pair (text encoder + motion encoder into one embedding space): the
// interface shared by the generator-side text encoder (models/text/text_motion_model.h) and the metric evaluator
// (models/eval/evaluator.h), its checkpoint format, and batched embedding of captions and motions.
//
// A RetrievalBundle is what a checkpoint holds: the model, its tokenizer (the vocabulary is part of the model),
// the feature statistics the motions are normalised with (train split), and the window (frames) it was trained on.
//
// Embedding (inference, no graph, model in eval mode), both L2-normalised (unit rows, the space InfoNCE trains):
//   embed_texts(bundle, texts)        captions -> (N, E) float32 (encode_captions with max_text_len()).
//   embed_motions(bundle, clips)      raw (unnormalised) features [T_i, F] -> (N, E) float32: the centred crop of
//                                     min(T_i, window) frames (start = (T_i - window) / 2), normalised with the
//                                     stats, right-padded with mask 0 to the longest crop of the batch.
//   Batches of `batch` rows; results do not depend on the batch size up to float rounding.
//
// Checkpoint (nn::Checkpoint, atomic): meta {"format": "t2m-retrieval-1", "kind": KIND, "config": {...},
// "window": W, "tokenizer": {...} (text/tokenizer.h), "train": {...} (free-form provenance)}; tensors
// "model." + parameter names, "feature_mean" (F,), "feature_std" (F,) float32.
// read_retrieval_checkpoint validates the format, the kind, the window, the tokenizer and the stats; the
// kind-specific loader then builds the model from "config" and loads "model." (Module::load_from checks names,
// shapes and extras).
// Errors (t2m::Error naming the checkpoint path): not a retrieval checkpoint, a different kind, missing or
// malformed meta fields, stats of the wrong dimension or with std <= 0, plus those of nn/checkpoint.h; in embed_*:
// an empty clip (0 frames), features not a multiple of F, an empty list.
#pragma once
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "autograd/variable.h"
#include "models/data/features_norm.h"
#include "models/text/tokenizer.h"
#include "nn/checkpoint.h"
#include "nn/module.h"

namespace t2m::text {

class RetrievalModel : public nn::Module {
 public:
  // ids (B, L) int64, mask (B, L) float -> (B, E) (not normalised).
  virtual ag::Variable embed_text(const Tensor& ids, const Tensor& mask) const = 0;
  // x (B, T, F) normalised features, mask (B, T) float -> (B, E) (not normalised).
  virtual ag::Variable embed_motion(const ag::Variable& x, const Tensor& mask) const = 0;
  virtual int64_t max_text_len() const = 0;
  virtual int64_t max_frames() const = 0;  // longest motion input
  virtual int64_t feature_dim() const = 0;
  virtual const char* kind() const = 0;  // checkpoint kind: "text_encoder", "evaluator"
  virtual nlohmann::json config_json() const = 0;
};

struct RetrievalBundle {
  std::shared_ptr<RetrievalModel> model;
  Tokenizer tokenizer;
  data::FeatureStats stats;
  int64_t window = 0;                               // training window (frames); embed_motions crops to it
  nlohmann::json train = nlohmann::json::object();  // provenance (command, seed, steps, data split)
};

void save_retrieval_checkpoint(const RetrievalBundle& b, const std::string& path);
nn::Checkpoint make_retrieval_checkpoint(const RetrievalBundle& b);

// Everything of the bundle except the model; ck is kept for the model's load_from.
struct RetrievalCheckpoint {
  nn::Checkpoint ck;
  nlohmann::json config;
  RetrievalBundle bundle;  // model left empty
};
RetrievalCheckpoint read_retrieval_checkpoint(const std::string& path, const std::string& kind);
RetrievalCheckpoint read_retrieval_checkpoint(nn::Checkpoint ck, const std::string& kind);

Tensor embed_texts(const RetrievalBundle& b, const std::vector<std::string>& texts, int64_t batch = 128);
Tensor embed_motions(const RetrievalBundle& b, const std::vector<const std::vector<float>*>& clips, int64_t batch = 64);

// tokenizer.encode_batch(texts, max_len) with ids and mask cut to the longest sequence of the batch (L = max
// length, at least 2): the encoders' outputs at real tokens do not depend on the padding length.
EncodedBatch encode_captions(const Tokenizer& tok, const std::vector<std::string>& texts, int64_t max_len);

// The centred crop [start, start + len) of a clip with `frames` frames for a window (len = min(frames, window)).
struct Crop {
  int64_t start = 0, len = 0;
};
Crop centre_crop(int64_t frames, int64_t window);

}  // namespace t2m::text
