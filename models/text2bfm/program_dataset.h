// program_dataset.h — the training data of the flow generator (Text2BFM §4.2, Eq 14–15): per train clip the
// compact program m = the posterior mean of the frozen VBB encoder q_φ(m | z_{1:Tz}) (Eq 3) over the clip's
// policy latents z (Eq 2 with the frozen BFM), and the frozen text encoder's token features of its captions.
//
// encode_programs(vbb, latents): latents[i] (Tz_i, d) -> programs[i] (Tm_i, latent), Tm_i = ceil(Tz_i / c); a clip
//   is right-padded to a multiple of c by repeating its last latent (replicate padding, as the causal convs do on
//   the left). One clip per encoder call (no cross-clip GroupNorm statistics), eval mode, no graph.
// ProgramDataset: programs are stored STANDARDISED, (m - mean) / std per latent channel, with mean/std over
//   every program frame of the set (computed by make_program_dataset); the generator learns that space and the
//   pipeline undoes it (pipeline_checkpoints.h "program_mean"/"program_std").
// sample_program_batch: B clips uniformly with replacement; per clip one caption uniformly; a window of W program
//   frames at a uniform start (clips shorter than W are right-padded with zeros and mask 0). Draws from rng only.
//   Returns m (B, W, latent), m_mask (B, W) float 0/1, tokens (B, L, D) and tok_mask (B, L) (L = the longest
//   caption of the whole set).
// Errors (t2m::Error "program dataset: ..."): no clips, a latent sequence not (Tz, vbb in_dim) or empty, a clip
//   without captions, caption indices out of range, W < 1, B < 1.
#pragma once
#include <cstdint>
#include <vector>

#include "models/text2bfm/vbb.h"
#include "tensor/rng.h"
#include "tensor/tensor.h"

namespace t2m::text2bfm {

std::vector<Tensor> encode_programs(const Vbb& vbb, const std::vector<Tensor>& latents);

struct ProgramDataset {
  std::vector<Tensor> programs;                // (Tm_i, latent) standardised
  std::vector<std::vector<int64_t>> captions;  // per clip: rows of tokens
  Tensor tokens, tok_mask;                     // (Ncap, L, D) token features, (Ncap, L) mask
  Tensor mean, std;                            // (latent) f32
  int64_t window = 16;                         // W, program frames per training window
};

// programs (raw posterior means), captions[i] = caption rows of clip i, tokens/tok_mask of every caption.
ProgramDataset make_program_dataset(std::vector<Tensor> programs, std::vector<std::vector<int64_t>> captions,
                                    Tensor tokens, Tensor tok_mask, int64_t window);

struct ProgramBatch {
  Tensor m, m_mask, tokens, tok_mask;
};
ProgramBatch sample_program_batch(const ProgramDataset& d, int64_t B, Generator& rng);

}  // namespace t2m::text2bfm
