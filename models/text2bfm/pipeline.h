// pipeline.h — text to physically simulated motion with Text2BFM (§4, ARCHITECTURE.md §7 "Generation"):
//
//   prompt --tokenizer--> ids --frozen text encoder--> y (B, L, D)                          stage "text"
//   m(0) ~ N(0, I) (B, Tm, d_m) --Eq 16 Euler, `steps` steps, CFG w--> m(1); m = m(1) std + mean  stage "sample"
//   (a generator checkpoint with objective "diffusion" is sampled with DDIM instead, diffusion_sampler.h)
//   D_θ(m) (Eq 4) -> ẑ (B, Tz, d); Compose: Eq 18–19 over the clauses; Proj onto the sphere ‖z‖ = √d  "decode"
//   a_t = μ(s_t, z_t) (the BFM policy mean), one 30 Hz MuJoCo control step each, t = 0..T-1, from the standing
//   start (the humanoid's qpos0: reference pose, soles on the floor, zero velocity)                    "rollout"
//
// B = 1 (one program for the whole prompt) or, with compose, B = N clauses (compose.h): one program per clause,
// all sampled in one batch. Lengths: T = round(length_s * 30) control steps. A single program has
// Tm = ceil(T / c) frames (c = VBB compression) and its decoded latents are cut to T; with N clauses each has
// T_n = ceil((T + (N - 1) O) / N / c) c latents, composed with overlap O and cut to T.
// The rollout records T + 1 states (s_0 = the standing start). A fall is the root (hips) dropping below 0.5 m
// (sim/pd_tracker.h's fall_height) from above it; `falls` counts such events.
// Randomness: m(0) from Generator(seed) only: a seed, prompt, options and thread count fix every output bit.
// Candidates (ours, not in the paper): with candidates = K > 1 the chain after the text stage runs K times, with
// seeds seed, seed + 1, ..., seed + K - 1, and the rollout that stays upright longest is kept (no fall beats any
// fall; then fewer falls; then the lower seed): physics as the critic of the sampled programs, at K times the
// sample/decode/rollout cost (those stage times are summed over the candidates). K = 1 is the plain chain.
//
// Outputs (write_generation): into a fresh temporary directory next to DIR, renamed to DIR at the very end, so
// DIR either holds all of them or does not exist (an existing DIR is refused unless overwrite, which swaps it
// out only after the new one is complete):
//   motion.bvh    sim/export.h (Bandai hierarchy, cm, Y up)
//   render.mp4    sim/render.h (skipped with render = false)
//   states.bin    nn::Checkpoint (CRC-checked) meta {"format": "t2m-states-1", "fps": 30, "prompt": ...},
//                 tensors "obs" (T+1, obs_dim) f32, "qpos" (T+1, nq) f64, "qvel" (T+1, nv) f64, "z" (T, d) f32
//   metrics.json  prompt, clauses, options, duration_s, frames, falls, fell, first_fall_s, min_root_height_m,
//                 candidate (index kept), candidate_seed, candidate_upright_s (per candidate: time to the first fall,
//                 the duration when none),
//                 timing_s per stage (text, sample, decode, rollout, export, render, total; wall), cpu_s per
//                 generation stage (process CPU time, all threads), threads, warnings.
// Errors (t2m::Error): an empty prompt; a prompt (or, with compose, a clause) whose words are all unknown to the
// tokenizer; length <= 0 or > 120 s; steps < 1; non-finite cfg; overlap < 0; candidates outside [1, 64]; a start state
// of other sizes than the humanoid's qpos / qvel (or only one of the two); a missing checkpoint (names the file and the
// command that makes it); mismatched model widths; an existing or unwritable output directory.
#pragma once
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/bfm/fb_agent.h"
#include "models/text/retrieval_model.h"
#include "models/text/text_encoder.h"
#include "models/text2bfm/pipeline_checkpoints.h"
#include "models/text2bfm/vbb.h"
#include "sim/humanoid.h"
#include "sim/retarget.h"

namespace t2m::text2bfm {

struct Text2BfmModels {
  text::RetrievalBundle text;             // a TextMotionModel (kind "text_encoder")
  const text::TextEncoder* encoder = nullptr;
  std::shared_ptr<Vbb> vbb;
  GenBundle gen;
  std::unique_ptr<bfm::FbAgent> policy;
  std::shared_ptr<const sim::Humanoid> humanoid;
  PipelinePaths paths;
  std::vector<std::string> warnings;  // e.g. the generator's BFM checksum differs from the policy file's
};

// Loads and cross-checks the four checkpoints (text dim = adapter tok_dim, VBB latent = generator latent,
// VBB in_dim = policy z_dim, VBB compression = the generator's, policy obs/action dims = the humanoid's). A
// generator trained on another BFM's latents (its train.bfm_checksum) is a warning, not an error.
Text2BfmModels load_text2bfm(const PipelinePaths& p);

struct GenerateOptions {
  uint64_t seed = 0;
  double length_s = 10.0;
  double cfg = 1.5;        // classifier-free guidance w
  int64_t steps = 16;      // Euler steps
  bool compose = false;    // one program per clause (Eq 18-19)
  int64_t overlap = 4;     // O, latent steps blended per clause boundary
  int64_t candidates = 1;  // K: programs tried (seeds seed .. seed + K - 1); the longest upright rollout is kept
  // The rollout's first state (qpos [nq], qvel [nv]); both empty (the default): the standing start. For evaluation
  // only (`t2m eval text2bfm --clip-start` starts each generation in its clip's first state).
  std::vector<double> start_qpos = {}, start_qvel = {};
  void validate() const;
};

struct StageTimes {
  double text = 0, sample = 0, decode = 0, rollout = 0, exporting = 0, render = 0;
};

struct Generation {
  std::string prompt;
  std::vector<std::string> clauses;   // what was encoded: {prompt} or the compose clauses
  GenerateOptions opt;
  Tensor z;                           // (T, d) latents fed to the policy
  std::vector<float> obs;             // (T + 1, obs_dim)
  sim::QposTrajectory traj;           // T + 1 frames at 30 fps
  int falls = 0;
  double first_fall_s = -1;           // -1: no fall
  double min_root_height = 0;
  StageTimes times;                   // wall seconds per stage
  StageTimes cpu;                     // process CPU seconds per stage (all threads)
  int64_t candidate = 0;              // which candidate was kept (its seed: opt.seed + candidate)
  std::vector<double> candidate_upright_s;  // per candidate: first fall time, or the duration without a fall
};

// The tokenizer + frozen text encoder: token features (B, L, D) and mask (B, L) of the texts (each must have a
// known word).
struct TextTokens {
  Tensor tokens, mask;
};
TextTokens encode_prompt_texts(const Text2BfmModels& m, const std::vector<std::string>& texts);

// The whole chain up to the simulated states (no files written); with opt.candidates > 1, the kept candidate.
Generation generate_motion(Text2BfmModels& m, const std::string& prompt, const GenerateOptions& opt);

struct WriteOptions {
  bool render = true;
  bool overwrite = false;
  int render_width = 640, render_height = 480;
};
// Writes DIR atomically (see above); fills g.times.exporting / render. Returns metrics.json's content.
nlohmann::json write_generation(Generation& g, const Text2BfmModels& m, const std::string& dir,
                                const WriteOptions& w);

}  // namespace t2m::text2bfm
