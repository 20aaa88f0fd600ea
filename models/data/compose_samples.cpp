// compose_samples.cpp — root-aligned concatenation with a smoothstep cross-fade, and its clip/caption wrappers.
#include "models/data/compose_samples.h"

#include <cmath>

#include "models/data/captions.h"
#include "models/data/features.h"
#include "models/data/features_math.h"

namespace t2m::data {

static constexpr int J = kFeatureJoints;

sim::Motion compose_motions(const sim::Motion& a, const sim::Motion& b, int K) {
  check_motion(a, "compose_motions (A)");
  check_motion(b, "compose_motions (B)");
  if (K < 1 || K >= a.frames || K >= b.frames)
    throw Error("compose_motions: blend " + std::to_string(K) + " frames must be in [1, min(" +
                std::to_string(a.frames) + ", " + std::to_string(b.frames) + ") - 1]");
  if (std::fabs(a.fps - b.fps) > 1e-6)
    throw Error("compose_motions: fps differ (" + std::to_string(a.fps) + " vs " + std::to_string(b.fps) + ")");
  const int s = a.frames - K;
  // Move B: root ground point of frame 0 to the origin, turn by the heading difference, translate to A[s].
  sim::Motion mb = b;
  const float* as = a.pos.data() + (size_t)s * J * 3;
  const double dyaw = heading_yaw(as) - heading_yaw(b.pos.data());
  const double bx = b.pos[0], by = b.pos[1];
  for (size_t i = 0; i < mb.pos.size(); i += 3) {
    mb.pos[i] = (float)((double)b.pos[i] - bx);
    mb.pos[i + 1] = (float)((double)b.pos[i + 1] - by);
  }
  transform_motion(mb, dyaw, as[0], as[1]);

  sim::Motion out;
  out.frames = a.frames + b.frames - K;
  out.fps = a.fps;
  out.offsets = a.offsets;
  out.pos.resize((size_t)out.frames * J * 3);
  out.rot.resize((size_t)out.frames * J * 4);
  std::copy(a.pos.begin(), a.pos.begin() + (size_t)s * J * 3, out.pos.begin());
  std::copy(a.rot.begin(), a.rot.begin() + (size_t)s * J * 4, out.rot.begin());
  for (int i = 0; i < K; ++i) {
    const double x = (i + 1.0) / (K + 1.0), w = x * x * (3.0 - 2.0 * x);  // smoothstep
    const size_t ta = (size_t)(s + i), tb = (size_t)i;
    for (int k = 0; k < J * 3; ++k)
      out.pos[ta * J * 3 + k] = (float)((1.0 - w) * a.pos[ta * J * 3 + k] + w * mb.pos[tb * J * 3 + k]);
    for (int j = 0; j < J; ++j) {
      const float* qa = &a.rot[(ta * J + j) * 4];
      const float* qb = &mb.rot[(tb * J + j) * 4];
      double dot = 0;
      for (int k = 0; k < 4; ++k) dot += (double)qa[k] * qb[k];
      const double sb = dot < 0 ? -1.0 : 1.0;
      double q[4];
      for (int k = 0; k < 4; ++k) q[k] = (1.0 - w) * qa[k] + w * sb * qb[k];
      fm::quat_normalize(q);
      for (int k = 0; k < 4; ++k) out.rot[(ta * J + j) * 4 + k] = (float)q[k];
    }
  }
  std::copy(mb.pos.begin() + (size_t)K * J * 3, mb.pos.end(), out.pos.begin() + (size_t)a.frames * J * 3);
  std::copy(mb.rot.begin() + (size_t)K * J * 4, mb.rot.end(), out.rot.begin() + (size_t)a.frames * J * 4);
  return out;
}

sim::Motion clip_to_motion(const MotionClip& c) {
  if (c.frames < 1 || c.features.size() != (size_t)c.frames * kFeatureDim)
    throw Error("clip_to_motion: clip '" + c.name + "' has " + std::to_string(c.frames) + " frames and " +
                std::to_string(c.features.size()) + " feature floats");
  sim::Motion m;
  m.frames = c.frames;
  m.fps = sim::kCanonicalFps;
  m.pos = features_to_positions(c.features);
  m.rot = features_to_rotations(c.features);
  return m;
}

MotionClip compose_clips(const MotionClip& a, const MotionClip& b, uint64_t seed, uint64_t index, int blend) {
  sim::Motion m = compose_motions(clip_to_motion(a), clip_to_motion(b), blend);
  auto caption_of = [&](const MotionClip& c, uint64_t k) {
    return c.caption.empty() ? make_caption(c.content, c.style, seed, k).text : c.caption;
  };
  MotionClip out;
  out.name = a.name + "+" + b.name;
  out.caption = compose_captions(caption_of(a, 2 * index), caption_of(b, 2 * index + 1));
  out.frames = m.frames;
  out.features = motion_to_features(m);
  return out;
}

std::vector<MotionClip> make_composed_clips(const std::vector<MotionClip>& clips, int count, uint64_t seed,
                                            int blend) {
  if (count < 0) throw Error("make_composed_clips: count must be >= 0, got " + std::to_string(count));
  if (count > 0 && clips.empty()) throw Error("make_composed_clips: no clips to compose");
  std::vector<int> ok;  // clips long enough to blend
  for (size_t i = 0; i < clips.size(); ++i)
    if (clips[i].frames > blend) ok.push_back((int)i);
  if (count > 0 && ok.empty())
    throw Error("make_composed_clips: no clip has more than " + std::to_string(blend) + " frames");
  std::vector<MotionClip> out;
  out.reserve(count);
  const uint32_t n = (uint32_t)ok.size();
  for (int k = 0; k < count; ++k) {
    uint32_t r[4];
    loader_random_bits(seed, 0xC0, (uint64_t)k, r);
    uint32_t ia = r[0] % n, ib = r[1] % n;
    if (n > 1 && ib == ia) ib = (ia + 1 + r[2] % (n - 1)) % n;
    out.push_back(compose_clips(clips[ok[ia]], clips[ok[ib]], seed, (uint64_t)k, blend));
  }
  return out;
}

}  // namespace t2m::data
