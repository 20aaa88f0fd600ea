// compose_samples.h — compositional samples "A, then B": two clips concatenated with a short blend.
//
// compose_motions(a, b, K) (position space, root aligned):
//   1. s = a.frames - K is the first frame of the blend. B is moved rigidly (rotation about Z, then planar
//      translation; heights unchanged) so that its frame-0 heading equals A's heading at frame s and its frame-0
//      root ground point equals A's root ground point at frame s.
//   2. frames [0, s) are A; frames [s, a.frames) blend A[t] with the moved B[t - s] using the weight
//      w_i = smoothstep((i + 1) / (K + 1)), i = t - s: positions (1 - w) pA + w pB per joint, rotations by
//      normalised lerp of sign-aligned quaternions; frames [a.frames, a.frames + b.frames - K) are the moved B.
//   Output: a.frames + b.frames - K frames, fps and offsets of A. In the blend window pos is the blend of
//   positions (what the features use), so the FK invariant of sim::Motion holds only approximately there.
//   K must be in [1, min(a.frames, b.frames) - 1].
// compose_clips(a, b, ...) does the same on MotionClips (features -> canonical positions/rotations with the exact
// inverse, compose, features again) and sets the caption "<caption A>, then <caption B>", where each part is
// a.caption if set, else make_caption(labels, seed, index).
// Errors: t2m::Error when K < 1, K >= a.frames or K >= b.frames, fps differ, or sizes are inconsistent.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "models/data/loader.h"
#include "sim/skeleton.h"

namespace t2m::data {

inline constexpr int kDefaultBlendFrames = 10;

sim::Motion compose_motions(const sim::Motion& a, const sim::Motion& b, int blend = kDefaultBlendFrames);

// Canonical motion (positions and rotations) of a clip's raw features; offsets empty, fps 30.
sim::Motion clip_to_motion(const MotionClip& c);

MotionClip compose_clips(const MotionClip& a, const MotionClip& b, uint64_t seed, uint64_t index,
                         int blend = kDefaultBlendFrames);

// `count` compositions of random pairs (A != B when possible) of the clips with more than `blend` frames, drawn
// with the seed: pair k uses loader_random_bits(seed, stream 0xC0, k). Deterministic. Throws when count > 0 and
// no clip is long enough.
std::vector<MotionClip> make_composed_clips(const std::vector<MotionClip>& clips, int count, uint64_t seed,
                                            int blend = kDefaultBlendFrames);

}  // namespace t2m::data
