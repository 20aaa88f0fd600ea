// test_captions.cpp — caption tables, determinism, variety, label coverage, mirroring, docs in sync.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "models/data/captions.h"
#include "tensor/tensor.h"

using namespace t2m::data;

namespace {

std::vector<std::string> read_lines(const std::string& path) {
  std::ifstream f(path);
  std::vector<std::string> out;
  for (std::string l; std::getline(f, l);) {
    while (!l.empty() && (l.back() == '\r' || l.back() == ' ')) l.pop_back();
    if (!l.empty()) out.push_back(l);
  }
  return out;
}

std::string cfg_dir() {
  for (std::string d : {std::string(T2M_SOURCE_DIR) + "/../shared/data/bandai/cfg", std::string("/work/shared/data/bandai/cfg")})
    if (std::ifstream(d + "/dataset-1_content_label.txt")) return d;
  return "";
}

bool contains_word(const std::string& text, const std::string& w) {
  size_t p = 0;
  while ((p = text.find(w, p)) != std::string::npos) {
    bool start = p == 0 || !std::isalpha((unsigned char)text[p - 1]);
    bool end = p + w.size() == text.size() || !std::isalpha((unsigned char)text[p + w.size()]);
    if (start && end) return true;
    ++p;
  }
  return false;
}

}  // namespace

TEST(Captions, TemplatesAreWellFormed) {
  ASSERT_EQ(caption_contents().size(), 25u);  // 17 dataset-1 + 10 dataset-2 contents, walk and run shared
  for (const auto& c : caption_contents()) {
    EXPECT_GE(c.templates.size(), 8u) << c.label;
    std::set<std::string> uniq(c.templates.begin(), c.templates.end());
    EXPECT_EQ(uniq.size(), c.templates.size()) << c.label << ": duplicate template";
    for (const auto& t : c.templates) {
      size_t s = t.find("{s}"), a = t.find("{a}");
      EXPECT_TRUE(s != std::string::npos && a != std::string::npos && s < a) << t;
      EXPECT_EQ(t.find("{s}", s + 1), std::string::npos) << t;
      EXPECT_FALSE(contains_word(t, "then")) << t << ": 'then' is reserved for compositional captions";
      for (char ch : t) EXPECT_FALSE(std::isupper((unsigned char)ch)) << t;
      EXPECT_NE(t.back(), '.') << t;
    }
  }
  for (const auto& s : caption_styles()) {
    EXPECT_GE(s.subjects.size(), 2u) << s.label;
    EXPECT_GE(s.adverbs.size(), 3u) << s.label;
  }
}

TEST(Captions, EveryLabelOfBothDataSetsIsCovered) {
  std::string dir = cfg_dir();
  if (dir.empty()) GTEST_SKIP() << "label files not found";
  int n = 0;
  for (int d : {1, 2}) {
    auto contents = read_lines(dir + "/dataset-" + std::to_string(d) + "_content_label.txt");
    auto styles = read_lines(dir + "/dataset-" + std::to_string(d) + "_style_label.txt");
    ASSERT_EQ(contents.size(), d == 1 ? 17u : 10u);
    ASSERT_EQ(styles.size(), d == 1 ? 15u : 7u);
    for (const auto& c : contents) {
      EXPECT_TRUE(has_caption_content(c)) << c;
      for (const auto& s : styles) {
        EXPECT_TRUE(has_caption_style(s)) << s;
        Caption cap = make_caption(c, s, 7, 0);
        EXPECT_FALSE(cap.text.empty());
        ++n;
      }
    }
  }
  EXPECT_EQ(n, 17 * 15 + 10 * 7);
}

TEST(Captions, DeterministicPerSeedAndIndex) {
  for (uint64_t seed : {0ull, 1ull, 12345ull})
    for (uint64_t i = 0; i < 20; ++i)
      EXPECT_EQ(make_caption("wave-left-hand", "elderly", seed, i).text,
                make_caption("dataset-2_wave-left-hand", "dataset-2_elderly", seed, i).text);
  // Different seeds give different paraphrase lists.
  auto a = caption_paraphrases("walk", "exhausted", 1, 6), b = caption_paraphrases("walk", "exhausted", 2, 6);
  ASSERT_EQ(a.size(), 6u);
  EXPECT_EQ(a, caption_paraphrases("walk", "exhausted", 1, 6));
  EXPECT_NE(a, b);
  EXPECT_EQ(std::set<std::string>(a.begin(), a.end()).size(), 6u);
}

TEST(Captions, VarietyEveryTemplateAndBothFormsAppear) {
  for (const auto& c : caption_contents()) {
    std::set<int> templates;
    int styled = 0;
    for (uint64_t i = 0; i < 400; ++i) {
      Caption cap = make_caption(c.label, "happy", 3, i);
      templates.insert(cap.template_id);
      styled += cap.styled_subject;
    }
    EXPECT_GE(templates.size(), 8u) << c.label;
    EXPECT_EQ(templates.size(), c.templates.size()) << c.label;
    EXPECT_GT(styled, 120) << c.label;
    EXPECT_LT(styled, 280) << c.label;
  }
}

