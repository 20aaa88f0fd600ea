// gen_casim.cpp — `t2m generate "PROMPT" --model casim-diff-cls | casim-diff-mhsa | casim-diff-mhca`: the MDM-style
// diffusion CASIM baseline (docs/CASIM.md). Loads CHECKPOINTS/casim_diff_<variant>.t2mckpt and
// CHECKPOINTS/text_encoder.t2mckpt; DDIM sampling (eta 0) with classifier-free guidance. Defaults from the
// checkpoint: --steps (50), --cfg (2.5), --length = the training window (64 frames, 2.1 s); a longer --length
// extrapolates the sinusoidal positions beyond what the model was trained on. Seeded by --seed.
#include <cmath>
#include <string>

#include "models/casim/diffusion_generate.h"
#include "models/text/text_motion_model.h"
#include "tools/kinematic_models.h"

namespace {

namespace cs = t2m::casim;

t2m::cli::KinematicResult generate_diff(const t2m::cli::KinematicRequest& r, const std::string& v) {
  const std::string path = r.checkpoints + "/casim_diff_" + v + ".t2mckpt";
  const std::string text_p = r.checkpoints + "/text_encoder.t2mckpt";
  const cs::DiffusionBundle b = cs::load_diffusion_checkpoint(path);
  const auto tb = t2m::text::load_text_motion_model(text_p);
  cs::SamplerOptions o = b.sampler;
  if (r.steps > 0) o.steps = r.steps;
  if (r.cfg >= 0) o.guidance = r.cfg;
  const int64_t frames = r.length_s > 0 ? std::max<int64_t>(1, std::llround(r.length_s * 30.0)) : b.window;
  t2m::cli::KinematicResult out;
  out.features = cs::generate_motion_features(b, tb, {r.prompt}, {frames}, o, r.seed).front();
  out.info = {{"model", "casim-diff-" + v},
              {"checkpoint", path},
              {"frames", frames},
              {"sampler", {{"kind", o.eta == 0 ? "DDIM" : "DDPM"}, {"steps", o.steps}, {"eta", o.eta},
                           {"guidance", o.guidance}, {"diffusion_steps", b.model->config().diffusion_steps}}},
              {"train_window_frames", b.window},
              {"train", b.train}};
  return out;
}

t2m::cli::KinematicResult generate_cls(const t2m::cli::KinematicRequest& r) { return generate_diff(r, "cls"); }
t2m::cli::KinematicResult generate_mhsa(const t2m::cli::KinematicRequest& r) { return generate_diff(r, "mhsa"); }
t2m::cli::KinematicResult generate_mhca(const t2m::cli::KinematicRequest& r) { return generate_diff(r, "mhca"); }

}  // namespace

T2M_KINEMATIC_MODEL("casim-diff-cls", "CASIM baseline: MDM diffusion, pooled sentence embedding ([CLS])",
                    generate_cls);
T2M_KINEMATIC_MODEL("casim-diff-mhsa", "CASIM baseline: MDM diffusion, token embeddings, self-attention aligner",
                    generate_mhsa);
T2M_KINEMATIC_MODEL("casim-diff-mhca", "CASIM baseline: MDM diffusion, token embeddings, cross-attention aligner",
                    generate_mhca);
