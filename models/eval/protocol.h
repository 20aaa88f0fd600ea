// protocol.h — the whole text-to-motion evaluation protocol over R seeded runs (Guo et al.; ARCHITECTURE.md
// section 6): what `t2m eval` reports for a generator and for the real-motion ceiling row.
//
// Each run r = 0..R-1 gets gen = Generator(run_seed(seed, r)) (models/eval/metrics.h) and:
//   1. embed(gen, r) returns the embeddings of this run (a generator samples its motions with gen here; for the
//      real-motion row embed returns the same real embeddings every run);
//   2. then, drawing from the same gen in this order: r_precision(text, motion) top-1..k, the caption-shuffled
//      control shuffled_r_precision(text, motion) top-1..k, fid(motion, real_motion) (when real_motion is
//      defined), mm_dist(text, motion), diversity(motion, diversity_pairs), multimodality(mm_motion, mm_pairs)
//      (when mm_motion is defined).
// Metric names, in report order: r_precision_top1..k, control_r_precision_top1..k, fid, mm_dist, diversity,
// multimodality (the last two optional as above). The report holds mean, std and 95% half-width per metric.
// Defaults are the protocol's: 20 runs, batches of 32, top-3, Diversity 300 pairs, MultiModality 10 pairs.
// Errors: t2m::Error from the metrics (shapes, sizes; message names the metric), runs < 1, a run whose
// embeddings switch an optional part (real_motion, mm_motion) on or off relative to run 0, at() of an unknown name.
#pragma once
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/eval/metrics.h"

namespace t2m::eval {

struct EvalEmbeddings {
  Tensor text;         // (N, D) caption embeddings (evaluator text encoder)
  Tensor motion;       // (N, D) embeddings of the motions for those captions (generated, or real for the ceiling)
  Tensor real_motion;  // (M, D) real test-motion embeddings: the FID reference; undefined = no FID
  Tensor mm_motion;    // (P, S, D) S generated motions per prompt for MultiModality; undefined = none
};

struct EvalProtocol {
  int runs = 20;
  uint64_t seed = 0;
  int64_t batch_size = 32;
  int top_k = 3;
  int64_t diversity_pairs = 300;
  int64_t mm_pairs = 10;
};

struct EvalReport {
  EvalProtocol protocol;
  std::vector<std::string> names;
  std::vector<MeanCI> values;      // values[i] belongs to names[i]
  const MeanCI& at(const std::string& name) const;
  bool has(const std::string& name) const;
  // {"runs": R, "seed": s, "batch_size": 32, ..., "metrics": {"fid": {"mean": .., "std": .., "ci95": ..}, ...}}
  nlohmann::json to_json() const;
};

EvalReport evaluate_protocol(const EvalProtocol& protocol,
                             const std::function<EvalEmbeddings(Generator& gen, int run)>& embed);

}  // namespace t2m::eval
