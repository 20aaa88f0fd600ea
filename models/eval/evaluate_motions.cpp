// evaluate_motions.cpp — embed a captioned motion set once with the evaluator, then run the seeded protocol.
#include "models/eval/evaluate_motions.h"

#include <string>

#include "tensor/ops.h"

namespace t2m::eval {

EvalReport evaluate_motions(const text::RetrievalBundle& evaluator, const MotionSet& set, const Tensor& reference,
                            const EvalProtocol& protocol) {
  const int64_t N = (int64_t)set.motions.size();
  if ((int64_t)set.captions.size() != N)
    throw Error("evaluate_motions: " + std::to_string(set.captions.size()) + " captions for " + std::to_string(N) +
                " motions");
  if (N < protocol.batch_size)
    throw Error("evaluate_motions: " + std::to_string(N) + " motions, R-precision needs at least one batch of " +
                std::to_string(protocol.batch_size));
  EvalProtocol proto = protocol;
  if (proto.diversity_pairs > N) proto.diversity_pairs = N;  // Diversity draws distinct first indices
  EvalEmbeddings e;
  e.text = embed_texts(evaluator, set.captions);
  e.motion = embed_motions(evaluator, set.motions);
  e.real_motion = reference;
  if (!set.groups.empty()) {
    const size_t S = set.groups[0].size();
    std::vector<const std::vector<float>*> flat;
    for (const auto& g : set.groups) {
      if (g.size() != S || S < 2)
        throw Error("evaluate_motions: MultiModality groups need the same number (>= 2) of samples, got " +
                    std::to_string(g.size()) + " and " + std::to_string(S));
      flat.insert(flat.end(), g.begin(), g.end());
    }
    if (proto.mm_pairs > (int64_t)S) proto.mm_pairs = (int64_t)S;  // distinct first indices per prompt
    const Tensor m = embed_motions(evaluator, flat);
    e.mm_motion = m.reshape({(int64_t)set.groups.size(), (int64_t)S, m.size(1)});
  }
  return evaluate_protocol(proto, [&](Generator&, int) { return e; });
}

}  // namespace t2m::eval
