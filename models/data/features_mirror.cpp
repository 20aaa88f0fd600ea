// features_mirror.cpp — reflection y -> -y with L/R joint swap, on motions and on feature rows.
#include "models/data/features_mirror.h"

#include <string>

#include "tensor/tensor.h"

namespace t2m::data {

static constexpr int J = kFeatureJoints;
static constexpr int D = kFeatureDim;

sim::Motion mirror_motion(const sim::Motion& m) {
  check_motion(m, "mirror_motion");
  sim::Motion o = m;
  for (int t = 0; t < m.frames; ++t)
    for (int j = 0; j < J; ++j) {
      const int s = sim::kJointMirror[j];
      const float* p = m.pos.data() + ((size_t)t * J + s) * 3;
      float* po = o.pos.data() + ((size_t)t * J + j) * 3;
      po[0] = p[0]; po[1] = -p[1]; po[2] = p[2];
      const float* q = m.rot.data() + ((size_t)t * J + s) * 4;
      float* qo = o.rot.data() + ((size_t)t * J + j) * 4;
      qo[0] = q[0]; qo[1] = -q[1]; qo[2] = q[2]; qo[3] = -q[3];
    }
  if (m.offsets.size() == (size_t)J * 3)
    for (int j = 0; j < J; ++j) {
      const int s = sim::kJointMirror[j];
      o.offsets[3 * j] = m.offsets[3 * s];
      o.offsets[3 * j + 1] = -m.offsets[3 * s + 1];
      o.offsets[3 * j + 2] = m.offsets[3 * s + 2];
    }
  return o;
}

std::vector<float> mirror_features(const std::vector<float>& f) {
  if (f.empty() || f.size() % D != 0)
    throw Error("mirror_features: feature buffer has " + std::to_string(f.size()) +
                " floats, not a positive multiple of " + std::to_string(D));
  std::vector<float> o(f.size());
  mirror_feature_rows(f.data(), o.data(), (int64_t)(f.size() / D));
  return o;
}

void mirror_feature_rows(const float* in, float* out, int64_t T) {
  static constexpr int kContactSwap[4] = {2, 3, 0, 1};  // Foot_L, Toes_L, Foot_R, Toes_R
  for (int64_t t = 0; t < T; ++t) {
    const float* a = in + t * D;
    float* b = out + t * D;
    b[kFeatRootYawVel] = -a[kFeatRootYawVel];
    b[kFeatRootVel] = a[kFeatRootVel];
    b[kFeatRootVel + 1] = -a[kFeatRootVel + 1];
    b[kFeatRootHeight] = a[kFeatRootHeight];
    for (int j = 0; j < J; ++j) {
      const int s = sim::kJointMirror[j];
      if (j > 0) {  // the root never swaps, so s > 0 here too
        const float* l = a + kFeatLocalPos + 3 * (s - 1);
        float* lo = b + kFeatLocalPos + 3 * (j - 1);
        lo[0] = l[0]; lo[1] = -l[1]; lo[2] = l[2];
      }
      const float* r = a + kFeatRot6d + 6 * s;
      float* ro = b + kFeatRot6d + 6 * j;
      ro[0] = r[0]; ro[1] = -r[1]; ro[2] = r[2];   //  M c0
      ro[3] = -r[3]; ro[4] = r[4]; ro[5] = -r[5];  // -M c1
      const float* v = a + kFeatJointVel + 3 * s;
      float* vo = b + kFeatJointVel + 3 * j;
      vo[0] = v[0]; vo[1] = -v[1]; vo[2] = v[2];
    }
    for (int k = 0; k < 4; ++k) b[kFeatContact + k] = a[kFeatContact + kContactSwap[k]];
  }
}

}  // namespace t2m::data
