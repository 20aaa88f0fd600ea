// score_motion_dir.cpp — evaluator scoring of a motions directory and its eval.json (see the header).
#include "tools/score_motion_dir.h"

#include <cstdio>

#include "models/eval/evaluate_motions.h"
#include "models/eval/evaluator.h"
#include "models/eval/motion_dir.h"
#include "nn/checkpoint.h"

namespace t2m::cli {

eval::EvalReport score_motion_dir(const ScoreRequest& r) {
  if (!r.reference) throw Error("score_motion_dir: no reference clips");
  const auto md = eval::load_motion_dir(r.dir);
  const auto ev = eval::load_evaluator(r.evaluator);
  const eval::MotionSet set = eval::motion_set_of(md);
  std::vector<const std::vector<float>*> ref;
  for (const auto& c : *r.reference) ref.push_back(&c.features);
  const eval::EvalReport rep = eval::evaluate_motions(ev, set, text::embed_motions(ev, ref), r.protocol);
  nlohmann::json j = rep.to_json();
  j["motions"] = r.what;
  j["count"] = set.motions.size();
  j["multimodality_prompts"] = set.groups.size();
  j["fid_reference"] = r.fid_reference;
  j["evaluator"] = r.evaluator;
  j["redrawn_per_run"] = "R-precision batches, shuffled control, Diversity and MultiModality pairs (the motions are "
                         "generated once)";
  for (const auto& [k, v] : r.fields.items()) j[k] = v;
  nn::write_file_atomic(r.dir + "/eval.json", j.dump(1) + "\n");
  std::printf("%s: %zu motions, %d runs (seed %llu); %s\n", r.what.c_str(), set.motions.size(), r.protocol.runs,
              (unsigned long long)r.protocol.seed, r.summary.c_str());
  std::fputs(eval::report_lines(rep).c_str(), stdout);
  std::printf("%s\n", eval::report_markdown_row(r.label, rep).c_str());
  return rep;
}

}  // namespace t2m::cli
