// protocol.cpp — R seeded runs of every metric, mean +- 95% CI per metric, JSON report.
#include "models/eval/protocol.h"

namespace t2m::eval {

const MeanCI& EvalReport::at(const std::string& name) const {
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return values[i];
  throw Error("EvalReport: no metric named '" + name + "'");
}

bool EvalReport::has(const std::string& name) const {
  for (const auto& n : names)
    if (n == name) return true;
  return false;
}

nlohmann::json EvalReport::to_json() const {
  nlohmann::json metrics = nlohmann::json::object();
  for (size_t i = 0; i < names.size(); ++i)
    metrics[names[i]] = {{"mean", values[i].mean}, {"std", values[i].std}, {"ci95", values[i].ci95}};
  return {{"runs", protocol.runs},
          {"seed", protocol.seed},
          {"batch_size", protocol.batch_size},
          {"top_k", protocol.top_k},
          {"diversity_pairs", protocol.diversity_pairs},
          {"mm_pairs", protocol.mm_pairs},
          {"ci", "mean +- 1.96 std / sqrt(runs), std with divisor runs"},
          {"metrics", metrics}};
}

EvalReport evaluate_protocol(const EvalProtocol& protocol,
                             const std::function<EvalEmbeddings(Generator& gen, int run)>& embed) {
  if (protocol.runs < 1) throw Error("evaluate_protocol: runs must be >= 1, got " + std::to_string(protocol.runs));
  EvalReport report;
  report.protocol = protocol;
  bool with_fid = false, with_mm = false;
  auto metrics = [&](Generator& gen, int run) {
    EvalEmbeddings e = embed(gen, run);
    if (run == 0) {
      with_fid = e.real_motion.defined();
      with_mm = e.mm_motion.defined();
    } else if (with_fid != e.real_motion.defined() || with_mm != e.mm_motion.defined()) {
      throw Error("evaluate_protocol: run " + std::to_string(run) +
                  " switched real_motion/mm_motion on or off relative to run 0");
    }
    std::vector<double> v;
    RPrecision rp = r_precision(e.text, e.motion, gen, protocol.top_k, protocol.batch_size);
    RPrecision ctl = shuffled_r_precision(e.text, e.motion, gen, protocol.top_k, protocol.batch_size);
    v.insert(v.end(), rp.top.begin(), rp.top.end());
    v.insert(v.end(), ctl.top.begin(), ctl.top.end());
    if (with_fid) v.push_back(fid(e.motion, e.real_motion));
    v.push_back(mm_dist(e.text, e.motion));
    v.push_back(diversity(e.motion, gen, protocol.diversity_pairs));
    if (with_mm) v.push_back(multimodality(e.mm_motion, gen, protocol.mm_pairs));
    return v;
  };
  report.values = repeat_runs(protocol.runs, protocol.seed, metrics);
  for (int k = 1; k <= protocol.top_k; ++k) report.names.push_back("r_precision_top" + std::to_string(k));
  for (int k = 1; k <= protocol.top_k; ++k) report.names.push_back("control_r_precision_top" + std::to_string(k));
  if (with_fid) report.names.push_back("fid");
  report.names.push_back("mm_dist");
  report.names.push_back("diversity");
  if (with_mm) report.names.push_back("multimodality");
  return report;
}

}  // namespace t2m::eval
