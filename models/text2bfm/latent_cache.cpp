// latent_cache.cpp — Eq 2 latents of a split: extraction (retarget -> replay -> B -> window means), the cache
// file and its validation (see latent_cache.h).
#include "models/text2bfm/latent_cache.h"

#include <atomic>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "models/bfm/ref_motions.h"
#include "nn/checkpoint.h"
#include "nn/fnv1a.h"
#include "sim/retarget.h"

namespace t2m::text2bfm {

void LatentSet::add_clip(bfm::FbAgent& agent, const std::string& name, const std::string& content_label,
                         const std::string& style_label, const Tensor& clip_states) {
  if (clip_states.dim() != 2 || clip_states.size(0) < 2)
    throw Error("latent cache: clip " + name + " needs states [T >= 2, S], got " + shape_str(clip_states.shape()));
  const Tensor zc = agent.infer_tracking_z(clip_states, window).contiguous();  // [T-1, d]  Eq 2
  const int64_t n = zc.size(0), d = zc.size(1), S = clip_states.size(1);
  if (names.empty()) {
    z_dim = d;
    obs_dim = S;
  } else if (d != z_dim || S != obs_dim) {
    throw Error("latent cache: clip " + name + " has z_dim " + std::to_string(d) + " / obs_dim " + std::to_string(S) +
                ", the set has " + std::to_string(z_dim) + " / " + std::to_string(obs_dim));
  }
  const Tensor s = clip_states.contiguous();
  names.push_back(name);
  content.push_back(content_label);
  style.push_back(style_label);
  offset.push_back(offset.back() + n);
  z.insert(z.end(), zc.data<float>(), zc.data<float>() + n * d);
  states.insert(states.end(), s.data<float>(), s.data<float>() + n * S);  // s_0 .. s_{T-2}
}

void LatentSet::validate(const std::string& where) const {
  const auto fail = [&](const std::string& m) { throw Error(where + m); };
  if (offset.empty() || offset.front() != 0) fail("offsets must start at 0");
  if ((int64_t)offset.size() != (int64_t)names.size() + 1)
    fail(std::to_string(offset.size()) + " offsets for " + std::to_string(names.size()) + " clips");
  if (content.size() != names.size() || style.size() != names.size())
    fail("label count differs from the clip count " + std::to_string(names.size()));
  for (size_t c = 0; c + 1 < offset.size(); ++c)
    if (offset[c + 1] <= offset[c]) fail("clip " + names[c] + " has no frames (offsets must increase)");
  if (z_dim < 1 || obs_dim < 1) fail("z_dim and obs_dim must be >= 1");
  if ((int64_t)z.size() != total_frames() * z_dim || (int64_t)states.size() != total_frames() * obs_dim)
    fail("z has " + std::to_string(z.size() / z_dim) + " rows and states " + std::to_string(states.size() / obs_dim) +
         ", offsets say " + std::to_string(total_frames()));
  for (float v : z)
    if (!std::isfinite(v)) fail("non-finite latent");
  for (float v : states)
    if (!std::isfinite(v)) fail("non-finite state");
  if (window < 1) fail("window L must be >= 1");
}

std::string file_checksum(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error("cannot read '" + path + "' for its checksum");
  std::ostringstream ss;
  ss << f.rdbuf();
  // FNV-1a 64 over every byte. Not a CRC: a checkpoint ends with the CRC of its own bytes, and the CRC of a
  // message followed by its CRC is the same constant for every message.
  const std::string bytes = ss.str();
  return nn::fnv1a_hex(nn::fnv1a64(bytes.data(), bytes.size(), nn::kFnv1aBfmOffset));
}

// Text2BFM Eq 2 over every clip of a split.
LatentSet extract_split_latents(bfm::FbAgent& agent, const sim::Humanoid& h, const data::Manifest& manifest,
                                data::Split split, const std::string& bfm_checksum, int L,
                                const std::function<void(int, int)>& progress) {
  const auto sel = bfm::select_split_clips(manifest, split, 0);
  const int N = (int)sel.size();
  std::vector<std::vector<float>> obs(N);
  std::vector<int> frames(N, 0);
  std::vector<std::string> err(N);
  std::atomic<int> done{0};
#pragma omp parallel for schedule(dynamic)
  for (int i = 0; i < N; ++i) {
    try {
      const sim::QposTrajectory q = sim::retarget(h, data::load_clip(*sel[i]));
      frames[i] = q.frames;
      if (q.frames >= 2) obs[i] = sim::replay_observations(h, q);
    } catch (const std::exception& e) {
      err[i] = e.what();
    }
    const int k = ++done;
    if (progress) {
#pragma omp critical(latent_progress)
      progress(k, N);
    }
  }
  LatentSet s;
  s.split = data::split_name(split);
  s.bfm_checksum = bfm_checksum;
  s.window = L;
  for (int i = 0; i < N; ++i) {
    if (!err[i].empty()) throw Error("latent extraction: clip " + sel[i]->name + ": " + err[i]);
    if (frames[i] < 2) continue;
    const int64_t S = (int64_t)obs[i].size() / frames[i];
    s.add_clip(agent, sel[i]->name, sel[i]->content_label, sel[i]->style_label,
               Tensor::from_vector(obs[i], {frames[i], S}));
    std::vector<float>().swap(obs[i]);
  }
  if (s.clips() == 0) throw Error("latent extraction: no clip of the split has 2 frames or more");
  return s;
}

void save_latent_set(const LatentSet& s, const std::string& path) {
  s.validate("latent cache " + path + ": ");
  nn::Checkpoint ck;
  ck.meta = {{"format", "t2m-latents-1"},
             {"split", s.split},
             {"bfm_checksum", s.bfm_checksum},
             {"window", s.window},
             {"clips", s.names},
             {"content", s.content},
             {"style", s.style},
             {"data", "Bandai-Namco-Research-Motiondataset (CC BY-NC 4.0), " + s.split +
                          " split, retargeted kinematic replay; z = Text2BFM Eq 2 with the frozen BFM B"}};
  const int64_t F = s.total_frames();
  ck.put("z", Tensor::from_vector(s.z, {F, s.z_dim}));
  ck.put("states", Tensor::from_vector(s.states, {F, s.obs_dim}));
  ck.put("offset", Tensor::from_vector(s.offset, {(int64_t)s.offset.size()}));
  if (const auto p = std::filesystem::path(path).parent_path(); !p.empty()) std::filesystem::create_directories(p);
  ck.save(path);
}

LatentSet load_latent_set(const std::string& path) {
  const std::string where = "latent cache " + path + ": ";
  const nn::Checkpoint ck = nn::Checkpoint::load(path);  // magic, version, CRC
  if (!ck.meta.is_object() || ck.meta.value("format", std::string()) != "t2m-latents-1")
    throw Error(where + "not a latent cache (format tag is not t2m-latents-1)");
  LatentSet s;
  try {
    s.split = ck.meta.at("split").get<std::string>();
    s.bfm_checksum = ck.meta.at("bfm_checksum").get<std::string>();
    s.window = ck.meta.at("window").get<int>();
    s.names = ck.meta.at("clips").get<std::vector<std::string>>();
    s.content = ck.meta.at("content").get<std::vector<std::string>>();
    s.style = ck.meta.at("style").get<std::vector<std::string>>();
  } catch (const std::exception& e) {
    throw Error(where + "bad metadata: " + e.what());
  }
  for (const char* n : {"z", "states", "offset"})
    if (!ck.has(n)) throw Error(where + "missing tensor '" + n + "'");
  const Tensor &z = ck.get("z"), &st = ck.get("states"), &off = ck.get("offset");
  if (z.dim() != 2 || z.dtype() != DType::f32 || st.dim() != 2 || st.dtype() != DType::f32 || off.dim() != 1 ||
      off.dtype() != DType::i64)
    throw Error(where + "tensors must be z [F, d] f32, states [F, S] f32, offset [C + 1] i64; got " +
                shape_str(z.shape()) + ", " + shape_str(st.shape()) + ", " + shape_str(off.shape()));
  s.z_dim = z.size(1);
  s.obs_dim = st.size(1);
  const Tensor zc = z.contiguous(), sc = st.contiguous(), oc = off.contiguous();
  s.z.assign(zc.data<float>(), zc.data<float>() + zc.numel());
  s.states.assign(sc.data<float>(), sc.data<float>() + sc.numel());
  s.offset.assign(oc.data<int64_t>(), oc.data<int64_t>() + oc.numel());
  s.validate(where);
  return s;
}

LatentSet ensure_latent_cache(const std::string& path, const std::string& bfm_checksum, int L,
                              const std::function<LatentSet()>& build, bool* rebuilt) {
  if (std::filesystem::exists(path)) {
    LatentSet s;
    try {
      s = load_latent_set(path);
    } catch (const std::exception& e) {
      throw Error(std::string(e.what()) + " (remove the file to rebuild the cache)");
    }
    if (s.bfm_checksum == bfm_checksum && s.window == L) {
      if (rebuilt) *rebuilt = false;
      return s;
    }
  }
  LatentSet s = build();
  if (s.bfm_checksum != bfm_checksum || s.window != L)
    throw Error("latent cache " + path + ": the build gave checksum " + s.bfm_checksum + " / L " +
                std::to_string(s.window) + ", expected " + bfm_checksum + " / " + std::to_string(L));
  save_latent_set(s, path);
  if (rebuilt) *rebuilt = true;
  return s;
}

}  // namespace t2m::text2bfm
