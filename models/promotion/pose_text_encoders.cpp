// pose_text_encoders.cpp — Θ (pose MLP), Φ (bi-GRU over script words), the posture-planning scores, the bundle.
#include "models/promotion/pose_text_encoders.h"

#include <algorithm>
#include <cmath>

#include "autograd/no_grad.h"
#include "autograd/ops_activation.h"
#include "autograd/ops_join.h"
#include "models/promotion/posture_script.h"
#include "models/text/retrieval_model.h"
#include "nn/checkpoint.h"
#include "nn/loss_contrastive.h"
#include "tensor/ops.h"

namespace t2m::promotion {

namespace {
const char* kFormat = "t2m-promotion-encoders-1";
}

nlohmann::json PoseTextConfig::to_json() const {
  return {{"embed", embed}, {"pose_hidden", pose_hidden}, {"word_dim", word_dim}, {"gru_hidden", gru_hidden},
          {"max_tokens", max_tokens}, {"vocab", vocab}};
}

PoseTextConfig PoseTextConfig::from_json(const nlohmann::json& j) {
  PoseTextConfig c;
  try {
    c.embed = j.at("embed"), c.pose_hidden = j.at("pose_hidden"), c.word_dim = j.at("word_dim");
    c.gru_hidden = j.at("gru_hidden"), c.max_tokens = j.at("max_tokens"), c.vocab = j.at("vocab");
  } catch (const nlohmann::json::exception& e) {
    throw Error(std::string("pose_text_encoders: bad config JSON: ") + e.what());
  }
  c.validate();
  return c;
}

void PoseTextConfig::validate() const {
  if (embed < 1 || pose_hidden < 1 || word_dim < 1 || gru_hidden < 1 || max_tokens < 2 || vocab < 5)
    throw Error("pose_text_encoders: bad config " + to_json().dump() + " (sizes >= 1, max_tokens >= 2, vocab >= 5)");
}

text::Tokenizer posture_script_tokenizer() { return text::Tokenizer::build(posture_script_corpus()); }

PoseTextEncoders::PoseTextEncoders(const PoseTextConfig& cfg, Generator& gen) : cfg_(cfg) {
  cfg.validate();
  p1_ = register_module("pose1", std::make_shared<nn::Linear>(kPoseDim, cfg.pose_hidden, true, gen));
  p2_ = register_module("pose2", std::make_shared<nn::Linear>(cfg.pose_hidden, cfg.pose_hidden, true, gen));
  p3_ = register_module("pose3", std::make_shared<nn::Linear>(cfg.pose_hidden, cfg.embed, true, gen));
  words_ = register_module("words", std::make_shared<nn::Embedding>(cfg.vocab, cfg.word_dim, gen));
  fwd_ = register_module("gru_fwd", std::make_shared<nn::GRU>(cfg.word_dim, cfg.gru_hidden, gen));
  bwd_ = register_module("gru_bwd", std::make_shared<nn::GRU>(cfg.word_dim, cfg.gru_hidden, gen));
  tproj_ = register_module("text_proj", std::make_shared<nn::Linear>(2 * cfg.gru_hidden, cfg.embed, true, gen));
  alpha_ = register_parameter("logit_scale", Tensor::full({1}, nn::kInitLogitScale));
}

// PRO-Motion Sec 3.3: Θ, the pose encoder (L2-normalised).
ag::Variable PoseTextEncoders::embed_poses(const ag::Variable& poses) const {
  const Tensor& p = poses.data();
  if (p.dim() != 2 || p.size(1) != kPoseDim)
    throw Error("pose_text_encoders: poses must be (N, 187), got " + shape_str(p.shape()));
  ag::Variable h = ag::gelu_tanh(p1_->forward(poses));
  h = ag::gelu_tanh(p2_->forward(h));
  return nn::l2_normalize(p3_->forward(h));
}

// PRO-Motion Sec 3.3: Φ, a single bi-GRU layer over the script's words (L2-normalised).
ag::Variable PoseTextEncoders::embed_scripts(const Tensor& ids, const Tensor& mask) const {
  if (!ids.defined() || ids.dim() != 2 || ids.dtype() != DType::i64 || !mask.defined() || mask.shape() != ids.shape())
    throw Error("pose_text_encoders: script ids must be int64 (N, L) with a float mask of the same shape, got " +
                (ids.defined() ? shape_str(ids.shape()) : std::string("undefined")));
  const ag::Variable x = words_->forward(ids);  // (N, L, word_dim)
  const auto f = fwd_->forward(x, mask, ag::Variable(), false);
  const auto b = bwd_->forward(x, mask, ag::Variable(), true);
  return nn::l2_normalize(tproj_->forward(ag::concat({f.last, b.last}, 1)));
}

double PoseTextEncoders::gamma() const { return std::exp(std::clamp(alpha_.data().item(), 0.0, nn::kMaxLogitScale)); }

// PRO-Motion Sec 3.3: E^i_j = softmax_j(Φ(t_i)·Θ(p^i_j)), A^i_jk = softmax_k(Θ(p^{i-1}_j)·Θ(p^i_k)), as logs.
PosturePlanningScores posture_planning_scores(const PoseTextEncoders& enc, const text::Tokenizer& tok,
                                              const Tensor& candidates, const std::vector<std::string>& scripts) {
  if (candidates.dim() != 3 || candidates.size(2) != kPoseDim || candidates.size(0) != (int64_t)scripts.size() ||
      candidates.size(0) < 1 || candidates.size(1) < 1)
    throw Error("pose_text_encoders: candidates must be (K, N, 187) with K = " + std::to_string(scripts.size()) +
                " scripts, got " + shape_str(candidates.shape()));
  ag::NoGradGuard ng;
  const int64_t K = candidates.size(0), N = candidates.size(1);
  const Tensor pe = enc.embed_poses(ag::Variable(candidates.reshape({K * N, kPoseDim}).to(DType::f32)))
                        .data().to(DType::f64).reshape({K, N, -1});
  const auto eb = text::encode_captions(tok, scripts, enc.config().max_tokens);
  const Tensor te = enc.embed_scripts(eb.ids, eb.mask).data().to(DType::f64);  // (K, E)
  const double g = enc.gamma();
  PosturePlanningScores s;
  // emission: (K, N) = γ <Φ(t_i), Θ(p^i_j)>, log-softmax over j.
  const Tensor el = mul(sum(mul(pe, te.unsqueeze(1)), {2}), g);
  s.emission = sub(el, logsumexp(el, 1, true));
  if (K > 1) {
    const Tensor prev = pe.slice(0, 0, K - 1), next = pe.slice(0, 1, K);
    const Tensor al = mul(matmul_t(prev, false, next, true), g);  // (K-1, N, N)
    s.transition = sub(al, logsumexp(al, 2, true));
  } else {
    s.transition = Tensor::zeros({0, N, N}, DType::f64);
  }
  return s;
}

void save_pose_text_bundle(const PoseTextBundle& b, const std::string& path) {
  nn::Checkpoint ck;
  ck.meta = {{"format", kFormat}, {"config", b.model->config().to_json()}, {"train", b.train}};
  b.tokenizer.save_to(ck, "tokenizer");
  b.model->save_to(ck, "model.");
  ck.put("pose_mean", Tensor::from_vector(b.stats.mean, {kPoseDim}));
  ck.put("pose_std", Tensor::from_vector(b.stats.std, {kPoseDim}));
  ck.save(path);
}

PoseTextBundle load_pose_text_bundle(const std::string& path) {
  const nn::Checkpoint ck = nn::Checkpoint::load(path);
  if (ck.meta.value("format", std::string()) != kFormat)
    throw Error("encoders checkpoint " + path + ": not a posture-planning encoder file (format '" +
                ck.meta.value("format", std::string()) + "', expected " + kFormat + ")");
  if (!ck.meta.contains("config")) throw Error("encoders checkpoint " + path + ": meta has no config");
  PoseTextBundle b;
  const PoseTextConfig cfg = PoseTextConfig::from_json(ck.meta.at("config"));
  Generator g(0);
  b.model = std::make_shared<PoseTextEncoders>(cfg, g);
  b.model->load_from(ck, "model.");
  b.model->eval();
  b.tokenizer = text::Tokenizer::load_from(ck, "tokenizer");
  if (b.tokenizer.vocab_size() != cfg.vocab)
    throw Error("encoders checkpoint " + path + ": tokenizer has " + std::to_string(b.tokenizer.vocab_size()) +
                " tokens, config says " + std::to_string(cfg.vocab));
  b.stats.mean = ck.expect("pose_mean", {kPoseDim}, DType::f32).to_vector<float>();
  b.stats.std = ck.expect("pose_std", {kPoseDim}, DType::f32).to_vector<float>();
  b.train = ck.meta.value("train", nlohmann::json::object());
  return b;
}

}  // namespace t2m::promotion