TEST(Captions, StyleWordsShowUp) {
  // Every caption carries its style: a styled subject or an adverb of that style (normal may carry neither).
  for (const auto& s : caption_styles()) {
    for (uint64_t i = 0; i < 100; ++i) {
      std::string t = make_caption("walk", s.label, 11, i).text;
      bool found = s.label == "normal";
      for (const auto& w : s.subjects) found |= t.find(w) != std::string::npos;
      for (const auto& w : s.adverbs) found |= !w.empty() && t.find(w) != std::string::npos;
      EXPECT_TRUE(found) << s.label << ": " << t;
    }
  }
  // The examples of the brief.
  std::set<std::string> all;
  for (uint64_t i = 0; i < 3000; ++i) all.insert(make_caption("walk", "exhausted", 5, i).text);
  EXPECT_TRUE(all.count("an exhausted person walks forward")) << "missing";
  EXPECT_TRUE(all.count("someone walks forward wearily")) << "missing";
  std::set<std::string> old;
  for (uint64_t i = 0; i < 3000; ++i) old.insert(make_caption("walk", "elderly", 5, i).text);
  EXPECT_TRUE(old.count("an elderly person walks forward"));
  EXPECT_TRUE(old.count("a person walks forward slowly, like an elderly person"));
}

TEST(Captions, SwapLeftRightWholeWords) {
  EXPECT_EQ(swap_left_right("Left hand, left-handed; leftwards and rightward"),
            "Right hand, right-handed; rightwards and leftward");
  EXPECT_EQ(swap_left_right("the leftover bright light"), "the leftover bright light");
  EXPECT_EQ(swap_left_right("turns right"), "turns left");
  EXPECT_EQ(swap_left_right(""), "");
  for (const char* s : {"waves the left hand", "a right turn to the left", "nothing here"})
    EXPECT_EQ(swap_left_right(swap_left_right(s)), s);
}

TEST(Captions, MirroredCaptionsSwapSidesAndMatchThePartnerContent) {
  std::set<std::string> right;
  for (uint64_t i = 0; i < 3000; ++i) right.insert(make_caption("wave-right-hand", "normal", 9, i).text);
  for (uint64_t i = 0; i < 200; ++i) {
    std::string plain = make_caption("wave-left-hand", "normal", 4, i).text;
    std::string mirrored = make_caption("wave-left-hand", "normal", 4, i, true).text;
    EXPECT_EQ(mirrored, swap_left_right(plain));
    EXPECT_TRUE(contains_word(plain, "left")) << plain;
    EXPECT_FALSE(contains_word(mirrored, "left")) << mirrored;
    EXPECT_TRUE(contains_word(mirrored, "right")) << mirrored;
    EXPECT_TRUE(right.count(mirrored)) << mirrored << " is not a wave-right-hand caption";
  }
  // Captions without sides are unchanged by mirroring.
  EXPECT_EQ(make_caption("bow", "sad", 1, 2, true).text, make_caption("bow", "sad", 1, 2).text);
}

TEST(Captions, Compose) {
  EXPECT_EQ(compose_captions("a person walks forward", "someone waves the left hand"),
            "a person walks forward, then someone waves the left hand");
}

TEST(Captions, BadInputThrows) {
  EXPECT_THROW(make_caption("moonwalk", "normal", 0, 0), t2m::Error);
  EXPECT_THROW(make_caption("walk", "sleepy", 0, 0), t2m::Error);
  EXPECT_THROW(caption_content("dataset-3_fly"), t2m::Error);
  EXPECT_THROW(caption_paraphrases("walk", "normal", 0, -1), t2m::Error);
  EXPECT_FALSE(has_caption_content("fly"));
  EXPECT_TRUE(caption_paraphrases("walk", "normal", 0, 0).empty());
}

TEST(Captions, DocsListEveryTemplate) {
  // docs/CAPTIONS.md holds captions_markdown() between the markers; T2M_UPDATE_DOCS=1 rewrites that block.
  const std::string path = std::string(T2M_SOURCE_DIR) + "/docs/CAPTIONS.md";
  const std::string begin = "<!-- BEGIN GENERATED: captions_markdown() -->\n", end = "<!-- END GENERATED -->";
  std::ifstream f(path);
  ASSERT_TRUE(f.good()) << path;
  std::stringstream ss;
  ss << f.rdbuf();
  std::string doc = ss.str();
  size_t b = doc.find(begin), e = doc.find(end);
  ASSERT_NE(b, std::string::npos);
  ASSERT_NE(e, std::string::npos);
  std::string current = doc.substr(b + begin.size(), e - b - begin.size());
  std::string want = captions_markdown();
  if (std::getenv("T2M_UPDATE_DOCS") && current != want) {
    std::ofstream(path) << doc.substr(0, b + begin.size()) + want + doc.substr(e);
    current = want;
  }
  EXPECT_EQ(current, want) << "docs/CAPTIONS.md is stale: run T2M_UPDATE_DOCS=1 test_captions";
  for (const auto& c : caption_contents())
    for (const auto& t : c.templates) EXPECT_NE(doc.find(t), std::string::npos) << t;
}
