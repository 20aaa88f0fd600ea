// text_motion_model.cpp — the TMR-style pair: construction, embeddings, checkpoint loading.
#include "models/text/text_motion_model.h"

namespace t2m::text {

TextMotionConfig TextMotionConfig::from_json(const nlohmann::json& j) {
  if (!j.is_object() || !j.contains("text") || !j.contains("motion"))
    throw Error("TextMotionModel: config needs 'text' and 'motion' objects, got " + j.dump());
  TextMotionConfig c;
  c.text = TextEncoderConfig::from_json(j["text"]);
  c.motion = MotionEncoderConfig::from_json(j["motion"]);
  return c;
}

TextMotionModel::TextMotionModel(const TextMotionConfig& cfg, Generator& gen) : cfg_(cfg) {
  if (cfg_.text.embed_dim != cfg_.motion.embed_dim)
    throw Error("TextMotionModel: text embed_dim " + std::to_string(cfg_.text.embed_dim) +
                " differs from motion embed_dim " + std::to_string(cfg_.motion.embed_dim));
  text_ = register_module("text", std::make_shared<TextEncoder>(cfg_.text, gen));
  motion_ = register_module("motion", std::make_shared<MotionEncoder>(cfg_.motion, gen));
}

ag::Variable TextMotionModel::embed_text(const Tensor& ids, const Tensor& mask) const {
  return text_->forward(ids, mask).pooled;
}

ag::Variable TextMotionModel::embed_motion(const ag::Variable& x, const Tensor& mask) const {
  return motion_->forward(x, mask);
}

RetrievalBundle load_text_motion_model(const std::string& path) {
  RetrievalCheckpoint r = read_retrieval_checkpoint(path, "text_encoder");
  Generator g(0);
  auto m = std::make_shared<TextMotionModel>(TextMotionConfig::from_json(r.config), g);
  if (m->config().text.vocab != r.bundle.tokenizer.vocab_size())
    throw Error("retrieval checkpoint " + path + ": config vocab " + std::to_string(m->config().text.vocab) +
                " differs from the tokenizer's " + std::to_string(r.bundle.tokenizer.vocab_size()));
  m->load_from(r.ck, "model.");
  m->eval();
  r.bundle.model = m;
  return r.bundle;
}

}  // namespace t2m::text
