// posture_script.cpp — posecodes -> script text (see posture_script.h).
#include "models/promotion/posture_script.h"

#include "models/promotion/posecodes.h"
#include "tensor/tensor.h"

namespace t2m::promotion {

namespace {

std::string fill(const std::string& text, const std::string& phrase) {
  std::string s = text;
  size_t p = s.find("{c}");
  if (p != std::string::npos) s.replace(p, 3, phrase);
  return s;
}

}  // namespace

std::string posture_script(const std::vector<int>& codes) {
  const auto& rules = posecode_rules();
  if (codes.size() != rules.size())
    throw Error("posture_script: expected " + std::to_string(rules.size()) + " posecodes, got " +
                std::to_string(codes.size()));
  for (size_t i = 0; i < rules.size(); ++i)
    if (codes[i] < 0 || codes[i] >= (int)rules[i].categories.size())
      throw Error("posture_script: category " + std::to_string(codes[i]) + " out of range for rule '" +
                  rules[i].name + "'");
  std::string out, sentence;
  int family = -1;
  auto flush = [&]() {
    if (sentence.empty()) return;
    if (!out.empty()) out += " ";
    out += sentence + ".";
    sentence.clear();
  };
  for (size_t i = 0; i < rules.size(); ++i) {
    const PosecodeRule& r = rules[i];
    if ((int)r.family != family) {
      flush();
      family = (int)r.family;
    }
    if (!r.described(codes[i])) continue;
    std::string clause;
    int p = r.partner;
    if (p >= 0 && p < (int)i && codes[p] == codes[i] && !r.both_text.empty()) continue;  // aggregated already
    if (p > (int)i && codes[p] == codes[i] && !r.both_text.empty())
      clause = fill(r.both_text, r.categories[codes[i]]);
    else
      clause = fill(r.text, r.categories[codes[i]]);
    if (!sentence.empty()) sentence += ", ";
    sentence += clause;
  }
  flush();
  if (out.empty()) out = "the body is in a neutral pose.";
  return out;
}

std::string pose_script(const float* pose) { return posture_script(pose_posecodes(pose)); }

std::vector<std::string> posture_script_corpus() {
  std::vector<std::string> corpus = {"the body is in a neutral pose."};
  for (const PosecodeRule& r : posecode_rules())
    for (const std::string& c : r.categories) {
      if (c.empty()) continue;
      corpus.push_back(fill(r.text, c) + ", ");
      if (!r.both_text.empty()) corpus.push_back(fill(r.both_text, c) + ".");
    }
  return corpus;
}

}  // namespace t2m::promotion
