// go_diffuser_eval.cpp — APE / AVE over joint positions recovered from features.
#include "models/promotion/go_diffuser_eval.h"

#include <cmath>
#include <string>

#include "models/data/features.h"
#include "tensor/tensor.h"

namespace t2m::promotion {

namespace {

constexpr int J = 21;

// Local positions [T, 21, 3]: root (0, 0, height), joints 1..20 from feature dims [4, 64).
std::vector<double> local_positions(const std::vector<float>& f, int T) {
  std::vector<double> out((size_t)T * J * 3, 0.0);
  for (int t = 0; t < T; ++t) {
    const float* r = f.data() + (size_t)t * data::kFeatureDim;
    out[(size_t)t * J * 3 + 2] = r[data::kFeatRootHeight];
    for (int k = 0; k < (J - 1) * 3; ++k) out[(size_t)t * J * 3 + 3 + k] = r[data::kFeatLocalPos + k];
  }
  return out;
}

struct Acc {
  double ape = 0, ave = 0;
};

// TEMOS APE / AVE of joint j over `dims` axes, added to acc (APE summed over frames, AVE once per sample).
void accumulate(const std::vector<double>& a, const std::vector<double>& b, int T, int j, int dims, Acc* acc) {
  double mean_a[3] = {0, 0, 0}, mean_b[3] = {0, 0, 0};
  for (int t = 0; t < T; ++t) {
    double d2 = 0;
    for (int c = 0; c < dims; ++c) {
      const double x = a[((size_t)t * J + j) * 3 + c], y = b[((size_t)t * J + j) * 3 + c];
      d2 += (x - y) * (x - y);
      mean_a[c] += x / T, mean_b[c] += y / T;
    }
    acc->ape += std::sqrt(d2) / T;  // APE[j]: 1/F sum_f ||H - Ĥ||
  }
  double dv = 0;
  for (int c = 0; c < dims; ++c) {
    double va = 0, vb = 0;
    for (int t = 0; t < T; ++t) {
      va += std::pow(a[((size_t)t * J + j) * 3 + c] - mean_a[c], 2) / (T - 1);
      vb += std::pow(b[((size_t)t * J + j) * 3 + c] - mean_b[c], 2) / (T - 1);
    }
    dv += (va - vb) * (va - vb);
  }
  acc->ave += std::sqrt(dv);  // AVE[j]: ||δ - δ̂||
}

}  // namespace

nlohmann::json ApeAve::to_json() const {
  return {{"samples", samples},
          {"ape_m", {{"root_joint", ape_root}, {"global_traj", ape_traj}, {"mean_local", ape_local},
                     {"mean_global", ape_global}}},
          {"ave_m2", {{"root_joint", ave_root}, {"global_traj", ave_traj}, {"mean_local", ave_local},
                      {"mean_global", ave_global}}}};
}

// PRO-Motion App. E: APE[j] = 1/(NF) sum ||H_f[j] - Ĥ_f[j]||, AVE[j] = 1/N sum ||δ[j] - δ̂[j]||.
ApeAve ape_ave(const std::vector<const std::vector<float>*>& truth, const std::vector<const std::vector<float>*>& gen) {
  if (truth.empty() || truth.size() != gen.size())
    throw Error("ape_ave: need the same non-zero number of truth and generated motions, got " +
                std::to_string(truth.size()) + " and " + std::to_string(gen.size()));
  ApeAve r;
  Acc root, traj, loc, glob;
  for (size_t n = 0; n < truth.size(); ++n) {
    const auto& a = *truth[n];
    const auto& b = *gen[n];
    if (a.size() != b.size() || a.size() % data::kFeatureDim || a.size() < 2 * (size_t)data::kFeatureDim)
      throw Error("ape_ave: sample " + std::to_string(n) + ": buffers of " + std::to_string(a.size()) + " and " +
                  std::to_string(b.size()) + " floats (need equal T x 257 with T >= 2)");
    const int T = (int)(a.size() / data::kFeatureDim);
    const auto pa_f = data::features_to_positions(a), pb_f = data::features_to_positions(b);
    const std::vector<double> ga(pa_f.begin(), pa_f.end()), gb(pb_f.begin(), pb_f.end());
    const auto la = local_positions(a, T), lb = local_positions(b, T);
    accumulate(ga, gb, T, 0, 3, &root);
    accumulate(ga, gb, T, 0, 2, &traj);
    for (int j = 0; j < J; ++j) {
      Acc l, g;
      accumulate(la, lb, T, j, 3, &l);
      accumulate(ga, gb, T, j, 3, &g);
      loc.ape += l.ape / J, loc.ave += l.ave / J, glob.ape += g.ape / J, glob.ave += g.ave / J;
    }
  }
  const double N = (double)truth.size();
  r.samples = (int)truth.size();
  r.ape_root = root.ape / N, r.ave_root = root.ave / N, r.ape_traj = traj.ape / N, r.ave_traj = traj.ave / N;
  r.ape_local = loc.ape / N, r.ave_local = loc.ave / N, r.ape_global = glob.ape / N, r.ave_global = glob.ave / N;
  return r;
}

}  // namespace t2m::promotion
