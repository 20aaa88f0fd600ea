// text_motion_model.h — the generator-side retrieval pair (TMR-style): TextEncoder (per-token y_{j,k} + pooled,
// models/text/text_encoder.h) and MotionEncoder (models/text/motion_encoder.h) trained with symmetric InfoNCE
// (models/text/retrieval_train.h). Frozen afterwards: Text2BFM and the baselines read text() token features.
// Checkpoint kind "text_encoder" (models/text/retrieval_model.h); parameters "text.*" then "motion.*".
// Errors: config errors of the encoders; TextMotionModel requires text.embed_dim == motion.embed_dim
// ("TextMotionModel: ..."); load_text_motion_model: those of read_retrieval_checkpoint and Module::load_from.
#pragma once
#include <memory>

#include "models/text/motion_encoder.h"
#include "models/text/retrieval_model.h"
#include "models/text/text_encoder.h"

namespace t2m::text {

struct TextMotionConfig {
  TextEncoderConfig text;
  MotionEncoderConfig motion;
  nlohmann::json to_json() const { return {{"text", text.to_json()}, {"motion", motion.to_json()}}; }
  static TextMotionConfig from_json(const nlohmann::json& j);
};

class TextMotionModel : public RetrievalModel {
 public:
  TextMotionModel(const TextMotionConfig& cfg, Generator& gen);
  ag::Variable embed_text(const Tensor& ids, const Tensor& mask) const override;
  ag::Variable embed_motion(const ag::Variable& x, const Tensor& mask) const override;
  int64_t max_text_len() const override { return cfg_.text.max_len; }
  int64_t max_frames() const override { return cfg_.motion.max_patches * cfg_.motion.patch; }
  int64_t feature_dim() const override { return cfg_.motion.feature_dim; }
  const char* kind() const override { return "text_encoder"; }
  nlohmann::json config_json() const override { return cfg_.to_json(); }

  const TextEncoder& text() const { return *text_; }
  const MotionEncoder& motion() const { return *motion_; }
  const TextMotionConfig& config() const { return cfg_; }

 private:
  TextMotionConfig cfg_;
  std::shared_ptr<TextEncoder> text_;
  std::shared_ptr<MotionEncoder> motion_;
};

// Reads a "text_encoder" checkpoint (model in eval mode).
RetrievalBundle load_text_motion_model(const std::string& path);

}  // namespace t2m::text
