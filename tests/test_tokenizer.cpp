// test_tokenizer.cpp — word splitting, vocabulary order, encode/decode round trips, truncation and padding,
// unknown words, checkpoint save/load, bad input; the vocabulary of the real train-split captions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <unistd.h>
#include <string>
#include <vector>

#include "models/data/captions.h"
#include "models/data/splits.h"
#include "models/text/caption_corpus.h"
#include "models/text/tokenizer.h"
#include "nn/checkpoint.h"
#include "tensor/tensor.h"

using namespace t2m;
using namespace t2m::text;
using Words = std::vector<std::string>;

namespace {

template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "<no error>";
}

Tokenizer small_tokenizer() {
  return Tokenizer::build({"a person walks forward", "a person runs forward, then a person bows",
                           "someone waves the left hand", "an old person walks slowly, like an old person"});
}

std::vector<int64_t> ids_of(const Encoded& e) { return e.ids.to_vector<int64_t>(); }
std::vector<float> mask_of(const Encoded& e) { return e.mask.to_vector<float>(); }

}  // namespace

TEST(Tokenizer, SplitWordsLowercasesAndSplitsPunctuation) {
  EXPECT_EQ(split_words("A Person WALKS forward"), (Words{"a", "person", "walks", "forward"}));
  EXPECT_EQ(split_words("slowly, like an old person."), (Words{"slowly", ",", "like", "an", "old", "person", "."}));
  EXPECT_EQ(split_words("walks,then runs!?"), (Words{"walks", ",", "then", "runs", "!", "?"}));
  EXPECT_EQ(split_words("  tabs\tand\nnewlines  "), (Words{"tabs", "and", "newlines"}));
  EXPECT_EQ(split_words(""), Words{});
  EXPECT_EQ(split_words(" \t "), Words{});
}

TEST(Tokenizer, SplitWordsKeepsInnerHyphensAndApostrophes) {
  EXPECT_EQ(split_words("waves bye-bye"), (Words{"waves", "bye-bye"}));
  EXPECT_EQ(split_words("a worn-out, child-like person"), (Words{"a", "worn-out", ",", "child-like", "person"}));
  EXPECT_EQ(split_words("don't"), (Words{"don't"}));
  // Leading, trailing or doubled joiners are punctuation tokens.
  EXPECT_EQ(split_words("-walk- run--fast 'x"), (Words{"-", "walk", "-", "run", "-", "-", "fast", "'", "x"}));
  EXPECT_EQ(split_words("(left)"), (Words{"(", "left", ")"}));
  // Non-ASCII bytes stay inside words (not lower-cased, never split).
  EXPECT_EQ(split_words("caf\xc3\xa9 Na\xc3\xafve"), (Words{"caf\xc3\xa9", "na\xc3\xafve"}));
}

TEST(Tokenizer, NormalizeJoinsPunctuationToTheLeft) {
  EXPECT_EQ(normalize("  Slowly ,  like AN old   person ."), "slowly, like an old person.");
  EXPECT_EQ(normalize("a; b: c! d?"), "a; b: c! d?");
  EXPECT_EQ(normalize("(left)"), "( left )");
  EXPECT_EQ(join_words({",", "a"}), ", a");
  // Every generated caption is already in normal form.
  for (const auto& c : data::caption_contents())
    for (const auto& s : data::caption_styles())
      for (const auto& t : data::caption_paraphrases(c.label, s.label, 7, 4)) EXPECT_EQ(normalize(t), t) << t;
}

TEST(Tokenizer, VocabularyOrderIsByCountThenWord) {
  Tokenizer tok = Tokenizer::build({"b a c", "a b", "a", "d d d ,"}, 1);
  // counts: a 3, d 3, b 2, c 1, "," 1 -> specials, a, d, b, ",", c  ("," < "c" byte-wise)
  EXPECT_EQ(tok.vocab(), (Words{"<pad>", "<unk>", "<bos>", "<eos>", "a", "d", "b", ",", "c"}));
  EXPECT_EQ(tok.id("<pad>"), Tokenizer::kPad);
  EXPECT_EQ(tok.id("<eos>"), Tokenizer::kEos);
  EXPECT_EQ(tok.id("a"), 4);
  EXPECT_EQ(tok.id("zzz"), Tokenizer::kUnk);
  EXPECT_EQ(tok.token(8), "c");
  // min_freq drops the rare words.
  Tokenizer tok2 = Tokenizer::build({"b a c", "a b", "a", "d d d ,"}, 2);
  EXPECT_EQ(tok2.vocab(), (Words{"<pad>", "<unk>", "<bos>", "<eos>", "a", "d", "b"}));
  EXPECT_EQ(tok2.min_freq(), 2);
  EXPECT_EQ(tok2.id("c"), Tokenizer::kUnk);
}

