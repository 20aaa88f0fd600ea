// pose_text_encoders.h — PRO-Motion's posture-planning encoders (Sec 3.3): a pose encoder Θ and a script encoder Φ
// with L2-normalised embeddings, trained contrastively on (key pose, posture script) pairs, and the emission /
// transition scores of posture planning computed from them.
//
//   Θ(p) = normalize(MLP(p))        p (N, 187) normalised pose (pose.h)   MLP 187 -> H -> H -> E, GELU (VPoser's
//                                   encoder is an MLP; ours has no VAE head: the embedding is deterministic)
//   Φ(s) = normalize(Linear([GRU_fwd(emb(s)).last ; GRU_bwd(emb(s)).last]))   ids/mask (N, L)   a single-layer
//          bi-GRU over word embeddings of the script tokenizer (the paper: one bi-GRU layer over DistilBERT
//          features; our frozen text encoder knows only the motion-caption words, "elbow", "knee", "bent", ... are
//          <unk> there, so the script words get their own trainable embeddings, like the posture diffuser's)
// Training: symmetric InfoNCE (nn::info_nce) with a learnable logit scale γ = exp(α) (CLIP init ln(1/0.07)).
//
// Posture-planning scores (PRO-Motion Sec 3.3, both softmax-normalised over the candidates and taken as logs):
//   emission   e[i][j]    = log softmax_j ( γ Φ(t_i)^T Θ(p^i_j) )                (log E^i_j)
//   transition a[i][j][k] = log softmax_k ( γ Θ(p^i_j)^T Θ(p^{i+1}_k) )          (log A^{i+1}_{jk})
// The paper's softmax has no temperature; with unit embeddings (dot in [-1, 1]) that would be nearly uniform, so
// we use the trained γ for both (documented in docs/PROMOTION.md). Weights: w_e = w_a = 1 (the paper's product).
// Errors (t2m::Error, "pose_text_encoders: ..."): bad config; inputs of the wrong shape (named).
#pragma once
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "autograd/variable.h"
#include "models/promotion/pose.h"
#include "models/text/tokenizer.h"
#include "nn/embedding.h"
#include "nn/gru.h"
#include "nn/linear.h"
#include "nn/module.h"
#include "tensor/rng.h"

namespace t2m::promotion {

struct PoseTextConfig {
  int64_t embed = 64;         // E
  int64_t pose_hidden = 256;  // H
  int64_t word_dim = 64;
  int64_t gru_hidden = 64;
  int64_t max_tokens = 96;    // script tokens incl. <bos>/<eos>
  int64_t vocab = 0;          // script tokenizer size
  nlohmann::json to_json() const;
  static PoseTextConfig from_json(const nlohmann::json& j);
  void validate() const;
};

// The script tokenizer: text::Tokenizer::build over posture_script_corpus() (closed vocabulary).
text::Tokenizer posture_script_tokenizer();

class PoseTextEncoders : public nn::Module {
 public:
  PoseTextEncoders(const PoseTextConfig& cfg, Generator& gen);
  ag::Variable embed_poses(const ag::Variable& poses) const;                   // (N, 187) -> (N, E) unit rows
  ag::Variable embed_scripts(const Tensor& ids, const Tensor& mask) const;     // (N, L) -> (N, E) unit rows
  const ag::Variable& logit_scale() const { return alpha_; }                   // α, γ = exp(clamp(α, 0, ln 100))
  double gamma() const;
  const PoseTextConfig& config() const { return cfg_; }

 private:
  PoseTextConfig cfg_;
  std::shared_ptr<nn::Linear> p1_, p2_, p3_;
  std::shared_ptr<nn::Embedding> words_;
  std::shared_ptr<nn::GRU> fwd_, bwd_;
  std::shared_ptr<nn::Linear> tproj_;
  ag::Variable alpha_;
};

struct PosturePlanningScores {
  Tensor emission;    // (K, N) float64
  Tensor transition;  // (K-1, N, N) float64
};

// Scores of the lattice of K scripts x N candidate poses: candidates (K, N, 187) normalised, scripts K texts.
PosturePlanningScores posture_planning_scores(const PoseTextEncoders& enc, const text::Tokenizer& tok,
                                              const Tensor& candidates, const std::vector<std::string>& scripts);

// The shipped bundle (models/checkpoints/promotion_encoders.t2mckpt): nn::Checkpoint, meta {"format":
// "t2m-promotion-encoders-1", "config", "tokenizer", "train"}, tensors "model.*", "pose_mean", "pose_std" (187).
struct PoseTextBundle {
  std::shared_ptr<PoseTextEncoders> model;
  text::Tokenizer tokenizer;
  PoseStats stats;
  nlohmann::json train = nlohmann::json::object();
};
void save_pose_text_bundle(const PoseTextBundle& b, const std::string& path);
PoseTextBundle load_pose_text_bundle(const std::string& path);

}  // namespace t2m::promotion
