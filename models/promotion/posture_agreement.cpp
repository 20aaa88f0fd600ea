// posture_agreement.cpp — sampled-posture vs script agreement (see the header).
#include "models/promotion/posture_agreement.h"

#include <algorithm>
#include <chrono>

#include "models/promotion/posecodes.h"
#include "tensor/rng.h"

namespace t2m::promotion {

nlohmann::json PostureAgreement::to_json(const PostureSampleOptions& o) const {
  return {{"scripts", scripts}, {"samples_per_script", samples_per_script}, {"guidance", o.guidance},
          {"steps", o.steps}, {"eta", o.eta}, {"agreement_model", model},
          {"agreement_random_train_pose", random_reference}, {"sampling_seconds", sampling_seconds}};
}

PostureAgreement posture_agreement(const PostureModel& m, const PostureScriptSet& scored,
                                   const PostureScriptSet& reference, int count, int n,
                                   const PostureSampleOptions& o, uint64_t seed) {
  if (count < 1 || n < 1 || scored.size() == 0 || reference.size() == 0)
    throw Error("posture_agreement: need count >= 1, n >= 1 and non-empty sets");
  count = std::min(count, scored.size());
  std::vector<int> items;
  std::vector<std::string> scripts;
  for (int i = 0; i < count; ++i) {
    items.push_back((int)((int64_t)i * scored.size() / count));
    scripts.push_back(scored.scripts[items.back()]);
  }
  PostureAgreement r;
  r.scripts = count;
  r.samples_per_script = n;
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<float> poses = sample_postures(m, scripts, n, seed, o);
  r.sampling_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  Generator g(seed + 1);
  const auto pick = randint({(int64_t)count * n}, g, 0, reference.size()).to_vector<int64_t>();
  for (int s = 0; s < count; ++s) {
    const std::vector<int> target = scored.codes_of(items[s]);
    for (int j = 0; j < n; ++j) {
      r.model += posecode_agreement(target, pose_posecodes(poses.data() + ((size_t)s * n + j) * kPoseDim));
      r.random_reference += posecode_agreement(target, reference.codes_of((int)pick[(size_t)s * n + j]));
    }
  }
  r.model /= (double)count * n;
  r.random_reference /= (double)count * n;
  return r;
}

}  // namespace t2m::promotion
