// gen_promotion.cpp — `t2m generate "PROMPT" --model promotion --out DIR`: the PRO-Motion baseline (rule/template
// planner -> posture diffuser -> Viterbi posture planning -> go-diffuser), models/promotion/promotion_pipeline.h.
// Request mapping: seed -> PromotionOptions::seed; cfg (>= 0) -> the posture diffuser's guidance; steps and
// length_s are not used (the go-diffuser's window fixes 64 frames = 2.13 s; the DDPMs use their trained step
// counts), which metrics.json's info says.
#include "models/promotion/promotion_pipeline.h"
#include "tools/kinematic_models.h"

namespace {

t2m::cli::KinematicResult generate_promotion(const t2m::cli::KinematicRequest& r) {
  namespace pm = t2m::promotion;
  const pm::PromotionModels m = pm::load_promotion_models(r.checkpoints);
  pm::PromotionOptions o;
  o.seed = r.seed;
  if (r.cfg >= 0) o.posture_guidance = r.cfg;
  pm::PromotionResult g = pm::generate_promotion(m, r.prompt, o);
  t2m::cli::KinematicResult out;
  out.features = std::move(g.features);
  out.info = g.info;
  out.info["requested_length_s"] = r.length_s;
  out.info["length_note"] = "fixed go-diffuser window; requested length and steps are not used";
  return out;
}

}  // namespace

T2M_KINEMATIC_MODEL("promotion", "PRO-Motion baseline: rule planner -> posture diffuser -> Viterbi -> go-diffuser",
                    generate_promotion);