TEST(Tokenizer, VocabularyDoesNotDependOnCorpusOrder) {
  std::vector<std::string> corpus;
  for (const auto& c : data::caption_contents()) corpus.push_back(data::make_caption(c.label, "tired", 3, 0).text);
  Tokenizer a = Tokenizer::build(corpus);
  std::reverse(corpus.begin(), corpus.end());
  std::rotate(corpus.begin(), corpus.begin() + 5, corpus.end());
  Tokenizer b = Tokenizer::build(corpus);
  EXPECT_EQ(a.vocab(), b.vocab());
  EXPECT_GT(a.vocab_size(), 30);
}

TEST(Tokenizer, EncodeLayoutAndPadding) {
  Tokenizer tok = small_tokenizer();
  Encoded e = tok.encode("A person walks forward", 8);
  ASSERT_EQ(e.ids.dtype(), DType::i64);
  ASSERT_EQ(e.ids.shape(), (Shape{8}));
  ASSERT_EQ(e.mask.dtype(), DType::f32);
  ASSERT_EQ(e.mask.shape(), (Shape{8}));
  const std::vector<int64_t> want = {Tokenizer::kBos, tok.id("a"), tok.id("person"), tok.id("walks"),
                                     tok.id("forward"), Tokenizer::kEos, Tokenizer::kPad, Tokenizer::kPad};
  EXPECT_EQ(ids_of(e), want);
  EXPECT_EQ(mask_of(e), (std::vector<float>{1, 1, 1, 1, 1, 1, 0, 0}));
  EXPECT_EQ(e.length, 6);
  EXPECT_EQ(e.unknown, 0);
  EXPECT_FALSE(e.truncated);
  for (int64_t i = 1; i <= 4; ++i) EXPECT_GT(want[(size_t)i], Tokenizer::kEos);
}

TEST(Tokenizer, EncodeTruncatesButKeepsEos) {
  Tokenizer tok = small_tokenizer();
  Encoded e = tok.encode("a person walks forward", 4);  // room for two words
  EXPECT_EQ(ids_of(e), (std::vector<int64_t>{Tokenizer::kBos, tok.id("a"), tok.id("person"), Tokenizer::kEos}));
  EXPECT_EQ(mask_of(e), (std::vector<float>{1, 1, 1, 1}));
  EXPECT_TRUE(e.truncated);
  EXPECT_EQ(e.length, 4);
  Encoded exact = tok.encode("a person walks forward", 6);
  EXPECT_FALSE(exact.truncated);
  EXPECT_EQ(exact.length, 6);
  Encoded two = tok.encode("a person", 2);
  EXPECT_EQ(ids_of(two), (std::vector<int64_t>{Tokenizer::kBos, Tokenizer::kEos}));
  EXPECT_TRUE(two.truncated);
  Encoded empty = tok.encode("", 3);
  EXPECT_EQ(ids_of(empty), (std::vector<int64_t>{Tokenizer::kBos, Tokenizer::kEos, Tokenizer::kPad}));
  EXPECT_FALSE(empty.truncated);
  EXPECT_EQ(tok.decode(e.ids), "a person");
}

TEST(Tokenizer, UnknownWords) {
  Tokenizer tok = small_tokenizer();
  Encoded e = tok.encode("a person moonwalks backward", 8);
  EXPECT_EQ(e.unknown, 2);
  auto ids = ids_of(e);
  EXPECT_EQ(ids[3], Tokenizer::kUnk);
  EXPECT_EQ(ids[4], Tokenizer::kUnk);
  EXPECT_EQ(tok.decode(e.ids), "a person <unk> <unk>");
  // Special-token spellings in the text are not special: "<eos>" splits into punctuation and a word.
  EXPECT_EQ(split_words("<eos>"), (Words{"<", "eos", ">"}));
  EXPECT_EQ(tok.encode_words("<eos>"), (std::vector<int64_t>{1, 1, 1}));
  EXPECT_FALSE(tok.contains("<eos>"));
  EXPECT_TRUE(tok.contains("walks"));
}

TEST(Tokenizer, AllUnknownPrompts) {
  Tokenizer tok = small_tokenizer();
  EXPECT_TRUE(tok.all_unknown(""));
  EXPECT_TRUE(tok.all_unknown("   "));
  EXPECT_TRUE(tok.all_unknown("xyzzy qwerty"));
  EXPECT_TRUE(tok.all_unknown(", , ,"));          // punctuation is known but carries no meaning
  EXPECT_TRUE(tok.all_unknown("moonwalks!"));
  EXPECT_FALSE(tok.all_unknown("moonwalks, then!"));  // "then" is a word of small_tokenizer()
  EXPECT_FALSE(tok.all_unknown("xyzzy walks"));
  EXPECT_FALSE(tok.all_unknown("PERSON"));
}

