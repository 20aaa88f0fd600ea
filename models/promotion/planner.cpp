// planner.cpp — clause splitting, content/style matching over the caption vocabulary, key-frame allocation.
#include "models/promotion/planner.h"

#include <cmath>
#include <map>
#include <set>

#include "models/data/captions.h"
#include "models/promotion/pose.h"
#include "models/promotion/posecodes.h"
#include "models/promotion/posture_script.h"
#include "models/text/tokenizer.h"
#include "tensor/tensor.h"

namespace t2m::promotion {

namespace {

// Subject and function words: never evidence for a content.
const std::set<std::string> kSubjectWords = {"a",  "an", "the", "person", "someone", "human", "man", "woman", "is",
                                             "{",  "}",  "s",   ",",      ".",       "of",    "to",  "with",  "in",
                                             "on", "at", "for", "and",    "by",      "into",  "it",  "this",  "them",
                                             "as", "who", "being"};

struct Vocab {
  std::vector<std::string> contents;
  std::vector<std::map<std::string, double>> content_vec;  // tf-idf, L2-normalised
  std::vector<std::string> styles;
  std::vector<std::set<std::string>> style_words;
};

std::vector<std::string> content_words(const std::string& text) {
  std::vector<std::string> out;
  for (const std::string& w : text::split_words(text))
    if (!kSubjectWords.count(w)) out.push_back(w);
  return out;
}

const Vocab& vocab() {
  static const Vocab v = [] {
    Vocab v;
    std::vector<std::map<std::string, double>> tf;
    std::map<std::string, int> df;
    for (const auto& c : data::caption_contents()) {
      v.contents.push_back(c.label);
      std::map<std::string, double> f;
      for (const std::string& t : c.templates)
        for (const std::string& w : content_words(t)) f[w] += 1;
      for (const auto& [w, n] : f) ++df[w];
      tf.push_back(f);
    }
    const double C = (double)v.contents.size();
    for (auto& f : tf) {
      double norm = 0;
      for (auto& [w, x] : f) {
        x *= std::log(1.0 + C / df[w]);
        norm += x * x;
      }
      for (auto& [w, x] : f) x /= std::sqrt(norm);
      v.content_vec.push_back(f);
    }
    std::set<std::string> generic = {"like", "in", "way", "with", "manner", "of", "and", "person", "a", "an"};
    for (const auto& s : data::caption_styles()) {
      v.styles.push_back(s.label);
      std::set<std::string> words;
      for (const auto& list : {s.subjects, s.adverbs})
        for (const std::string& t : list)
          for (const std::string& w : text::split_words(t))
            if (!generic.count(w) && !kSubjectWords.count(w)) words.insert(w);
      v.style_words.push_back(words);
    }
    return v;
  }();
  return v;
}

bool has_side(const std::string& label) {
  return label.find("left") != std::string::npos || label.find("right") != std::string::npos;
}

// +1: the template moves the left side more, -1: the right side, 0: balanced.
int active_side(const std::vector<std::vector<int>>& keys, const std::vector<int>& neutral) {
  const auto& rules = posecode_rules();
  int score = 0;
  for (const auto& c : keys)
    for (size_t r = 0; r < rules.size(); ++r) {
      if (c[r] == neutral[r]) continue;
      if (rules[r].name.rfind("left", 0) == 0) ++score;
      if (rules[r].name.rfind("right", 0) == 0) --score;
    }
  return (score > 0) - (score < 0);
}

std::string join(const std::vector<std::string>& w) { return text::join_words(w); }

}  // namespace

std::vector<std::vector<std::string>> split_clauses(const std::string& prompt) {
  const std::vector<std::string> words = text::split_words(prompt);
  std::vector<std::vector<std::string>> out(1);
  auto cut = [&]() {
    while (!out.back().empty() && (out.back().back() == "," || out.back().back() == "and"))
      out.back().pop_back();
    out.emplace_back();
  };
  for (size_t i = 0; i < words.size(); ++i) {
    const std::string& w = words[i];
    if (w == "then" || w == "afterwards" || w == "finally") {
      cut();
    } else if (w == "after" && i + 1 < words.size() && words[i + 1] == "that") {
      cut();
      ++i;
    } else if (!(out.back().empty() && (w == "," || w == "and"))) {
      out.back().push_back(w);
    }
  }
  std::vector<std::vector<std::string>> clauses;
  for (auto& c : out)
    if (!c.empty()) clauses.push_back(c);
  if (clauses.empty()) clauses.emplace_back();
  return clauses;
}

Plan plan_postures(const PlannerTable& table, const std::string& prompt, int k) {
  if (k < 1) throw Error("plan_postures: k must be >= 1, got " + std::to_string(k));
  const Vocab& v = vocab();
  std::vector<std::vector<std::string>> clauses = split_clauses(prompt);
  if ((int)clauses.size() > k) clauses.resize(k);
  const int n = (int)clauses.size();
  const std::vector<int> neutral = table.at("").front();
  Plan plan;
  for (int ci = 0; ci < n; ++ci) {
    PlannedClause pc;
    pc.text = join(clauses[ci]);
    pc.frames = k / n + (ci < k % n ? 1 : 0);
    std::set<std::string> words;
    for (const std::string& w : clauses[ci])
      if (!kSubjectWords.count(w)) words.insert(w);
    // content: cosine between the clause's binary word vector and the content tf-idf vectors
    double best = 0;
    for (size_t c = 0; c < v.contents.size(); ++c) {
      double dot = 0;
      for (const std::string& w : words) {
        auto it = v.content_vec[c].find(w);
        if (it != v.content_vec[c].end()) dot += it->second;
      }
      const double cos = words.empty() ? 0.0 : dot / std::sqrt((double)words.size());
      if (cos > best + 1e-12 && table.has(v.contents[c])) best = cos, pc.content = v.contents[c];
    }
    pc.score = best;
    int best_style = 0;
    for (size_t s = 0; s < v.styles.size() && !pc.content.empty(); ++s) {
      int hits = 0;
      for (const std::string& w : words) hits += (int)v.style_words[s].count(w);
      if (hits > best_style) best_style = hits, pc.style = v.styles[s];
    }
    pc.entry = pc.content;
    if (!pc.style.empty() && table.has(pc.content + "|" + pc.style)) pc.entry = pc.content + "|" + pc.style;
    std::vector<std::vector<int>> keys = table.at(pc.entry);
    const bool says_left = words.count("left") != 0, says_right = words.count("right") != 0;
    if (!pc.content.empty() && !has_side(pc.content) && says_left != says_right) {
      const int side = active_side(keys, neutral);
      if ((says_left && side < 0) || (says_right && side > 0)) {
        for (auto& c : keys) c = mirror_posecodes(c);
        pc.mirrored = true;
      }
    }
    for (int idx : key_frame_indices(table.k, pc.frames)) {
      plan.codes.push_back(keys[idx]);
      plan.scripts.push_back(posture_script(keys[idx]));
    }
    plan.clauses.push_back(pc);
  }
  return plan;
}

}  // namespace t2m::promotion
