// evaluate_motions.cpp — embed a captioned motion set once with the evaluator, then run the seeded protocol.
#include "models/eval/evaluate_motions.h"

#include <cstdio>
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

MotionSet motion_set_of(const MotionDir& md) {
  MotionSet set;
  for (int64_t i : md.main_set()) {
    set.captions.push_back(md.entries[i].caption);
    set.motions.push_back(&md.entries[i].features);
  }
  for (const auto& g : md.prompt_groups()) {
    set.groups.emplace_back();
    for (int64_t i : g) set.groups.back().push_back(&md.entries[i].features);
  }
  return set;
}

std::string report_lines(const EvalReport& rep) {
  std::string out;
  char b[160];
  for (size_t i = 0; i < rep.names.size(); ++i) {
    std::snprintf(b, sizeof b, "  %-26s %8.4f +- %.4f\n", rep.names[i].c_str(), rep.values[i].mean,
                  rep.values[i].ci95);
    out += b;
  }
  return out;
}

std::string report_markdown_row(const std::string& label, const EvalReport& rep) {
  auto cell = [&](const char* name) -> std::string {
    if (!rep.has(name)) return "–";
    char b[64];
    std::snprintf(b, sizeof b, "%.3f ± %.3f", rep.at(name).mean, rep.at(name).ci95);
    return b;
  };
  return "| " + label + " | " + cell("r_precision_top1") + " | " + cell("r_precision_top2") + " | " +
         cell("r_precision_top3") + " | " + cell("fid") + " | " + cell("mm_dist") + " | " + cell("diversity") +
         " | " + cell("multimodality") + " |";
}

}  // namespace t2m::eval

