// captions.cpp — caption assembly from the tables, left/right word swap, Markdown listing.
#include "models/data/captions.h"

#include <cctype>
#include <set>

#include "nn/fnv1a.h"
#include "tensor/rng.h"
#include "tensor/tensor.h"

namespace t2m::data {

std::string strip_dataset_prefix(const std::string& label) {
  if (label.rfind("dataset-", 0) == 0) {
    size_t p = label.find('_');
    if (p != std::string::npos) return label.substr(p + 1);
  }
  return label;
}

bool has_caption_content(const std::string& label) {
  std::string l = strip_dataset_prefix(label);
  for (const auto& c : caption_contents())
    if (c.label == l) return true;
  return false;
}

bool has_caption_style(const std::string& label) {
  std::string l = strip_dataset_prefix(label);
  for (const auto& s : caption_styles())
    if (s.label == l) return true;
  return false;
}

const CaptionContent& caption_content(const std::string& label) {
  std::string l = strip_dataset_prefix(label);
  for (const auto& c : caption_contents())
    if (c.label == l) return c;
  throw Error("caption_content: no caption templates for content label '" + label + "'");
}

const CaptionStyle& caption_style(const std::string& label) {
  std::string l = strip_dataset_prefix(label);
  for (const auto& s : caption_styles())
    if (s.label == l) return s;
  throw Error("caption_style: no caption words for style label '" + label + "'");
}

void caption_random_bits(uint64_t seed, uint64_t key, uint64_t counter, uint32_t out[4]) {
  // Philox4x32-10 (tensor/rng.h) keyed by the seed mixed with the label key; the counter is the paraphrase index.
  philox4x32(seed ^ (key * 0x9e3779b97f4a7c15ull + 0x632be59bd9b4e019ull), counter, out);
}

namespace {

uint64_t label_key(const std::string& content, const std::string& style) {
  const std::string key = content + "/" + style;  // FNV-1a 64 of "content/style"
  return nn::fnv1a64(key.data(), key.size());
}

std::string fill(const std::string& tmpl, const std::string& subject, const std::string& manner) {
  size_t s = tmpl.find("{s}"), a = tmpl.find("{a}");
  if (s == std::string::npos || a == std::string::npos || tmpl.find("{s}", s + 1) != std::string::npos ||
      tmpl.find("{a}", a + 1) != std::string::npos || a < s)
    throw Error("make_caption: template '" + tmpl + "' needs one {s} followed by one {a}");
  std::string out = tmpl.substr(0, s) + subject + tmpl.substr(s + 3, a - s - 3);
  if (!manner.empty()) out += (manner[0] == ',' ? "" : " ") + manner;
  out += tmpl.substr(a + 3);
  return out;
}

bool is_letter(char c) { return std::isalpha((unsigned char)c) != 0; }

}  // namespace

Caption make_caption(const std::string& content, const std::string& style, uint64_t seed, uint64_t index,
                     bool mirrored) {
  const CaptionContent& c = caption_content(content);
  const CaptionStyle& s = caption_style(style);
  if (c.templates.empty()) throw Error("make_caption: content '" + content + "' has no templates");
  uint32_t r[4];
  caption_random_bits(seed, label_key(c.label, s.label), index, r);
  Caption out;
  out.template_id = (int)(r[0] % c.templates.size());
  out.styled_subject = (r[1] & 1u) != 0;
  std::string subject, manner;
  if (out.styled_subject) {
    subject = s.subjects[r[2] % s.subjects.size()];
  } else {
    const auto& neutral = caption_neutral_subjects();
    subject = neutral[r[2] % neutral.size()];
    manner = s.adverbs[r[3] % s.adverbs.size()];
  }
  out.text = fill(c.templates[out.template_id], subject, manner);
  if (mirrored) out.text = swap_left_right(out.text);
  return out;
}

std::vector<std::string> caption_paraphrases(const std::string& content, const std::string& style, uint64_t seed,
                                             int n, bool mirrored) {
  if (n < 0) throw Error("caption_paraphrases: n must be >= 0, got " + std::to_string(n));
  std::vector<std::string> out;
  std::set<std::string> seen;
  for (uint64_t i = 0; (int)out.size() < n && i < 64ull * (uint64_t)n; ++i) {
    std::string t = make_caption(content, style, seed, i, mirrored).text;
    if (seen.insert(t).second) out.push_back(t);
  }
  return out;
}

std::string swap_left_right(const std::string& text) {
  static const std::pair<const char*, const char*> kPairs[] = {
      {"left", "right"}, {"leftward", "rightward"}, {"leftwards", "rightwards"}};
  std::string out;
  out.reserve(text.size() + 8);
  size_t i = 0;
  while (i < text.size()) {
    if (!is_letter(text[i])) { out += text[i++]; continue; }
    size_t j = i;
    while (j < text.size() && is_letter(text[j])) ++j;
    std::string word = text.substr(i, j - i), lower = word;
    for (char& ch : lower) ch = (char)std::tolower((unsigned char)ch);
    std::string repl = word;
    for (auto [a, b] : kPairs) {
      if (lower == a) repl = b;
      else if (lower == b) repl = a;
      else continue;
      if (std::isupper((unsigned char)word[0])) repl[0] = (char)std::toupper((unsigned char)repl[0]);
      break;
    }
    out += repl;
    i = j;
  }
  return out;
}

std::string compose_captions(const std::string& a, const std::string& b) { return a + ", then " + b; }

std::string captions_markdown() {
  std::string md;
  md += "### Subjects\n\nNeutral subjects (used with a style adverb): ";
  const auto& neutral = caption_neutral_subjects();
  for (size_t i = 0; i < neutral.size(); ++i) md += (i ? ", " : "") + std::string("\"") + neutral[i] + "\"";
  md += "\n\n### Styles\n\n| style | styled subjects | adverbs / manner phrases |\n|---|---|---|\n";
  for (const auto& s : caption_styles()) {
    md += "| " + s.label + " | ";
    for (size_t i = 0; i < s.subjects.size(); ++i) md += (i ? "; " : "") + s.subjects[i];
    md += " | ";
    for (size_t i = 0; i < s.adverbs.size(); ++i) md += (i ? "; " : "") + (s.adverbs[i].empty() ? "(none)" : s.adverbs[i]);
    md += " |\n";
  }
  md += "\n### Content templates\n\n`{s}` is the subject, `{a}` the manner phrase (empty when the style is in the "
        "subject).\n";
  for (const auto& c : caption_contents()) {
    md += "\n**" + c.label + "**";
    if (!c.mirrored_from.empty()) md += " (left/right swap of " + c.mirrored_from + ")";
    md += "\n\n";
    for (size_t i = 0; i < c.templates.size(); ++i) md += std::to_string(i) + ". `" + c.templates[i] + "`\n";
  }
  return md;
}

}  // namespace t2m::data
