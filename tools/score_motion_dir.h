// score_motion_dir.h — the common last step of the generate-and-score commands (`t2m eval casim`, `eval casim-ar`,
// `eval text2bfm`): score the motions directory they wrote exactly as `t2m eval motions DIR` does (evaluator
// checkpoint, FID reference = the given real clips), write DIR/eval.json atomically (the report, count,
// MultiModality prompts, the evaluator path, what was scored, the FID reference, and the caller's extra fields) and
// print "WHAT: N motions, R runs; SUMMARY", the report lines and a markdown table row labelled LABEL.
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/data/loader.h"
#include "models/eval/protocol.h"

namespace t2m::cli {

struct ScoreRequest {
  std::string dir;            // motions directory (motions.json)
  std::string evaluator;      // evaluator checkpoint
  std::string what;           // what the motions are (eval.json "motions")
  std::string fid_reference;  // description of the reference set (eval.json "fid_reference")
  std::string label;          // markdown row label
  std::string summary;        // printed after the motion count (e.g. generation time)
  const std::vector<data::MotionClip>* reference = nullptr;  // real clips for FID
  eval::EvalProtocol protocol;
  nlohmann::json fields = nlohmann::json::object();  // merged into eval.json
};

eval::EvalReport score_motion_dir(const ScoreRequest& r);

}  // namespace t2m::cli