TEST(Tokenizer, DecodeRoundTripsEveryCaptionForm) {
  std::vector<std::string> corpus;
  for (const auto& c : data::caption_contents())
    for (const auto& s : data::caption_styles()) {
      for (bool m : {false, true})
        for (const auto& t : data::caption_paraphrases(c.label, s.label, 11, 6, m)) corpus.push_back(t);
    }
  const size_t n = corpus.size();
  for (size_t i = 0; i + 1 < n; i += 37) corpus.push_back(data::compose_captions(corpus[i], corpus[i + 1]));
  Tokenizer tok = Tokenizer::build(corpus);
  EXPECT_TRUE(tok.contains(","));
  EXPECT_TRUE(tok.contains("then"));
  for (const auto& t : corpus) {
    Encoded e = tok.encode(t, 64);
    ASSERT_FALSE(e.truncated) << t;
    EXPECT_EQ(e.unknown, 0) << t;
    EXPECT_EQ(tok.decode(e.ids), t);
  }
  // decode skips <pad>/<bos> anywhere and stops at the first <eos>.
  const int64_t w = tok.id("walks");
  EXPECT_EQ(tok.decode(std::vector<int64_t>{Tokenizer::kPad, Tokenizer::kBos, w, Tokenizer::kEos, w}), "walks");
}

TEST(Tokenizer, EncodeBatchStacksItems) {
  Tokenizer tok = small_tokenizer();
  EncodedBatch b = tok.encode_batch({"a person walks", "", "someone waves the left hand, then bows"}, 6);
  ASSERT_EQ(b.ids.shape(), (Shape{3, 6}));
  ASSERT_EQ(b.mask.shape(), (Shape{3, 6}));
  EXPECT_EQ(b.length, (std::vector<int64_t>{5, 2, 6}));
  for (int64_t i = 0; i < 3; ++i) {
    Encoded e = tok.encode(i == 0 ? "a person walks" : i == 1 ? "" : "someone waves the left hand, then bows", 6);
    for (int64_t j = 0; j < 6; ++j) {
      EXPECT_EQ(b.ids.at({i, j}), e.ids.at({j}));
      EXPECT_EQ(b.mask.at({i, j}), e.mask.at({j}));
    }
  }
  EncodedBatch none = tok.encode_batch({}, 4);
  EXPECT_EQ(none.ids.shape(), (Shape{0, 4}));
}

