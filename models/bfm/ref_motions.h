// ref_motions.h — the reference motions the BFM trains and is evaluated on: clips of one data split retargeted to
// the humanoid (sim/retarget), with per frame the state s_t of the kinematic replay (what Eq 2 encodes with B),
// qpos / qvel (what an episode is started from and what PD tracks) and the 21 body positions (what tracking is
// scored against).
//
//   auto refs = load_ref_motions(*h, manifest, data::Split::train, /*max_clips=*/300);
//   refs.obs_at(c, t)  -> s_t of clip c [obs_dim];  refs.trajectory(c) -> sim::QposTrajectory of clip c
//
// Clip selection (deterministic): the split's clips sorted by name; with max_clips > 0 and more clips than that,
// every k-th clip with k = n / max_clips (real-valued stride, so the choice spreads over all content labels).
// Errors (t2m::Error): a clip with fewer than 2 frames (add), an index out of range, a model that is not our
// humanoid, no clips in the selection, a clip that fails to load (names it).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "models/data/dataset.h"
#include "models/data/splits.h"
#include "sim/humanoid.h"
#include "sim/retarget.h"

namespace t2m::bfm {

struct RefMotions {
  int obs_dim = 0, nq = 0, nv = 0;
  std::vector<std::string> names;
  std::vector<int64_t> offset{0};  // [clips + 1]: clip c holds global frames offset[c] .. offset[c + 1) - 1
  std::vector<float> obs;          // [F, obs_dim]  kinematic-replay state s_t (sim/observation.h)
  std::vector<float> body_pos;     // [F, 21, 3]    body origins (m), world frame
  std::vector<double> qpos, qvel;  // [F, nq], [F, nv]

  int clips() const { return (int)names.size(); }
  int frames(int c) const;
  int64_t total_frames() const { return offset.back(); }
  int64_t global_frame(int c, int t) const;  // checks c and t
  const float* obs_at(int c, int t) const { return obs.data() + global_frame(c, t) * obs_dim; }
  const double* qpos_at(int c, int t) const { return qpos.data() + global_frame(c, t) * nq; }
  const double* qvel_at(int c, int t) const { return qvel.data() + global_frame(c, t) * nv; }
  // Frames [start, start + len) of clip c as a trajectory (len -1: to the end).
  sim::QposTrajectory trajectory(int c, int start = 0, int len = -1) const;

  // Appends one clip (kinematic replay of q computes obs and body_pos).
  void add(const sim::Humanoid& h, const std::string& name, const sim::QposTrajectory& q);
};

// Clip names of `split` in the manifest, subsampled to at most max_clips (0 = all) as described above.
std::vector<const data::ClipInfo*> select_split_clips(const data::Manifest& manifest, data::Split split,
                                                      int max_clips);

// Loads, retargets and replays the selected clips (OpenMP over clips, results in name order).
RefMotions load_ref_motions(const sim::Humanoid& h, const data::Manifest& manifest, data::Split split,
                            int max_clips = 0);
// The same for the given clips (in their order; clips shorter than 2 frames are left out).
RefMotions load_ref_motions(const sim::Humanoid& h, const std::vector<const data::ClipInfo*>& clips);

// Standing-still ("hold") references, appended to dst as clips named "hold:qpos0" and "hold:<clip>": the
// humanoid's standing start qpos0 (where generation starts) and the first frame of each listed clip of src, each
// held for `frames` frames with zero velocity. Real clips never stand still for long; these teach
// (`t2m train bfm --static-holds`) and test (`t2m eval track --stand`) holding a pose, i.e. z = B(s) of a static
// state. dst may be src.
// Errors: a clip index out of range, frames < 2 (t2m::Error).
void append_static_holds(RefMotions& dst, const RefMotions& src, const sim::Humanoid& h, const std::vector<int>& clips,
                         int frames);

// One pose qpos [nq] held still for `frames` frames (zero velocity). Error: frames < 1.
sim::QposTrajectory still_trajectory(const double* qpos, int nq, int nv, int frames);

// `count` of the indices 0..n-1 spread evenly (every k-th, k = n / count, real-valued); all of them when count >= n.
std::vector<int> spread_indices(int n, int count);

}  // namespace t2m::bfm
