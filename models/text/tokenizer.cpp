// tokenizer.cpp — word splitting, vocabulary building, encode/decode, checkpoint persistence.
#include "models/text/tokenizer.h"

#include <algorithm>
#include <cstring>

namespace t2m::text {

namespace {

constexpr const char* kFormat = "t2m-tokenizer-1";

bool is_word_byte(unsigned char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c >= 0x80;
}
bool is_space_byte(unsigned char c) { return c <= 0x20 || c == 0x7f; }
bool is_joiner(unsigned char c) { return c == '-' || c == '\''; }
bool attaches_left(const std::string& w) { return w.size() == 1 && std::strchr(",.;:!?", w[0]) != nullptr; }
bool has_alnum(const std::string& w) {
  for (unsigned char c : w)
    if (is_word_byte(c)) return true;
  return false;
}

}  // namespace

std::vector<std::string> split_words(const std::string& text) {
  std::vector<std::string> out;
  std::string cur;
  auto flush = [&] {
    if (!cur.empty()) out.push_back(std::move(cur));
    cur.clear();
  };
  const size_t n = text.size();
  for (size_t i = 0; i < n; ++i) {
    const unsigned char c = (unsigned char)text[i];
    if (is_word_byte(c)) {
      cur.push_back((c >= 'A' && c <= 'Z') ? (char)(c - 'A' + 'a') : (char)c);
    } else if (is_joiner(c) && !cur.empty() && i + 1 < n && is_word_byte((unsigned char)text[i + 1])) {
      cur.push_back((char)c);  // "bye-bye", "don't": one word
    } else if (is_space_byte(c)) {
      flush();
    } else {
      flush();
      out.emplace_back(1, (char)c);  // punctuation is a token of its own
    }
  }
  flush();
  return out;
}

std::string join_words(const std::vector<std::string>& words) {
  std::string out;
  for (const auto& w : words) {
    if (!out.empty() && !attaches_left(w)) out.push_back(' ');
    out += w;
  }
  return out;
}

std::string normalize(const std::string& text) { return join_words(split_words(text)); }

const std::vector<std::string>& Tokenizer::special_tokens() {
  static const std::vector<std::string> s = {"<pad>", "<unk>", "<bos>", "<eos>"};
  return s;
}

Tokenizer::Tokenizer() : Tokenizer(special_tokens(), 1) {}

Tokenizer::Tokenizer(std::vector<std::string> vocab, int min_freq) : vocab_(std::move(vocab)), min_freq_(min_freq) {
  if (min_freq < 1) throw Error("tokenizer: min_freq must be >= 1 (got " + std::to_string(min_freq) + ")");
  const auto& sp = special_tokens();
  if (vocab_.size() < sp.size() || !std::equal(sp.begin(), sp.end(), vocab_.begin()))
    throw Error("tokenizer: the vocabulary must start with <pad> <unk> <bos> <eos> (size " +
                std::to_string(vocab_.size()) + ")");
  for (size_t i = 0; i < vocab_.size(); ++i) {
    const std::string& w = vocab_[i];
    if (i >= sp.size()) {
      auto parts = split_words(w);
      if (parts.size() != 1 || parts[0] != w)
        throw Error("tokenizer: vocabulary entry " + std::to_string(i) + " '" + w +
                    "' is not a single normalised word");
    }
    if (!index_.emplace(w, (int64_t)i).second)
      throw Error("tokenizer: duplicate vocabulary entry '" + w + "' at id " + std::to_string(i));
  }
}

Tokenizer Tokenizer::build(const std::vector<std::string>& corpus, int min_freq) {
  if (min_freq < 1) throw Error("tokenizer build: min_freq must be >= 1 (got " + std::to_string(min_freq) + ")");
  std::unordered_map<std::string, int64_t> counts;
  for (const auto& t : corpus)
    for (auto& w : split_words(t)) ++counts[w];
  std::vector<std::pair<std::string, int64_t>> kept;
  for (auto& [w, c] : counts)
    if (c >= min_freq) kept.emplace_back(w, c);
  std::sort(kept.begin(), kept.end(), [](const auto& a, const auto& b) {
    return a.second != b.second ? a.second > b.second : a.first < b.first;
  });
  std::vector<std::string> vocab = special_tokens();
  for (auto& [w, c] : kept) vocab.push_back(w);
  return Tokenizer(std::move(vocab), min_freq);
}

int64_t Tokenizer::id(const std::string& word) const {
  auto it = index_.find(word);
  return it == index_.end() ? kUnk : it->second;
}

bool Tokenizer::contains(const std::string& word) const {
  auto it = index_.find(word);
  return it != index_.end() && it->second > kEos;
}

const std::string& Tokenizer::token(int64_t id) const {
  if (id < 0 || id >= vocab_size())
    throw Error("tokenizer token: id " + std::to_string(id) + " out of range [0, " + std::to_string(vocab_size()) +
                ")");
  return vocab_[(size_t)id];
}

std::vector<int64_t> Tokenizer::encode_words(const std::string& text) const {
  std::vector<int64_t> ids;
  for (const auto& w : split_words(text)) {
    int64_t i = id(w);
    ids.push_back(i > kEos ? i : kUnk);  // a literal "<eos>" in the text cannot be produced by split_words anyway
  }
  return ids;
}

Encoded Tokenizer::encode(const std::string& text, int64_t max_len) const {
  if (max_len < 2)
    throw Error("tokenizer encode: max_len must be >= 2 for <bos> and <eos> (got " + std::to_string(max_len) + ")");
  std::vector<int64_t> words = encode_words(text);
  Encoded e;
  for (int64_t w : words) e.unknown += (w == kUnk);
  const int64_t keep = std::min<int64_t>((int64_t)words.size(), max_len - 2);
  e.truncated = keep < (int64_t)words.size();
  e.length = keep + 2;
  e.ids = Tensor::zeros({max_len}, DType::i64);
  e.mask = Tensor::zeros({max_len}, DType::f32);
  int64_t* ids = e.ids.data<int64_t>();
  float* mask = e.mask.data<float>();
  ids[0] = kBos;
  for (int64_t i = 0; i < keep; ++i) ids[1 + i] = words[(size_t)i];
  ids[keep + 1] = kEos;
  for (int64_t i = 0; i < e.length; ++i) mask[i] = 1.0f;
  return e;
}

EncodedBatch Tokenizer::encode_batch(const std::vector<std::string>& texts, int64_t max_len) const {
  if (max_len < 2)
    throw Error("tokenizer encode_batch: max_len must be >= 2 (got " + std::to_string(max_len) + ")");
  const int64_t B = (int64_t)texts.size();
  EncodedBatch out;
  out.ids = Tensor::zeros({B, max_len}, DType::i64);
  out.mask = Tensor::zeros({B, max_len}, DType::f32);
  for (int64_t b = 0; b < B; ++b) {
    Encoded e = encode(texts[(size_t)b], max_len);
    std::memcpy(out.ids.data<int64_t>() + b * max_len, e.ids.data<int64_t>(), sizeof(int64_t) * max_len);
    std::memcpy(out.mask.data<float>() + b * max_len, e.mask.data<float>(), sizeof(float) * max_len);
    out.length.push_back(e.length);
  }
  return out;
}

std::string Tokenizer::decode(const std::vector<int64_t>& ids) const {
  std::vector<std::string> words;
  for (int64_t i : ids) {
    const std::string& t = token(i);  // range check first: a bad id anywhere is an error
    if (i == kEos) break;
    if (i == kPad || i == kBos) continue;
    words.push_back(t);
  }
  return join_words(words);
}

std::string Tokenizer::decode(const Tensor& ids) const {
  if (!ids.defined() || ids.dtype() != DType::i64 || ids.dim() != 1)
    throw Error("tokenizer decode: expected a 1-D int64 tensor, got " +
                (ids.defined() ? std::string(dtype_name(ids.dtype())) + " " + shape_str(ids.shape())
                               : std::string("an undefined tensor")));
  return decode(ids.to_vector<int64_t>());
}

bool Tokenizer::all_unknown(const std::string& text) const {
  for (const auto& w : split_words(text))
    if (has_alnum(w) && contains(w)) return false;
  return true;
}

void Tokenizer::save_to(nn::Checkpoint& ckpt, const std::string& key) const {
  ckpt.meta[key] = {{"format", kFormat}, {"min_freq", min_freq_}, {"vocab", vocab_}};
}

Tokenizer Tokenizer::load_from(const nn::Checkpoint& ckpt, const std::string& key) {
  const std::string where = "tokenizer load: checkpoint " + ckpt.source() + " meta['" + key + "']";
  if (!ckpt.meta.is_object() || !ckpt.meta.contains(key)) throw Error(where + " is missing");
  const auto& j = ckpt.meta.at(key);
  if (!j.is_object()) throw Error(where + " is not an object");
  if (!j.contains("format") || !j.at("format").is_string() || j.at("format").get<std::string>() != kFormat)
    throw Error(where + ": format is not \"" + kFormat + "\"");
  if (!j.contains("vocab") || !j.at("vocab").is_array()) throw Error(where + ": 'vocab' is not a list");
  if (!j.contains("min_freq") || !j.at("min_freq").is_number_integer())
    throw Error(where + ": 'min_freq' is not an integer");
  std::vector<std::string> vocab;
  for (const auto& v : j.at("vocab")) {
    if (!v.is_string()) throw Error(where + ": vocab entry " + std::to_string(vocab.size()) + " is not a string");
    vocab.push_back(v.get<std::string>());
  }
  try {
    return Tokenizer(std::move(vocab), j.at("min_freq").get<int>());
  } catch (const Error& e) {
    throw Error(where + ": " + e.what());
  }
}

}  // namespace t2m::text
