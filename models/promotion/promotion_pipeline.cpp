// promotion_pipeline.cpp — the stages of PRO-Motion wired together.
#include "models/promotion/promotion_pipeline.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "models/data/features.h"
#include "models/promotion/planner.h"
#include "models/promotion/viterbi.h"

namespace t2m::promotion {

namespace {

std::string need(const std::string& dir, const std::string& file, const std::string& how) {
  const std::string p = dir + "/" + file;
  if (!std::filesystem::is_regular_file(p))
    throw Error("promotion: missing " + p + " (make it with `" + how + "`, see docs/PROMOTION.md)");
  return p;
}

}  // namespace

PromotionModels load_promotion_models(const std::string& dir) {
  PromotionModels m;
  m.planner = load_planner_table(need(dir, "promotion_planner.json", "t2m train promotion --variant posture"));
  m.posture = load_posture_model(need(dir, "promotion_posture.t2mckpt", "t2m train promotion --variant posture"));
  m.encoders =
      load_pose_text_bundle(need(dir, "promotion_encoders.t2mckpt", "t2m train promotion --variant encoders"));
  m.go = load_go_checkpoint(need(dir, "promotion_go.t2mckpt", "t2m train promotion --variant go"));
  return m;
}

// PRO-Motion Sec 3.3: argmax_G E^1_{g_1} prod_i E^i_{g_i} A^i_{g_{i-1} g_i} over the candidate lattice.
PostureChoice plan_key_poses(const PoseTextBundle& enc, const std::vector<float>& candidates, int K, int N,
                             const std::vector<std::string>& scripts) {
  if ((int64_t)candidates.size() != (int64_t)K * N * kPoseDim || (int)scripts.size() != K)
    throw Error("promotion: plan_key_poses needs (K, N, 187) = (" + std::to_string(K) + ", " + std::to_string(N) +
                ", 187) candidates and K scripts, got " + std::to_string(candidates.size()) + " floats and " +
                std::to_string(scripts.size()) + " scripts");
  std::vector<float> norm = candidates;
  normalize_poses(norm, enc.stats);
  const auto s = posture_planning_scores(*enc.model, enc.tokenizer, Tensor::from_vector(norm, {K, N, kPoseDim}),
                                         scripts);
  const ViterbiPath vp = viterbi_decode(s.emission, s.transition);
  PostureChoice c;
  c.path = vp.path;
  c.score = vp.score;
  for (int k = 0; k < K; ++k) {
    const float* p = candidates.data() + ((size_t)k * N + vp.path[k]) * kPoseDim;
    c.poses.insert(c.poses.end(), p, p + kPoseDim);
  }
  return c;
}

// PRO-Motion Sec 3.4: the go-diffuser turns the chosen key poses into the whole motion.
std::vector<float> go_from_key_poses(const GoBundle& go, const std::vector<float>& key_poses, uint64_t seed,
                                     double guidance, bool inpaint) {
  const auto& cfg = go.model->config();
  const int64_t K = cfg.keys, T = cfg.frames;
  if ((int64_t)key_poses.size() != K * kPoseDim)
    throw Error("promotion: the go-diffuser needs " + std::to_string(K) + " key poses (" +
                std::to_string(K * kPoseDim) + " floats), got " + std::to_string(key_poses.size()) + " floats");
  std::vector<float> keys = key_poses;
  normalize_poses(keys, pose_stats_from_feature_stats(go.stats));
  std::vector<int64_t> kf;
  for (int f : key_frame_indices((int)T, (int)K)) kf.push_back(f);
  Generator g(seed);
  const Tensor out = go.model->sample(Tensor::from_vector(keys, {1, K, kPoseDim}), Tensor::from_vector(kf, {1, K}),
                                      g, guidance, inpaint);
  std::vector<float> f = out.to_vector<float>();
  data::denormalize_features(f, go.stats);
  return f;
}

// Number of chained go-diffuser windows for a requested length (header: Length).
int go_windows(int64_t frames, int64_t window) {
  if (frames <= 0) return 1;
  return (int)std::max<int64_t>(1, std::llround((double)(frames - 1) / (double)(window - 1)));
}

PromotionResult generate_promotion(const PromotionModels& m, const std::string& prompt, const PromotionOptions& o) {
  if (o.candidates < 1) throw Error("promotion: candidates must be >= 1, got " + std::to_string(o.candidates));
  if (o.frames < 0 || o.frames > 30 * 600) throw Error("promotion: frames must be in [0, 18000]");
  const int K = (int)m.go.model->config().keys;
  const int64_t T = m.go.model->config().frames;
  const int W = go_windows(o.frames, T), Kall = W * (K - 1) + 1;
  PromotionResult r;
  const Plan plan = plan_postures(m.planner, prompt, Kall);  // Sec 3.2 (rule/template planner, no LLM)
  r.scripts = plan.scripts;
  PostureSampleOptions so;
  so.guidance = o.posture_guidance;
  so.steps = o.posture_steps;
  const std::vector<float> cands = sample_postures(m.posture, plan.scripts, o.candidates, o.seed, so);  // Sec 3.3
  r.choice = plan_key_poses(m.encoders, cands, Kall, o.candidates, plan.scripts);
  for (int w = 0; w < W; ++w) {  // Sec 3.4, one window per K key poses (shared boundary keys)
    const auto k0 = r.choice.poses.begin() + (ptrdiff_t)w * (K - 1) * kPoseDim;
    const std::vector<float> keys(k0, k0 + (ptrdiff_t)K * kPoseDim);
    const std::vector<float> f = go_from_key_poses(m.go, keys, o.seed + 1 + w, o.go_guidance, o.go_inpaint);
    r.features.insert(r.features.end(), f.begin() + (w == 0 ? 0 : data::kFeatureDim), f.end());
  }
  nlohmann::json clauses = nlohmann::json::array();
  for (const auto& c : plan.clauses)
    clauses.push_back({{"text", c.text}, {"content", c.content}, {"style", c.style}, {"entry", c.entry},
                       {"mirrored", c.mirrored}, {"key_frames", c.frames}, {"score", c.score}});
  r.info = {{"model", "promotion"}, {"planner", "rule/template (no LLM)"}, {"clauses", clauses},
            {"scripts", plan.scripts}, {"candidates_per_script", o.candidates}, {"viterbi_path", r.choice.path},
            {"viterbi_log_prob", r.choice.score}, {"posture_guidance", o.posture_guidance},
            {"posture_steps", o.posture_steps == 0 ? (int)m.posture.net->config().diffusion_steps : o.posture_steps},
            {"go_guidance", o.go_guidance}, {"go_inpaint", o.go_inpaint}, {"frames", (int64_t)r.features.size() / data::kFeatureDim},
            {"go_windows", W}, {"key_frames", Kall}, {"fps", 30},
            {"seed", o.seed}};
  return r;
}

}  // namespace t2m::promotion
