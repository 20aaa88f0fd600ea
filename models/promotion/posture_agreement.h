// posture_agreement.h — how well sampled postures follow their scripts: the mean posecode agreement (posecodes.h
// posecode_agreement) of n posture-diffuser samples per script with the codes the script was made from, over
// `count` items spread evenly over a PoseScript-style set (usually the test split), next to the same measure for
// random poses of a reference set (usually the train split: the no-text floor). docs/PROMOTION.md section 4.
// Errors (t2m::Error): count < 1, n < 1, an empty set; those of sample_postures.
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>

#include "models/promotion/posture_diffuser_sampler.h"
#include "models/promotion/posture_script_set.h"

namespace t2m::promotion {

struct PostureAgreement {
  int scripts = 0, samples_per_script = 0;
  double model = 0;            // mean agreement of the samples with their scripts' codes
  double random_reference = 0; // mean agreement of random reference poses with the same codes
  double sampling_seconds = 0;
  nlohmann::json to_json(const PostureSampleOptions& o) const;
};

PostureAgreement posture_agreement(const PostureModel& m, const PostureScriptSet& scored,
                                   const PostureScriptSet& reference, int count, int n,
                                   const PostureSampleOptions& o, uint64_t seed);

}  // namespace t2m::promotion
