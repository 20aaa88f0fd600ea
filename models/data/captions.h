// captions.h — text captions generated from the Bandai content and style labels.
//
// The data sets have no free text. A caption is built from one content template and one style:
//   template  "{s} walks forward{a}"             ({s} = subject slot, {a} = manner slot, each exactly once)
//   style     subjects {"an elderly person", ...}, adverbs {"slowly, like an old person", "stiffly", ...}
// and one of two forms, chosen at random (1/2 each): styled subject + empty manner ("an elderly person walks
// forward") or neutral subject + style adverb ("someone walks forward stiffly"). The "normal" style's adverbs
// include "" (no manner phrase). All text is lower case without a final period.
// Every template and word list is printed by captions_markdown() into docs/CAPTIONS.md (a test keeps them equal).
//
// Determinism: caption (content, style, seed, index) draws 4 x 32 random bits from a counter-based generator
// keyed by seed and a hash of the labels, at counter `index` (see caption_random_bits); the same arguments give
// the same caption on any machine and in any order of calls.
// Mirroring: a mirrored clip's caption is swap_left_right() of the unmirrored one ("left" <-> "right" word by
// word); the "-right" contents are defined as the left/right swap of their "-left" partners, so mirroring a
// "wave-left-hand" clip gives exactly a "wave-right-hand" caption.
// Labels: with or without the "dataset-N_" prefix ("dataset-2_walk" == "walk"). Unknown labels throw t2m::Error
// naming the label.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace t2m::data {

struct CaptionContent {
  std::string label;                    // "walk-turn-left"
  std::vector<std::string> templates;   // each with one "{s}" and one "{a}"
  std::string mirrored_from;            // "" or the label whose templates were left/right swapped
};
struct CaptionStyle {
  std::string label;                    // "exhausted"
  std::vector<std::string> subjects;    // "an exhausted person"
  std::vector<std::string> adverbs;     // "wearily"; "" allowed (normal style only)
};

// The tables (built once; contents sorted as in the label files, dataset-1 first, duplicates merged).
const std::vector<CaptionContent>& caption_contents();
const std::vector<CaptionStyle>& caption_styles();
const std::vector<std::string>& caption_neutral_subjects();  // "a person", "someone", ...
// Lookup by label (prefix "dataset-N_" ignored); throws t2m::Error for an unknown label.
const CaptionContent& caption_content(const std::string& label);
const CaptionStyle& caption_style(const std::string& label);
bool has_caption_content(const std::string& label);
bool has_caption_style(const std::string& label);
std::string strip_dataset_prefix(const std::string& label);  // "dataset-2_walk" -> "walk"

struct Caption {
  std::string text;
  int template_id = -1;         // index into caption_content(content).templates
  bool styled_subject = false;  // true: style in the subject, false: neutral subject + adverb
};

// One caption. Throws t2m::Error on unknown labels.
Caption make_caption(const std::string& content, const std::string& style, uint64_t seed, uint64_t index,
                     bool mirrored = false);
// n distinct paraphrases (indices 0, 1, ... until n distinct texts or 64 n draws), in draw order.
std::vector<std::string> caption_paraphrases(const std::string& content, const std::string& style, uint64_t seed,
                                             int n, bool mirrored = false);

// "left" <-> "right", "leftward(s)" <-> "rightward(s)", whole words only, case kept for the first letter.
std::string swap_left_right(const std::string& text);
// "<a>, then <b>" (the compositional caption).
std::string compose_captions(const std::string& a, const std::string& b);

// 4 x 32 random bits for (seed, key, counter): Philox4x32-10 (tensor/rng.h), a pure function of its arguments.
void caption_random_bits(uint64_t seed, uint64_t key, uint64_t counter, uint32_t out[4]);

// The generated part of docs/CAPTIONS.md: every template of every content and every style's words, as Markdown.
std::string captions_markdown();

}  // namespace t2m::data
