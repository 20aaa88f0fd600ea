// latent_cache.h — the policy latents z_{1:Tz} of Text2BFM Eq 2 for every clip of a data split, with the states
// s_t they pair with (what Eq 5's action KL evaluates the frozen actor at), cached on disk per split and keyed by
// a checksum of the BFM policy checkpoint they came from.
//
// Extraction (extract_split_latents): the split's clips in name order (bfm::select_split_clips, all clips),
// retargeted to the humanoid (sim::retarget) and replayed kinematically (sim::replay_observations) -> states
// s_0..s_{T-1} [T, S]; z = FbAgent::infer_tracking_z(states, L) [T-1, d] (frozen B, H_t = min(L, T-1-t),
// projection to radius sqrt(d)). Clip c keeps rows t = 0..T-2: z_t and the state s_t it is paired with.
// Clips shorter than 2 frames are skipped (no transition). OpenMP over clips; the result does not depend on the
// thread count (each clip is computed by one thread; B runs per clip).
//
// File (nn::Checkpoint: atomic temp + rename, CRC-32C): tensors "z" [F, d] f32, "states" [F, S] f32, "offset"
// [C + 1] i64; meta {"format": "t2m-latents-1", "split", "bfm_checksum" (16 hex digits, FNV-1a 64 of the policy
// file's bytes), "window" L, "clips": [names], "content": [labels], "style": [labels], "data": provenance}.
// ensure_latent_cache(path, bfm_checksum, L, build): loads `path` when it exists and its bfm_checksum and window
// match; otherwise (no file, another BFM, another L) calls build() and saves its result atomically, so a changed
// BFM invalidates the cache. A file that exists but cannot be read (truncated, corrupt, not a latent cache) is an
// error naming it and suggesting its removal; nothing is overwritten then.
// Errors (t2m::Error "latent cache PATH: ..."): the above, plus inconsistent contents (offsets not increasing from
// 0 to F, name/label count != clips, z and states of different row counts, non-finite values).
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "models/bfm/fb_agent.h"
#include "models/data/dataset.h"
#include "models/data/splits.h"
#include "sim/humanoid.h"

namespace t2m::text2bfm {

struct LatentSet {
  std::string split;
  std::string bfm_checksum;             // 16 hex digits
  int window = 8;                       // L of Eq 2
  int64_t z_dim = 0, obs_dim = 0;
  std::vector<std::string> names;       // clip names, sorted
  std::vector<std::string> content, style;  // the clips' labels (captions are made from them)
  std::vector<int64_t> offset{0};       // [clips + 1]: clip c holds rows offset[c] .. offset[c + 1) - 1
  std::vector<float> z;                 // [F, z_dim]   z_t (Eq 2)
  std::vector<float> states;            // [F, obs_dim] s_t

  int clips() const { return (int)names.size(); }
  int64_t frames(int c) const { return offset.at(c + 1) - offset.at(c); }  // Tz of clip c
  int64_t total_frames() const { return offset.back(); }
  const float* z_at(int c, int64_t t) const { return z.data() + (offset[c] + t) * z_dim; }
  const float* state_at(int c, int64_t t) const { return states.data() + (offset[c] + t) * obs_dim; }
  // Appends a clip: states [T, S] (T >= 2) -> rows z_t, s_t for t < T - 1 from agent.infer_tracking_z.
  void add_clip(bfm::FbAgent& agent, const std::string& name, const std::string& content_label,
                const std::string& style_label, const Tensor& clip_states);
  void validate(const std::string& where) const;  // throws Error(where + ...) on inconsistent contents
};

// FNV-1a 64 of a file's bytes as 16 lower-case hex digits (not a CRC: the CRC of a whole checkpoint file,
// which ends with its own CRC, is a constant). Error when the file cannot be read.
std::string file_checksum(const std::string& path);

// Text2BFM Eq 2 over every clip of `split` (see above); progress(done, total) after each clip (any thread order).
LatentSet extract_split_latents(bfm::FbAgent& agent, const sim::Humanoid& h, const data::Manifest& manifest,
                                data::Split split, const std::string& bfm_checksum, int L,
                                const std::function<void(int, int)>& progress = {});

void save_latent_set(const LatentSet& s, const std::string& path);
LatentSet load_latent_set(const std::string& path);

// Loads the cache or rebuilds it (see above). *rebuilt (optional) says which happened.
LatentSet ensure_latent_cache(const std::string& path, const std::string& bfm_checksum, int L,
                              const std::function<LatentSet()>& build, bool* rebuilt = nullptr);

}  // namespace t2m::text2bfm
