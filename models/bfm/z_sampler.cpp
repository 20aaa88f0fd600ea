// z_sampler.cpp — the tracking / goal / random latent mix for FB training (see z_sampler.h).
#include "models/bfm/z_sampler.h"

#include <cmath>
#include <cstring>

#include "models/bfm/sphere_projection.h"
#include "tensor/ops.h"

namespace t2m::bfm {

Tensor sample_training_z(int64_t n, const ZMix& mix, const RefMotions& refs, int L, const Tensor& next_obs,
                         const EncodeFn& encode, int z_dim, Generator& gen) {
  if (!(mix.track >= 0 && mix.goal >= 0 && mix.track + mix.goal <= 1.0 + 1e-12))
    throw Error("sample_training_z: ratios track " + std::to_string(mix.track) + ", goal " + std::to_string(mix.goal) +
                " (each in [0, 1], sum <= 1)");
  if (n < 1 || z_dim < 1) throw Error("sample_training_z: n = " + std::to_string(n) + ", z_dim " + std::to_string(z_dim));
  if (mix.goal > 0 && (!next_obs.defined() || next_obs.dim() != 2 || next_obs.size(0) != n))
    throw Error("sample_training_z: next_obs must have " + std::to_string(n) + " rows, got " +
                (next_obs.defined() ? shape_str(next_obs.shape()) : std::string("undefined")));
  // Kinds, then the random sphere points, then the tracking frames: always in this order.
  const std::vector<float> u = rand_uniform({n}, gen).to_vector<float>();
  const std::vector<float> g = rand_normal({n, z_dim}, gen).to_vector<float>();
  std::vector<int64_t> track_rows, goal_rows;
  for (int64_t i = 0; i < n; ++i) {
    if (u[i] < mix.track) track_rows.push_back(i);
    else if (u[i] < mix.track + mix.goal) goal_rows.push_back(i);
  }
  Tensor z = project_rows(Tensor::from_vector(g, {n, z_dim}), std::sqrt((double)z_dim));
  float* zp = z.data<float>();
  const auto put = [&](const std::vector<int64_t>& rows, const Tensor& src, const char* what) {
    if (rows.empty()) return;
    const Tensor c = src.contiguous();
    if (c.dim() != 2 || c.size(0) != (int64_t)rows.size() || c.size(1) != z_dim)
      throw Error(std::string("sample_training_z: ") + what + " latents have shape " + shape_str(c.shape()) +
                  ", expected " + shape_str({(int64_t)rows.size(), z_dim}));
    for (size_t k = 0; k < rows.size(); ++k) std::memcpy(zp + rows[k] * z_dim, c.data<float>() + k * z_dim, 4 * z_dim);
  };
  if (!track_rows.empty()) {
    // Start frames: uniform over the global frames that have a successor (T - 1 per clip).
    const int64_t valid = refs.total_frames() - refs.clips();
    if (valid < 1) throw Error("sample_training_z: the reference motions have no transitions");
    const int64_t m = (int64_t)track_rows.size();
    std::vector<int64_t> clip(m), frame(m);
    const Tensor r = randint({m}, gen, 0, valid);
    for (int64_t k = 0; k < m; ++k) {
      int64_t v = r.data<int64_t>()[k];
      // Global frame index among valid frames -> (clip, t): clip c holds frames - 1 valid starts.
      int lo = 0, hi = refs.clips() - 1;
      while (lo < hi) {  // smallest c with offset[c + 1] - (c + 1) > v
        const int mid = (lo + hi) / 2;
        if (refs.offset[mid + 1] - (mid + 1) > v) hi = mid;
        else lo = mid + 1;
      }
      clip[k] = lo;
      frame[k] = v - (refs.offset[lo] - lo);
    }
    put(track_rows, window_latents(refs, clip.data(), frame.data(), m, L, encode), "tracking");
  }
  if (!goal_rows.empty()) {
    const int64_t m = (int64_t)goal_rows.size();
    std::vector<int64_t> src(m);
    for (int64_t k = 0; k < m; ++k) src[k] = (goal_rows[k] + n / 2) % n;
    const Tensor states = index_select(next_obs, 0, Tensor::from_vector(src, {m}));
    put(goal_rows, encode(states), "goal");
  }
  return z;
}

}  // namespace t2m::bfm
