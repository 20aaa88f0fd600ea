// viterbi.h — the max-sum (Viterbi) decoder over a lattice of K steps x N candidates (PRO-Motion Sec 3.3,
// posture planning; Forney 1973). Generic: it knows nothing about poses, only scores.
//
//   emission   (K, N)      e[k][j]   score of candidate j at step k              (log E^k_j in the paper)
//   transition (K-1, N, N) a[k][i][j] score of going from candidate i at step k to candidate j at step k+1
//                                                                                (log A^{k+1}_{ij} in the paper)
//   path g = (g_0, ..., g_{K-1}) maximises  S(g) = e[0][g_0] + sum_{k>=1} (a[k-1][g_{k-1}][g_k] + e[k][g_k])
// (the log of PRO-Motion's P(G) = E^1_{g_1} prod_{i>=2} E^i_{g_i} A^i_{g_{i-1} g_i}).
// Scores are read as double (float32 or float64 tensors of any strides) and accumulated in double. Ties: among
// equally scoring paths the decoder returns the one whose LAST index is smallest, then the one whose
// second-to-last index is smallest, and so on (backpointers and the final choice take the smallest index among
// maxima), which a brute-force enumeration can reproduce exactly.
// K = 1: the argmax of the emission row (transition must then be (0, N, N) or undefined).
// Errors (t2m::Error, message starts "viterbi:" and names the shapes): emission not 2-D float with K, N >= 1;
// transition not (K-1, N, N) float (undefined is allowed only for K = 1); a non-finite score.
#pragma once
#include <vector>

#include "tensor/tensor.h"

namespace t2m::promotion {

struct ViterbiPath {
  std::vector<int> path;  // (K) candidate index per step
  double score = 0;       // S(path)
};

ViterbiPath viterbi_decode(const Tensor& emission, const Tensor& transition);

// S(path) for a given path (the same sum in the same order as the decoder; for tests and reports).
double viterbi_path_score(const Tensor& emission, const Tensor& transition, const std::vector<int>& path);

}  // namespace t2m::promotion
