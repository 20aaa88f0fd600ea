// evaluate_motions.h — the evaluation protocol (models/eval/protocol.h) applied to a set of captioned motions with
// the metric evaluator (models/eval/evaluator.h): what `t2m eval motions` runs, for a directory of generated
// motions (models/eval/motion_dir.h) and for the real-motion row (the test split's real clips with their own
// captions).
//
// MotionSet: main[i] = (caption, raw features [T, 257]) for R-precision, FID, MM-Dist and Diversity; groups (optional)
// = P prompts x S samples of raw features for MultiModality. Embeddings: evaluator embed_texts / embed_motions
// (unit rows; centred crops of the evaluator's window). The reference set for FID is given as embeddings
// (embed_motions of the real test clips) or undefined (no FID). Motions are embedded once; every one of the
// protocol's runs re-draws the R-precision batches, the shuffled control, the Diversity and MultiModality pairs.
// Diversity draws pairs with distinct first indices, so it uses min(diversity_pairs, N) pairs (the test split has
// 274 clips: 274 pairs instead of 300), and MultiModality min(mm_pairs, S) pairs per prompt; the report's protocol
// says how many.
// Errors (t2m::Error "evaluate_motions: ..."): fewer main motions than one R-precision batch (names both numbers),
// groups of unequal size, plus those of the evaluator and the metrics.
#pragma once
#include <string>
#include <vector>

#include "models/eval/motion_dir.h"
#include "models/eval/protocol.h"
#include "models/text/retrieval_model.h"

namespace t2m::eval {

struct MotionSet {
  std::vector<std::string> captions;                           // (N)
  std::vector<const std::vector<float>*> motions;              // (N) raw features
  std::vector<std::vector<const std::vector<float>*>> groups;  // (P) x (S), may be empty
};

EvalReport evaluate_motions(const text::RetrievalBundle& evaluator, const MotionSet& set, const Tensor& reference,
                            const EvalProtocol& protocol);

// The MotionSet of a loaded motions directory: its main_set() entries and its prompt groups (pointers into md,
// which must outlive the set).
MotionSet motion_set_of(const MotionDir& md);

// Text of a report: one line per metric "  name  mean +- ci95" (what every `t2m eval ...` prints).
std::string report_lines(const EvalReport& rep);
// One Markdown table row "| label | R@1 | R@2 | R@3 | FID | MM-Dist | Diversity | MultiModality |" with
// "mean ± ci95" cells ("–" where a metric is absent).
std::string report_markdown_row(const std::string& label, const EvalReport& rep);

}  // namespace t2m::eval
