// go_diffuser_eval.h — APE / AVE of generated motions against ground truth (PRO-Motion Tab 2 and App. E, after
// TEMOS / Ghosh et al.), used to score the go-diffuser fed the GROUND-TRUTH key poses of held-out clips.
//
// Inputs per sample n: raw features [T, 257] of the ground truth and of the generation (same T). Both are turned
// into joint positions with data::features_to_positions (canonical frame: frame-0 root at x = y = 0, heading 0),
// so global errors include the drift of the integrated root velocities.
//   global  H_f[j]: world joint positions (21 joints, metres);   root = joint 0 (Hips)
//   local   L_f[j]: the body in its own heading frame: root (0, 0, height), joints from feature dims [4, 64)
//   APE[j] = 1/(N F) sum_n sum_f || H_f[j] - Ĥ_f[j] ||_2
//   AVE[j] = 1/N sum_n || δ[j] - δ̂[j] ||_2,  δ[j] = 1/(F - 1) sum_f (H_f[j] - mean_f H[j])^2 ∈ R^3
// Reported: root joint (APE/AVE of joint 0, 3D), global trajectory (joint 0, x and y only), mean local (mean over
// the 21 joints of the local positions), mean global (mean over the 21 joints of the global positions). Metres
// (APE) and square metres (AVE).
// Errors (t2m::Error "ape_ave: ..."): no samples, a pair of different lengths, T < 2, buffers not T x 257.
#pragma once
#include <nlohmann/json.hpp>
#include <vector>

namespace t2m::promotion {

struct ApeAve {
  double ape_root = 0, ape_traj = 0, ape_local = 0, ape_global = 0;
  double ave_root = 0, ave_traj = 0, ave_local = 0, ave_global = 0;
  int samples = 0;
  nlohmann::json to_json() const;
};

ApeAve ape_ave(const std::vector<const std::vector<float>*>& truth, const std::vector<const std::vector<float>*>& gen);

}  // namespace t2m::promotion
