// compositional.h — the compositional metrics of Text2BFM §4.3 (Table 2) on one generated motion of an N-clause
// prompt. Pure functions: no model, no I/O.
//
// segment_bounds_uniform(T, N): N segments of [0, T): b_0 = 0, b_n = floor(n T / N), b_N = T (the paper's "uniform
//   segments" for a single-program generation). Returns N + 1 bounds.
// order_correct(seg, clause): seg (N, D) embeddings of the N segments in time order, clause (N, D) embeddings of the
//   N clauses in prompt order (the frozen evaluator's). Each segment is assigned the clause of highest cosine
//   similarity; the order is correct iff the assigned indices are strictly increasing and match the target
//   sequence, i.e. segment i is assigned clause i for every i (ties: the lowest index wins).
//   Order Accuracy over a set of prompts = the fraction of prompts whose order is correct.
// segment_mm_dist(seg, clause): mean_i ||seg_i − clause_i|| (MM-Dist of Table 2, per segment and its own clause).
// transition_score(features, bounds): Text2BFM Eq 20, Transition = 1/(N−1) Σ_{i=1}^{N−1} (||s_{i+1} − s_i|| +
//   ||v_{i+1} − v_i||) with, at the boundary b_i between segment i and i+1 of raw features [T, 257]
//   (models/data/features.h): s_i = the root-relative joint positions [4, 64) (m) of the last frame of segment i
//   (b_i − 1), s_{i+1} those of the first frame of segment i+1 (b_i); v the same two frames' joint velocities
//   [190, 253) converted to m/s (x 30 fps). N = 1 gives 0.
// Errors (t2m::Error "compositional: ..."): N < 1 or T < N; seg/clause not (N, D) of one shape; bounds not
//   strictly increasing from >= 0 to <= T, or an inner boundary at 0; features not a multiple of 257.
#pragma once
#include <cstdint>
#include <vector>

#include "tensor/tensor.h"

namespace t2m::eval {

std::vector<int64_t> segment_bounds_uniform(int64_t T, int64_t N);

// Text2BFM §4.3 Order Accuracy (one prompt): segment i's best clause is clause i for all i.
bool order_correct(const Tensor& seg, const Tensor& clause);

double segment_mm_dist(const Tensor& seg, const Tensor& clause);

// Text2BFM Eq 20: pose + velocity jump across each clause boundary, averaged over the N − 1 boundaries.
double transition_score(const std::vector<float>& features, const std::vector<int64_t>& bounds);

}  // namespace t2m::eval
