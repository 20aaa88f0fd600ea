// tokenizer.h — word-level tokenizer over the training captions (text side, ARCHITECTURE.md section 6).
//
// Normalisation (split_words): ASCII letters are lower-cased; a word is a maximal run of letters, digits and
// non-ASCII (UTF-8) bytes, where a single '-' or '\'' between two such characters stays inside the word
// ("bye-bye", "worn-out", "don't"); every other printable punctuation character is a token of its own
// ("slowly, like" -> "slowly" "," "like"; commas must survive: the Compose clause splitter splits on them);
// whitespace and control characters separate words. join_words() is the inverse for display: words separated by
// one space, no space before , . ; : ! ? — so decode(encode(t)) == normalize(t) for in-vocabulary text, and
// normalize(c) == c for every generated caption.
//
// Vocabulary: ids 0..3 are the special tokens <pad> <unk> <bos> <eos>; then every word of the corpus seen at least
// min_freq times, by descending count, ties by byte-wise ascending word. The order is a pure function of the
// corpus multiset (not of its order). Words never seen (or seen < min_freq times) map to <unk>.
//
// encode(text, max_len) -> ids (max_len,) int64 and mask (max_len,) float32: <bos> w_1 .. w_n <eos> <pad>...;
// mask 1 on <bos>, the words and <eos>, 0 on padding. When n > max_len - 2 the words are truncated to the first
// max_len - 2 and <eos> is still the last valid token (truncated = true). max_len must be >= 2.
// encode_batch stacks encodings into (B, max_len) int64 ids and (B, max_len) float32 mask.
// decode(ids) drops <pad> and <bos>, stops at the first <eos>, writes <unk> for the unknown id, and joins with
// join_words. Ids outside [0, vocab_size) throw.
//
// Persistence: save_to(ckpt, key) writes ckpt.meta[key] = {"format": "t2m-tokenizer-1", "min_freq": m,
// "vocab": [token, ...]} (the vocab as a JSON list, specials included); load_from reads it back and validates it.
// Errors (t2m::Error, message starts with "tokenizer"): max_len < 2, min_freq < 1, a vocabulary without the four
// specials in front, an empty or duplicate token, a token that is not a single normalised word, an id out of
// range, a missing or malformed meta entry (naming the checkpoint source and the key).
#pragma once
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "nn/checkpoint.h"
#include "tensor/tensor.h"

namespace t2m::text {

struct Encoded {
  Tensor ids;              // (max_len,) int64
  Tensor mask;             // (max_len,) float32, 1 = real token (<bos>, words, <eos>)
  int64_t length = 0;      // valid tokens = sum(mask), <= max_len
  int64_t unknown = 0;     // words mapped to <unk> (before truncation)
  bool truncated = false;  // words were dropped to fit max_len
};

struct EncodedBatch {
  Tensor ids;                    // (B, max_len) int64
  Tensor mask;                   // (B, max_len) float32
  std::vector<int64_t> length;   // per item
};

// Lower-cased words and punctuation tokens of a text (see the rules above). Never throws.
std::vector<std::string> split_words(const std::string& text);
// Words joined for display: one space between words, none before , . ; : ! ?
std::string join_words(const std::vector<std::string>& words);
// join_words(split_words(text)).
std::string normalize(const std::string& text);

class Tokenizer {
 public:
  static constexpr int64_t kPad = 0, kUnk = 1, kBos = 2, kEos = 3;
  static const std::vector<std::string>& special_tokens();  // {"<pad>", "<unk>", "<bos>", "<eos>"}

  Tokenizer();  // specials only
  // vocab must start with the four specials (in order); every other entry a distinct normalised word.
  explicit Tokenizer(std::vector<std::string> vocab, int min_freq = 1);
  // Counts the words of every corpus text and keeps those seen >= min_freq times (order: see above).
  static Tokenizer build(const std::vector<std::string>& corpus, int min_freq = 1);

  int64_t vocab_size() const { return (int64_t)vocab_.size(); }
  const std::vector<std::string>& vocab() const { return vocab_; }
  int min_freq() const { return min_freq_; }
  int64_t id(const std::string& word) const;         // kUnk when absent
  bool contains(const std::string& word) const;      // a regular word (not a special) of the vocabulary
  const std::string& token(int64_t id) const;        // throws when out of range

  // Word ids without <bos>/<eos>, no length limit.
  std::vector<int64_t> encode_words(const std::string& text) const;
  Encoded encode(const std::string& text, int64_t max_len) const;
  EncodedBatch encode_batch(const std::vector<std::string>& texts, int64_t max_len) const;
  std::string decode(const std::vector<int64_t>& ids) const;
  std::string decode(const Tensor& ids) const;       // 1-D int64

  // True when no word of the text (a token with a letter or digit; punctuation does not count) is in the
  // vocabulary, so also for empty or punctuation-only text: a prompt the model cannot read; the CLI rejects it.
  bool all_unknown(const std::string& text) const;

  void save_to(nn::Checkpoint& ckpt, const std::string& key = "tokenizer") const;
  static Tokenizer load_from(const nn::Checkpoint& ckpt, const std::string& key = "tokenizer");

 private:
  std::vector<std::string> vocab_;
  std::unordered_map<std::string, int64_t> index_;
  int min_freq_ = 1;
};

}  // namespace t2m::text
