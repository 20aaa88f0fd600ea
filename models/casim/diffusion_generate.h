// diffusion_generate.h — text in, raw motion features out, with a trained CASIM-MDM bundle and the frozen text
// encoder (models/checkpoints/text_encoder.t2mckpt). What `t2m generate --model casim-diff-*`, `t2m eval casim`
// and the trainer (text side) call.
//
// encode_diffusion_text(text_bundle, captions): the frozen encoder's outputs without a graph:
//   tokens (N, L, 256) per-token features y_{j,k}, tok_mask (N, L), pooled (N, 256) sentence feature
//   (encode_captions: L = the longest caption, capped at the encoder's max_len).
// generate_motion_features(bundle, text_bundle, captions, frames, opt, seed, batch): one motion per caption,
//   frames[i] >= 1 frames long (30 fps), in batches of `batch` captions (padded to the longest of the batch, frame
//   mask). Batch k draws its noise from Generator(seed + 7919 k): the result is a pure function of (captions,
//   frames, opt, seed, batch, thread count). Returns raw (denormalised) features [frames[i], 257] per caption.
// Errors (t2m::Error "casim generate: ..."): empty caption list, sizes differ, frames < 1, batch < 1; text encoder
//   and model errors pass through.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "models/casim/diffusion_checkpoint.h"
#include "models/text/retrieval_model.h"

namespace t2m::casim {

DiffusionText encode_diffusion_text(const text::RetrievalBundle& text_bundle, const std::vector<std::string>& captions);

std::vector<std::vector<float>> generate_motion_features(const DiffusionBundle& bundle,
                                                         const text::RetrievalBundle& text_bundle,
                                                         const std::vector<std::string>& captions,
                                                         const std::vector<int64_t>& frames,
                                                         const SamplerOptions& opt, uint64_t seed,
                                                         int64_t batch = 32);

}  // namespace t2m::casim
