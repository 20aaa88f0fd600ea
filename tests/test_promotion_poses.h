// test_promotion_poses.h — hand-made joint positions [21, 3] for the PRO-Motion posecode and planner tests.
#pragma once
#include "sim/skeleton.h"

namespace t2m::testing {

struct Joints {
  float p[21][3];
  void set(int j, float x, float y, float z) { p[j][0] = x, p[j][1] = y, p[j][2] = z; }
  const float* data() const { return &p[0][0]; }
};

using namespace t2m::sim;

// Upright, arms hanging, feet under the hips on the floor (x forward, y left, z up).
inline Joints standing() {
  Joints J;
  J.set(kHips, 0, 0, 0.95f);
  J.set(kSpine, 0, 0, 1.05f);
  J.set(kChest, 0, 0, 1.25f);
  J.set(kNeck, 0, 0, 1.45f);
  J.set(kHead, 0, 0, 1.60f);
  for (int s : {1, -1}) {
    bool L = s > 0;
    J.set(L ? kShoulderL : kShoulderR, 0, 0.05f * s, 1.40f);
    J.set(L ? kUpperArmL : kUpperArmR, 0, 0.18f * s, 1.40f);
    J.set(L ? kLowerArmL : kLowerArmR, 0, 0.18f * s, 1.12f);
    J.set(L ? kHandL : kHandR, 0, 0.18f * s, 0.85f);
    J.set(L ? kUpperLegL : kUpperLegR, 0, 0.10f * s, 0.92f);
    J.set(L ? kLowerLegL : kLowerLegR, 0, 0.10f * s, 0.50f);
    J.set(L ? kFootL : kFootR, 0, 0.10f * s, 0.08f);
    J.set(L ? kToesL : kToesR, 0.12f, 0.10f * s, 0.02f);
  }
  return J;
}

}  // namespace t2m::testing
