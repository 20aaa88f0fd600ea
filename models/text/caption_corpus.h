// caption_corpus.h — the caption texts of one data split, as the training loader can produce them: the corpus the
// tokenizer's vocabulary is built from (train split only, so val/test words never leak into the vocabulary).
//
// For every clip of the split (sorted by name): caption_paraphrases(content, style, seed, paraphrases) and, when
// mirrored, the same for the mirrored clip (left/right swapped words). With compositions, clip i's first caption
// is also composed with clip i+1's ("<a>, then <b>", models/data/captions.h) so that "then" and the comma are in the
// corpus. Deterministic: a pure function of (split assignment, split, seed, options).
// Errors: t2m::Error for paraphrases < 1, a clip name that does not parse, or a label without caption words
// (messages name the clip).
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "models/data/splits.h"

namespace t2m::text {

struct CaptionCorpusOptions {
  uint64_t seed = 0;
  int paraphrases = 64;      // distinct captions per clip (fewer when the templates run out)
  bool mirrored = true;      // also the left/right-swapped captions
  bool compositions = true;  // also "A, then B" captions of neighbouring clips
};

std::vector<std::string> split_caption_corpus(const std::map<std::string, data::Split>& splits, data::Split which,
                                              const CaptionCorpusOptions& opt = {});

}  // namespace t2m::text
