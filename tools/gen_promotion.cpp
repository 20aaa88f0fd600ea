// gen_promotion.cpp — `t2m generate "PROMPT" --model promotion --out DIR`: the PRO-Motion baseline (rule/template
// planner -> posture diffuser -> Viterbi posture planning -> go-diffuser), models/promotion/promotion_pipeline.h.
// Request mapping: seed -> PromotionOptions::seed; cfg (>= 0) -> the posture diffuser's guidance; steps (> 0) ->
// the posture diffuser's sampling steps (DDIM; its T = 1000 is DDPM); length_s (> 0) -> chained go-diffuser
// windows of 63 new frames each (promotion_pipeline.h: the nearest multiple of 63 frames plus one, at least 64).
#include <algorithm>
#include <cmath>

#include "models/promotion/promotion_pipeline.h"
#include "tools/kinematic_models.h"

namespace {

t2m::cli::KinematicResult generate_promotion(const t2m::cli::KinematicRequest& r) {
  namespace pm = t2m::promotion;
  const pm::PromotionModels m = pm::load_promotion_models(r.checkpoints);
  pm::PromotionOptions o;
  o.seed = r.seed;
  if (r.cfg >= 0) o.posture_guidance = r.cfg;
  if (r.steps > 0) o.posture_steps = r.steps;
  if (r.length_s > 0) o.frames = std::max<int64_t>(1, std::llround(r.length_s * 30));
  pm::PromotionResult g = pm::generate_promotion(m, r.prompt, o);
  t2m::cli::KinematicResult out;
  out.features = std::move(g.features);
  out.info = g.info;
  out.info["requested_length_s"] = r.length_s;
  return out;
}

}  // namespace

T2M_KINEMATIC_MODEL("promotion", "PRO-Motion baseline: rule planner -> posture diffuser -> Viterbi -> go-diffuser",
                    generate_promotion);
