// compose.h — Text2BFM-Compose (§4.4, Eq 18–19): a multi-action prompt split into clauses, one program per clause,
// the decoded policy-latent sequences concatenated with a blended overlap at each clause boundary.
//
// split_clauses(prompt): the prompt's words (text/tokenizer.h split_words: lower-cased, punctuation as tokens) cut
//   at the separators "," ";" "." "then" and "after that" (an "and" right before or after a separator is dropped:
//   "walks and then waves" -> {"walks", "waves"}); each clause is join_words of its words; empty clauses are
//   dropped. A prompt without separators gives one clause (its normalised text); an empty prompt gives none.
// overlap_blend_weights(O): Eq 19 rho_o = o / (O + 1), o = 1..O  -> O values in (0, 1), increasing.
// compose_latents(segs, O): segs[n] (T_n, d), n = 1..N. Eq 18 concatenates them; Eq 19 replaces the O latents on
//   each side of a boundary by their blend: z~_o = (1 - rho_o) z^(n)_{T_n - O + o} + rho_o z^(n+1)_o, so the
//   last O latents of segment n and the first O of segment n+1 become O blended latents and the result has
//   sum_n T_n - (N - 1) O rows. O = 0 is the plain concatenation. Returns (T, d) float32, contiguous.
//   Blended latents are not re-projected here (the pipeline projects every latent onto the policy's sphere).
// Errors (t2m::Error "compose: ..."): no segments, a segment not 2-D or of another width d, O < 0, a segment
//   shorter than O (ends) or 2 O (a middle segment, which has an overlap on both sides).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "tensor/tensor.h"

namespace t2m::text2bfm {

std::vector<std::string> split_clauses(const std::string& prompt);

// Text2BFM Eq 19: blend weights rho_o = o / (O + 1).
std::vector<double> overlap_blend_weights(int64_t O);

// Text2BFM Eq 18–19: concatenation of decoded latent segments with O blended steps per boundary.
Tensor compose_latents(const std::vector<Tensor>& segs, int64_t O);

}  // namespace t2m::text2bfm
