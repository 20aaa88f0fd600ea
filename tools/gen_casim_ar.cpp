// gen_casim_ar.cpp — `t2m generate "PROMPT" --model casim-ar-cls | casim-ar-tok`: the autoregressive CASIM
// baseline (T2M-GPT-style token GPT + VQ-VAE tokenizer; docs/CASIM.md). Sampling: temperature 1, all codes
// (T2M-GPT's categorical sampling), seeded by --seed; --length S fixes ~S seconds (round(S·30/4) tokens, end token
// disallowed), otherwise the GPT ends the motion with its end token (at most 48 tokens = 6.4 s). --cfg and
// --steps do not apply to this model and are reported as ignored.
#include <string>

#include "models/casim/ar_generate.h"
#include "tools/kinematic_models.h"

namespace {

namespace cs = t2m::casim;

t2m::cli::KinematicResult generate_ar(const t2m::cli::KinematicRequest& r, cs::ArCond cond) {
  const cs::ArGenerator g(r.checkpoints, cond);
  cs::ArSampleOptions o;
  if (r.length_s > 0) o.tokens = g.tokens_for_seconds(r.length_s);
  t2m::Generator rng(r.seed);
  t2m::cli::KinematicResult out;
  out.features = g.generate({r.prompt}, o, rng).front();
  out.info = {{"model", std::string("casim-ar-") + cs::ar_cond_name(cond)},
              {"checkpoint", g.gpt_path()},
              {"tokens", out.features.size() / 257 / 4},
              {"temperature", o.temperature},
              {"length", r.length_s > 0 ? "fixed by --length" : "end token"},
              {"ignored", {{"cfg", r.cfg >= 0}, {"steps", r.steps > 0}}}};
  return out;
}

t2m::cli::KinematicResult generate_ar_cls(const t2m::cli::KinematicRequest& r) { return generate_ar(r, cs::ArCond::cls); }
t2m::cli::KinematicResult generate_ar_tok(const t2m::cli::KinematicRequest& r) { return generate_ar(r, cs::ArCond::tok); }

}  // namespace

T2M_KINEMATIC_MODEL("casim-ar-cls", "CASIM baseline: T2M-GPT token GPT, sentence embedding as a prefix token",
                    generate_ar_cls);
T2M_KINEMATIC_MODEL("casim-ar-tok", "CASIM baseline: T2M-GPT token GPT, text token features as prefix (CASIM)",
                    generate_ar_tok);
