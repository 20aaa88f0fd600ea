// evaluator.cpp — GRU text and motion encoders of the metric evaluator (see evaluator.h).
#include "models/eval/evaluator.h"

#include <string>

#include "autograd/ops_join.h"
#include "autograd/ops_unary.h"
#include "models/text/motion_encoder.h"
#include "tensor/ops.h"

namespace t2m::eval {

namespace {

int64_t get_int(const nlohmann::json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number_integer())
    throw Error(std::string("Evaluator: config field '") + key + "' missing or not an integer in " + j.dump());
  return j[key].get<int64_t>();
}

void check_has_real(const Tensor& mask, const char* what) {
  const Tensor c = t2m::sum(mask.to(DType::f64), {1});
  const auto v = c.to_vector<double>();
  for (size_t b = 0; b < v.size(); ++b)
    if (!(v[b] > 0)) throw Error(std::string("Evaluator: ") + what + " " + std::to_string(b) + " has no real entry");
}

}  // namespace

nlohmann::json EvaluatorConfig::to_json() const {
  return {{"vocab", vocab},
          {"word_dim", word_dim},
          {"text_hidden", text_hidden},
          {"max_len", max_len},
          {"feature_dim", feature_dim},
          {"patch", patch},
          {"motion_hidden", motion_hidden},
          {"max_frames", max_frames},
          {"embed_dim", embed_dim}};
}

EvaluatorConfig EvaluatorConfig::from_json(const nlohmann::json& j) {
  EvaluatorConfig c;
  c.vocab = get_int(j, "vocab");
  c.word_dim = get_int(j, "word_dim");
  c.text_hidden = get_int(j, "text_hidden");
  c.max_len = get_int(j, "max_len");
  c.feature_dim = get_int(j, "feature_dim");
  c.patch = get_int(j, "patch");
  c.motion_hidden = get_int(j, "motion_hidden");
  c.max_frames = get_int(j, "max_frames");
  c.embed_dim = get_int(j, "embed_dim");
  c.validate();
  return c;
}

void EvaluatorConfig::validate() const {
  if (vocab < 1 || word_dim < 1 || text_hidden < 1 || max_len < 2 || feature_dim < 1 || patch < 1 ||
      motion_hidden < 1 || max_frames < 1 || embed_dim < 1)
    throw Error("Evaluator: every config size must be >= 1 (max_len >= 2), got " + to_json().dump());
}

Evaluator::Evaluator(const EvaluatorConfig& cfg, Generator& gen) : cfg_(cfg) {
  cfg_.validate();
  emb_ = register_module("text_emb", std::make_shared<nn::Embedding>(cfg_.vocab, cfg_.word_dim, gen));
  tgf_ = register_module("text_gru_f", std::make_shared<nn::GRU>(cfg_.word_dim, cfg_.text_hidden, gen));
  tgb_ = register_module("text_gru_b", std::make_shared<nn::GRU>(cfg_.word_dim, cfg_.text_hidden, gen));
  tout1_ =
      register_module("text_out1", std::make_shared<nn::Linear>(2 * cfg_.text_hidden, cfg_.text_hidden, true, gen));
  tout2_ = register_module("text_out2", std::make_shared<nn::Linear>(cfg_.text_hidden, cfg_.embed_dim, true, gen));
  move_ = register_module("motion_move",
                          std::make_shared<nn::Linear>(cfg_.patch * cfg_.feature_dim, cfg_.motion_hidden, true, gen));
  mgf_ = register_module("motion_gru_f", std::make_shared<nn::GRU>(cfg_.motion_hidden, cfg_.motion_hidden, gen));
  mgb_ = register_module("motion_gru_b", std::make_shared<nn::GRU>(cfg_.motion_hidden, cfg_.motion_hidden, gen));
  mout1_ = register_module("motion_out1",
                           std::make_shared<nn::Linear>(2 * cfg_.motion_hidden, cfg_.motion_hidden, true, gen));
  mout2_ = register_module("motion_out2", std::make_shared<nn::Linear>(cfg_.motion_hidden, cfg_.embed_dim, true, gen));
}

ag::Variable Evaluator::embed_text(const Tensor& ids, const Tensor& mask) const {
  if (!ids.defined() || ids.dtype() != DType::i64 || ids.dim() != 2 || ids.size(0) < 1 || ids.size(1) < 1)
    throw Error("Evaluator: ids must be a non-empty (B, L) int64 tensor, got " +
                (ids.defined() ? shape_str(ids.shape()) : std::string("undefined")));
  if (ids.size(1) > cfg_.max_len)
    throw Error("Evaluator: sequence length " + std::to_string(ids.size(1)) + " exceeds max_len " +
                std::to_string(cfg_.max_len));
  if (!mask.defined() || mask.shape() != ids.shape() || mask.dtype() == DType::i64)
    throw Error("Evaluator: text mask must be a float tensor of the ids' shape " + shape_str(ids.shape()));
  check_has_real(mask, "caption");
  const ag::Variable w = emb_->forward(ids);  // (B, L, W)
  const Tensor m = mask.to(w.dtype());
  const ag::Variable hf = tgf_->forward(w, m).last, hb = tgb_->forward(w, m, ag::Variable(), true).last;
  return tout2_->forward(tout1_->forward_relu(ag::concat({hf, hb}, 1)));
}

ag::Variable Evaluator::embed_motion(const ag::Variable& x, const Tensor& mask) const {
  text::Patches p = text::patchify(x, mask, cfg_.patch, cfg_.feature_dim, "Evaluator");
  if (x.size(1) > cfg_.max_frames)
    throw Error("Evaluator: " + std::to_string(x.size(1)) + " frames exceed max_frames " +
                std::to_string(cfg_.max_frames));
  check_has_real(p.mask, "motion");
  const ag::Variable h = move_->forward_relu(p.x);  // (B, P, H_m)
  const ag::Variable hf = mgf_->forward(h, p.mask).last, hb = mgb_->forward(h, p.mask, ag::Variable(), true).last;
  return mout2_->forward(mout1_->forward_relu(ag::concat({hf, hb}, 1)));
}

text::RetrievalBundle load_evaluator(const std::string& path) {
  text::RetrievalCheckpoint r = text::read_retrieval_checkpoint(path, "evaluator");
  Generator g(0);
  auto m = std::make_shared<Evaluator>(EvaluatorConfig::from_json(r.config), g);
  if (m->config().vocab != r.bundle.tokenizer.vocab_size())
    throw Error("retrieval checkpoint " + path + ": config vocab " + std::to_string(m->config().vocab) +
                " differs from the tokenizer's " + std::to_string(r.bundle.tokenizer.vocab_size()));
  m->load_from(r.ck, "model.");
  m->eval();
  r.bundle.model = m;
  return r.bundle;
}

}  // namespace t2m::eval