TEST(Tokenizer, SaveLoadThroughCheckpointFile) {
  Tokenizer tok = Tokenizer::build({"a person walks forward", "someone, then", "a person runs"}, 1);
  nn::Checkpoint ck;
  ck.put("dummy", Tensor::ones({2}));
  tok.save_to(ck, "tok");
  EXPECT_TRUE(ck.meta["tok"]["vocab"].is_array());
  auto dir = std::filesystem::temp_directory_path() / ("t2m_test_tokenizer_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "tok.ckpt").string();
  ck.save(path);
  nn::Checkpoint back = nn::Checkpoint::load(path);
  Tokenizer tok2 = Tokenizer::load_from(back, "tok");
  EXPECT_EQ(tok2.vocab(), tok.vocab());
  EXPECT_EQ(tok2.min_freq(), tok.min_freq());
  for (const char* t : {"a person walks forward", "someone runs, then walks", "unknown words here"})
    EXPECT_EQ(ids_of(tok2.encode(t, 10)), ids_of(tok.encode(t, 10)));
  std::filesystem::remove_all(dir);
  EXPECT_NE(error_of([&] { Tokenizer::load_from(back, "tokenizer"); }).find("meta['tokenizer'] is missing"),
            std::string::npos);
}

TEST(Tokenizer, LoadRejectsMalformedMeta) {
  auto load_with = [](nlohmann::json j) {
    nn::Checkpoint ck;
    ck.meta["tokenizer"] = std::move(j);
    return error_of([&] { Tokenizer::load_from(ck); });
  };
  const nlohmann::json good = {{"format", "t2m-tokenizer-1"}, {"min_freq", 1},
                               {"vocab", {"<pad>", "<unk>", "<bos>", "<eos>", "walk"}}};
  EXPECT_EQ(load_with(good), "<no error>");
  auto bad = good;
  bad["format"] = "t2m-tokenizer-0";
  EXPECT_NE(load_with(bad).find("format"), std::string::npos);
  bad = good;
  bad["vocab"] = "walk";
  EXPECT_NE(load_with(bad).find("'vocab' is not a list"), std::string::npos);
  bad = good;
  bad["vocab"][4] = 5;
  EXPECT_NE(load_with(bad).find("vocab entry 4 is not a string"), std::string::npos);
  bad = good;
  bad["vocab"].push_back("walk");
  EXPECT_NE(load_with(bad).find("duplicate vocabulary entry 'walk'"), std::string::npos);
  bad = good;
  bad["vocab"] = {"<unk>", "<pad>", "<bos>", "<eos>"};
  EXPECT_NE(load_with(bad).find("must start with <pad> <unk> <bos> <eos>"), std::string::npos);
  bad = good;
  bad.erase("min_freq");
  EXPECT_NE(load_with(bad).find("min_freq"), std::string::npos);
  EXPECT_NE(load_with(nlohmann::json::array()).find("is not an object"), std::string::npos);
}

TEST(Tokenizer, BadInputThrows) {
  Tokenizer tok = small_tokenizer();
  EXPECT_NE(error_of([&] { tok.encode("a person", 1); }).find("tokenizer encode: max_len must be >= 2 for <bos> and <eos> (got 1)"),
            std::string::npos);
  EXPECT_NE(error_of([&] { tok.encode_batch({"a"}, 0); }).find("max_len must be >= 2"), std::string::npos);
  EXPECT_NE(error_of([&] { tok.decode(std::vector<int64_t>{2, 99999}); }).find("id 99999 out of range"),
            std::string::npos);
  EXPECT_NE(error_of([&] { tok.decode(std::vector<int64_t>{-1}); }).find("id -1 out of range"), std::string::npos);
  EXPECT_NE(error_of([&] { tok.decode(Tensor::zeros({2, 2}, DType::i64)); }).find("1-D int64"), std::string::npos);
  EXPECT_NE(error_of([&] { tok.decode(Tensor::zeros({3})); }).find(dtype_name(DType::f32)), std::string::npos);
  EXPECT_NE(error_of([] { Tokenizer::build({"a"}, 0); }).find("min_freq must be >= 1"), std::string::npos);
  const Words sp = Tokenizer::special_tokens();
  auto with = [&](const std::string& w) {
    Words v = sp;
    v.push_back(w);
    return error_of([&] { Tokenizer t(v); });
  };
  EXPECT_NE(with("Walk").find("'Walk' is not a single normalised word"), std::string::npos);
  EXPECT_NE(with("two words").find("is not a single normalised word"), std::string::npos);
  EXPECT_NE(with("").find("is not a single normalised word"), std::string::npos);
  EXPECT_NE(with("<pad>").find("'<pad>' is not a single normalised word"), std::string::npos);
  EXPECT_NE(error_of([&] { Tokenizer t(Words{"<pad>", "<unk>", "<bos>", "<eos>", "walk", "run", "walk"}); })
                .find("duplicate vocabulary entry 'walk' at id 6"),
            std::string::npos);
  EXPECT_EQ(with("bye-bye"), "<no error>");
  EXPECT_EQ(Tokenizer().vocab_size(), 4);
}

// The real vocabulary: captions of the train split of the 2,785 Bandai clips (tests/fixtures/data), 64 paraphrases
// per clip, mirrored, plus compositions. Prints the size (the number the text encoder's embedding table uses).
TEST(Tokenizer, TrainSplitVocabulary) {
  const std::string path = std::string(T2M_SOURCE_DIR) + "/tests/fixtures/data/bandai_splits.json";
  if (!std::ifstream(path)) GTEST_SKIP() << path << " missing";
  auto splits = data::load_splits(path);
  CaptionCorpusOptions opt;
  auto corpus = split_caption_corpus(splits, data::Split::train, opt);
  Tokenizer tok = Tokenizer::build(corpus);
  Tokenizer again = Tokenizer::build(split_caption_corpus(splits, data::Split::train, opt));
  EXPECT_EQ(tok.vocab(), again.vocab());
  std::set<std::string> distinct(corpus.begin(), corpus.end());
  std::printf("train captions: %zu texts (%zu distinct), vocabulary %lld tokens (4 specials), top words:",
              corpus.size(), distinct.size(), (long long)tok.vocab_size());
  for (int64_t i = 4; i < std::min<int64_t>(12, tok.vocab_size()); ++i) std::printf(" %s", tok.token(i).c_str());
  std::printf("\n");
  RecordProperty("vocab_size", (int)tok.vocab_size());
  EXPECT_GT(tok.vocab_size(), 200);
  EXPECT_LT(tok.vocab_size(), 2000);
  for (const char* w : {",", "then", "left", "right", "walks", "bye-bye"}) EXPECT_TRUE(tok.contains(w)) << w;
  size_t longest = 0;
  for (const auto& t : distinct) {
    longest = std::max(longest, split_words(t).size());
    ASSERT_EQ(tok.decode(tok.encode(t, 96).ids), t);
  }
  std::printf("longest train caption: %zu words\n", longest);
  // Test-split captions: every word should be known (all labels occur in train).
  int64_t unknown = 0;
  for (const auto& t : split_caption_corpus(splits, data::Split::test, opt)) unknown += tok.encode(t, 96).unknown;
  EXPECT_EQ(unknown, 0);
}
