// evaluator.h — the metric evaluator: a second text–motion retrieval pair, independent of the generator-side
// text encoder (different architecture and seed), GRU-based as in Guo et al. 2022, used only by `t2m eval` for
// R-precision, FID, MM-Dist, Diversity and MultiModality (models/eval/metrics.h, protocol.h).
//
// Text:   ids (B, L) -> word embedding (V, W) -> bidirectional GRU (hidden H_t each way, padding-aware: the
//         backward direction starts at each sentence's last real token) -> [h_fwd_last, h_bwd_last] (B, 2 H_t)
//         -> e_text = out2(relu(out1([h_f, h_b]))), out1 Linear(2 H_t, H_t), out2 Linear(H_t, E)  (B, E).
// Motion: x (B, T, F), mask (B, T) -> patches of `patch` frames (models/text/motion_encoder.h patchify)
//         -> relu(Linear(patch F, H_m)) (the movement encoder) -> bidirectional GRU (hidden H_m each way) ->
//         e_motion = out2(relu(out1([h_f, h_b]))) (B, E).
// Parameters (in order): text_emb.weight, text_gru_f.*, text_gru_b.*, text_out1.*, text_out2.*, motion_move.*,
// motion_gru_f.*, motion_gru_b.*, motion_out1.*, motion_out2.*.
// Checkpoint kind "evaluator" (models/text/retrieval_model.h).
// Errors (t2m::Error "Evaluator: ..."): config sizes < 1; ids not (B, L) int64 or L > max_len, masks not
// matching, a row without a real token / frame, more than max_frames frames; load_evaluator: those of
// read_retrieval_checkpoint and Module::load_from.
#pragma once
#include <memory>

#include "models/text/retrieval_model.h"
#include "nn/embedding.h"
#include "nn/gru.h"
#include "nn/linear.h"

namespace t2m::eval {

struct EvaluatorConfig {
  int64_t vocab = 0;
  int64_t word_dim = 128;
  int64_t text_hidden = 128;
  int64_t max_len = 32;
  int64_t feature_dim = 257;
  int64_t patch = 4;
  int64_t motion_hidden = 192;
  int64_t max_frames = 256;
  int64_t embed_dim = 256;

  nlohmann::json to_json() const;
  static EvaluatorConfig from_json(const nlohmann::json& j);
  void validate() const;
};

class Evaluator : public text::RetrievalModel {
 public:
  Evaluator(const EvaluatorConfig& cfg, Generator& gen);
  ag::Variable embed_text(const Tensor& ids, const Tensor& mask) const override;
  ag::Variable embed_motion(const ag::Variable& x, const Tensor& mask) const override;
  int64_t max_text_len() const override { return cfg_.max_len; }
  int64_t max_frames() const override { return cfg_.max_frames; }
  int64_t feature_dim() const override { return cfg_.feature_dim; }
  const char* kind() const override { return "evaluator"; }
  nlohmann::json config_json() const override { return cfg_.to_json(); }
  const EvaluatorConfig& config() const { return cfg_; }

 private:
  EvaluatorConfig cfg_;
  std::shared_ptr<nn::Embedding> emb_;
  std::shared_ptr<nn::GRU> tgf_, tgb_, mgf_, mgb_;
  std::shared_ptr<nn::Linear> tout1_, tout2_, move_, mout1_, mout2_;
};

text::RetrievalBundle load_evaluator(const std::string& path);

}  // namespace t2m::eval
