// ar_sample.h — autoregressive sampling of motion tokens from the GPT (CASIM Eq 1: c_i ~ p(c_i | c_<i, text)),
// with temperature and top-k, seedable.
//
// sample_codes(model, text, opt, gen): text holds B conditions (ar_gpt.h ArText); every row is sampled in parallel,
// one full forward per step (no KV cache: sequences are at most 1 + L + max_motion tokens long). Step i draws
//   u ~ U[0, 1) per row from gen (one rand_uniform of B values per step, so a seed fixes the result for any thread
//   count), p = softmax(logits_i / temperature) over the top_k largest logits (top_k 0 = all K + 1), and picks the
//   inverse-CDF index of u, the CDF running over the candidates in order of descending logit (ties: lower index
//   first). temperature 0 = greedy (argmax; u is still drawn).
// Length: opt.tokens == 0: until the end token (id K) or max_motion tokens; the end token is disallowed at step 0
//   (every motion has at least one token). opt.tokens > 0: exactly that many tokens (<= max_motion), the end token
//   disallowed. Rows that ended keep being fed (their later draws are discarded).
// Returns B code lists (ints in [0, K)).
// Errors (t2m::Error "ar sample: ..."): temperature < 0, top_k < 0, tokens < 0 or > max_motion.
#pragma once
#include <cstdint>
#include <vector>

#include "models/casim/ar_gpt.h"
#include "tensor/rng.h"

namespace t2m::casim {

struct ArSampleOptions {
  double temperature = 1.0;
  int64_t top_k = 0;
  int64_t tokens = 0;
};

std::vector<std::vector<int64_t>> sample_codes(const ArGpt& model, const ArText& text, const ArSampleOptions& opt,
                                               Generator& gen);

// One categorical draw from a row of logits (size V) with the options above; `allow_end` false masks index V - 1.
// u in [0, 1). Exposed for tests.
int64_t sample_from_logits(const float* logits, int64_t V, double temperature, int64_t top_k, bool allow_end,
                           double u);

}  // namespace t2m::casim
