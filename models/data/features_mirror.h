// features_mirror.h — left/right mirroring of motions and of feature sequences.
//
// The mirror is the reflection M = diag(1, -1, 1) of the world (y -> -y: the XZ plane, the sagittal plane of a
// performer at yaw 0) combined with swapping every _L joint with its _R partner (sim::kJointMirror):
//   pos'[t, j]     = M pos[t, mirror(j)]
//   rot'[t, j]     = M R[t, mirror(j)] M      quaternion (w, x, y, z) -> (w, -x, y, -z)
//   offsets'[j]    = M offsets[mirror(j)]
// so the forward-kinematics invariant of sim::Motion holds for the mirrored motion exactly (no symmetry of the
// rest skeleton is assumed). Mirroring twice is the identity (bit-exact: only signs and indices change).
// In feature space (features.h layout) the same map is linear: yaw velocity and every y component change sign,
// joint blocks are permuted by mirror(j), a 6D block (c0, c1) becomes (M c0, -M c1), contacts swap L <-> R.
// mirror_features(motion_to_features(m)) equals motion_to_features(mirror_motion(m)) up to float rounding.
// Errors: t2m::Error on inconsistent sizes (see check_motion) or a feature buffer not a multiple of kFeatureDim.
#pragma once
#include <cstdint>
#include <vector>

#include "models/data/features.h"

namespace t2m::data {

sim::Motion mirror_motion(const sim::Motion& m);
std::vector<float> mirror_features(const std::vector<float>& f);  // [T, kFeatureDim] -> same shape
// The same on raw rows: in [T, kFeatureDim] -> out [T, kFeatureDim]; in and out must not overlap; no allocation.
void mirror_feature_rows(const float* in, float* out, int64_t T);

}  // namespace t2m::data
