// posture_diffuser_sampler.h — the shipped posture-diffuser bundle (network + script tokenizer + pose mean/std)
// and PRO-Motion's script -> candidate postures sampling (paper Sec 3.3: "sampled several times per script").
//
// sample_postures: for S scripts and n candidates each, B = S n chains (diffusion_schedule.h: with steps = 0 or T
// the DDPM ancestral sampler over the model's T steps, else strided DDIM over `steps` of them with stochasticity
// eta; x_{T-1} ~ N(0, I) from Generator(seed)), x0 estimate with classifier-free
// guidance (paper Eq 3) f = f(x, t, null) + w (f(x, t, c) - f(x, t, null)), then de-normalised with the bundle's
// pose stats. Returns raw poses [S, n, kPoseDim] (script-major, row s * n + j). Scripts longer than max_tokens
// are truncated by the tokenizer. Deterministic for (seed, thread count).
// Checkpoint ("kind": "promotion_posture"): meta config (PostureDiffuserConfig), tokenizer (meta "tokenizer"),
// "info" (free JSON: training command, data); tensors "model.*", "pose_mean", "pose_std" (kPoseDim).
// Errors (t2m::Error): empty script list, n < 1, a checkpoint of another kind or with missing entries.
#pragma once
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/promotion/pose.h"
#include "models/promotion/posture_diffuser.h"
#include "models/text/tokenizer.h"

namespace t2m::promotion {

struct PostureModel {
  std::shared_ptr<PostureDiffuser> net;
  text::Tokenizer tokenizer;
  PoseStats stats;
  nlohmann::json info;
};

struct PostureSampleOptions {
  double guidance = 2.0;  // w of paper Eq 3 (not given in the paper; our choice)
  int steps = 0;          // sampling steps: 0 = all T of the model (DDPM, the paper); 1..T-1: strided DDIM
  double eta = 1.0;       // DDIM stochasticity in [0, 1] (1 with all steps = DDPM)
};

std::vector<float> sample_postures(const PostureModel& m, const std::vector<std::string>& scripts, int n_per_script,
                                   uint64_t seed, const PostureSampleOptions& opt = {});

void save_posture_model(const PostureModel& m, const std::string& path);
PostureModel load_posture_model(const std::string& path);

}  // namespace t2m::promotion
