// compose.cpp — clause splitting and the Eq 18–19 latent concatenation with overlap blending.
#include "models/text2bfm/compose.h"

#include "models/text/tokenizer.h"
#include <algorithm>

namespace t2m::text2bfm {

namespace {

bool is_separator_word(const std::string& w) { return w == "," || w == ";" || w == "." || w == "then"; }

void flush_clause(std::vector<std::string>& words, std::vector<std::string>& out) {
  while (!words.empty() && words.back() == "and") words.pop_back();
  size_t first = 0;
  while (first < words.size() && words[first] == "and") ++first;
  if (first < words.size()) out.push_back(text::join_words({words.begin() + (long)first, words.end()}));
  words.clear();
}

}  // namespace

std::vector<std::string> split_clauses(const std::string& prompt) {
  const std::vector<std::string> w = text::split_words(prompt);
  std::vector<std::string> out, cur;
  for (size_t i = 0; i < w.size(); ++i) {
    if (is_separator_word(w[i])) {
      flush_clause(cur, out);
    } else if (w[i] == "after" && i + 1 < w.size() && w[i + 1] == "that") {
      flush_clause(cur, out);
      ++i;
    } else {
      cur.push_back(w[i]);
    }
  }
  flush_clause(cur, out);
  return out;
}

std::vector<double> overlap_blend_weights(int64_t O) {
  if (O < 0) throw Error("compose: overlap O must be >= 0, got " + std::to_string(O));
  std::vector<double> rho((size_t)O);
  for (int64_t o = 1; o <= O; ++o) rho[(size_t)o - 1] = double(o) / double(O + 1);
  return rho;
}

Tensor compose_latents(const std::vector<Tensor>& segs, int64_t O) {
  if (segs.empty()) throw Error("compose: no latent segments");
  const std::vector<double> rho = overlap_blend_weights(O);
  const int64_t N = (int64_t)segs.size();
  std::vector<Tensor> c(segs.size());
  int64_t d = -1, total = 0;
  for (int64_t n = 0; n < N; ++n) {
    const Tensor& s = segs[(size_t)n];
    if (!s.defined() || s.dim() != 2)
      throw Error("compose: segment " + std::to_string(n) + " must be (T, d)");
    if (d < 0) d = s.size(1);
    if (s.size(1) != d)
      throw Error("compose: segment " + std::to_string(n) + " has width " + std::to_string(s.size(1)) +
                  ", segment 0 has " + std::to_string(d));
    const int64_t need = (n > 0 && n + 1 < N) ? 2 * O : (N > 1 ? O : 0);
    if (s.size(0) < std::max<int64_t>(need, 1))
      throw Error("compose: segment " + std::to_string(n) + " has " + std::to_string(s.size(0)) +
                  " latents, the overlap O = " + std::to_string(O) + " needs at least " +
                  std::to_string(std::max<int64_t>(need, 1)));
    c[(size_t)n] = s.to(DType::f32).contiguous();
    total += s.size(0);
  }
  total -= (N - 1) * O;
  Tensor out = Tensor::empty({total, d});
  float* o = out.data<float>();
  int64_t row = 0;
  for (int64_t n = 0; n < N; ++n) {
    const float* s = c[(size_t)n].data<float>();
    const int64_t T = c[(size_t)n].size(0);
    const int64_t begin = n > 0 ? O : 0;        // the first O rows went into the previous boundary's blend
    const int64_t end = n + 1 < N ? T - O : T;  // the last O rows go into the next boundary's blend
    for (int64_t t = begin; t < end; ++t, ++row)
      for (int64_t k = 0; k < d; ++k) o[row * d + k] = s[t * d + k];
    if (n + 1 < N) {
      const float* nx = c[(size_t)n + 1].data<float>();
      for (int64_t q = 1; q <= O; ++q, ++row) {  // Eq 19
        const double r = rho[(size_t)q - 1];
        for (int64_t k = 0; k < d; ++k)
          o[row * d + k] = float((1.0 - r) * s[(T - O + q - 1) * d + k] + r * nx[(q - 1) * d + k]);
      }
    }
  }
  return out;
}

}  // namespace t2m::text2bfm
