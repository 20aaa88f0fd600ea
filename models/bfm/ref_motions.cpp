// ref_motions.cpp — loading, retargeting and replaying the reference clips of a split (see ref_motions.h).
#include "models/bfm/ref_motions.h"

#include <algorithm>
#include <exception>

#include "sim/observation.h"
#include "sim/skeleton.h"
#include "tensor/tensor.h"

namespace t2m::bfm {

int RefMotions::frames(int c) const {
  if (c < 0 || c >= clips()) throw Error("RefMotions: clip " + std::to_string(c) + " out of range [0, " +
                                         std::to_string(clips()) + ")");
  return (int)(offset[c + 1] - offset[c]);
}

int64_t RefMotions::global_frame(int c, int t) const {
  const int T = frames(c);
  if (t < 0 || t >= T)
    throw Error("RefMotions: frame " + std::to_string(t) + " out of range [0, " + std::to_string(T) + ") of clip " +
                names[c]);
  return offset[c] + t;
}

sim::QposTrajectory RefMotions::trajectory(int c, int start, int len) const {
  const int T = frames(c);
  if (len < 0) len = T - start;
  if (start < 0 || len < 1 || start + len > T)
    throw Error("RefMotions: frames [" + std::to_string(start) + ", " + std::to_string(start + len) +
                ") out of range for clip " + names[c] + " (" + std::to_string(T) + " frames)");
  sim::QposTrajectory q;
  q.frames = len;
  q.nq = nq;
  q.nv = nv;
  const int64_t g = offset[c] + start;
  q.qpos.assign(qpos.begin() + g * nq, qpos.begin() + (g + len) * nq);
  q.qvel.assign(qvel.begin() + g * nv, qvel.begin() + (g + len) * nv);
  return q;
}

void RefMotions::add(const sim::Humanoid& h, const std::string& name, const sim::QposTrajectory& q) {
  if (!h.is_humanoid()) throw Error("RefMotions: the model is not the t2m humanoid");
  if (q.frames < 2) throw Error("RefMotions: clip " + name + " has " + std::to_string(q.frames) +
                                " frames (need >= 2 for a transition)");
  const int D = sim::observation_dim((int)h.tracked_bodies().size());
  if (clips() == 0) {
    obs_dim = D;
    nq = h.model()->nq;
    nv = h.model()->nv;
  }
  const std::vector<float> o = sim::replay_observations(h, q);  // checks the trajectory's sizes
  const std::vector<float> p = sim::replay_joint_positions(h, q);
  names.push_back(name);
  offset.push_back(offset.back() + q.frames);
  obs.insert(obs.end(), o.begin(), o.end());
  body_pos.insert(body_pos.end(), p.begin(), p.end());
  qpos.insert(qpos.end(), q.qpos.begin(), q.qpos.end());
  qvel.insert(qvel.end(), q.qvel.begin(), q.qvel.end());
}

std::vector<const data::ClipInfo*> select_split_clips(const data::Manifest& manifest, data::Split split,
                                                      int max_clips) {
  std::vector<std::string> all;
  for (const auto& c : manifest.clips) all.push_back(c.name);
  const auto splits = data::assign_splits(all);
  std::vector<const data::ClipInfo*> in;
  for (const auto& c : manifest.clips)
    if (splits.at(c.name) == split) in.push_back(&c);
  std::sort(in.begin(), in.end(), [](const data::ClipInfo* a, const data::ClipInfo* b) { return a->name < b->name; });
  if (max_clips > 0 && (int)in.size() > max_clips) {
    std::vector<const data::ClipInfo*> sub;
    const double stride = (double)in.size() / max_clips;
    for (int i = 0; i < max_clips; ++i) sub.push_back(in[(size_t)(i * stride)]);
    in = sub;
  }
  if (in.empty()) throw Error(std::string("no clips in the ") + data::split_name(split) + " split of the manifest");
  return in;
}

RefMotions load_ref_motions(const sim::Humanoid& h, const data::Manifest& manifest, data::Split split,
                            int max_clips) {
  return load_ref_motions(h, select_split_clips(manifest, split, max_clips));
}

RefMotions load_ref_motions(const sim::Humanoid& h, const std::vector<const data::ClipInfo*>& sel) {
  const int N = (int)sel.size();
  std::vector<sim::QposTrajectory> traj(N);
  std::vector<std::string> err(N);
#pragma omp parallel for schedule(dynamic)
  for (int i = 0; i < N; ++i) {
    try {
      traj[i] = sim::retarget(h, data::load_clip(*sel[i]));
    } catch (const std::exception& e) {
      err[i] = e.what();
    }
  }
  RefMotions r;
  for (int i = 0; i < N; ++i) {
    if (!err[i].empty()) throw Error("reference clip " + sel[i]->name + ": " + err[i]);
    if (traj[i].frames < 2) continue;  // nothing to track
    r.add(h, sel[i]->name, traj[i]);
  }
  if (r.clips() == 0) throw Error("no usable reference clips (all shorter than 2 frames)");
  return r;
}

void append_static_holds(RefMotions& dst, const RefMotions& src, const sim::Humanoid& h, const std::vector<int>& clips,
                         int frames) {
  if (frames < 2) throw Error("append_static_holds: frames must be >= 2, got " + std::to_string(frames));
  const int nq = h.model()->nq, nv = h.model()->nv;
  std::vector<std::string> names{"hold:qpos0"};
  std::vector<double> poses(h.model()->qpos0, h.model()->qpos0 + nq);  // copied first: dst may be src
  for (int c : clips) {
    const double* p = src.qpos_at(c, 0);  // checks c
    poses.insert(poses.end(), p, p + nq);
    names.push_back("hold:" + src.names[(size_t)c]);
  }
  for (size_t i = 0; i < names.size(); ++i) dst.add(h, names[i], still_trajectory(poses.data() + i * nq, nq, nv, frames));
}

sim::QposTrajectory still_trajectory(const double* qpos, int nq, int nv, int frames) {
  if (frames < 1) throw Error("still_trajectory: frames must be >= 1, got " + std::to_string(frames));
  sim::QposTrajectory q;
  q.frames = frames;
  q.nq = nq;
  q.nv = nv;
  for (int t = 0; t < frames; ++t) q.qpos.insert(q.qpos.end(), qpos, qpos + nq);
  q.qvel.assign((size_t)frames * nv, 0.0);
  return q;
}

std::vector<int> spread_indices(int n, int count) {
  std::vector<int> out;
  if (n <= 0 || count <= 0) return out;
  if (count >= n) count = n;
  const double stride = (double)n / count;
  for (int i = 0; i < count; ++i) out.push_back((int)(i * stride));
  return out;
}

}  // namespace t2m::bfm
