// ar_generate.h — text -> motion with the autoregressive CASIM baseline: frozen text encoder -> token GPT (cls or
// tok) -> sampled code sequence (ar_sample.h) -> tokenizer decoder -> denormalised raw features [T, 257], T = 4n.
// The C++ API behind `t2m generate --model casim-ar-cls|casim-ar-tok` and the batch evaluation.
//
// ArGenerator(dir, cond) loads DIR/text_encoder.t2mckpt, DIR/casim_vq.t2mckpt and DIR/casim_ar_<cond>.t2mckpt and
// checks that the GPT was trained on this tokenizer (its vq_crc equals the tokenizer file's CRC-32C).
// generate(captions, opt, gen): one motion per caption, sampled in one batch; opt as ar_sample.h (tokens = 0: the
// GPT decides the length with its end token).
// tokens_for_seconds(s): round(s · 30 / 4) clamped to [1, max_motion] (30 fps, 4 frames per token).
// Errors (t2m::Error naming the file): missing checkpoints (with the command that makes them), tokenizer mismatch.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "models/casim/ar_checkpoint.h"
#include "models/casim/ar_sample.h"
#include "models/casim/ar_text.h"

namespace t2m::casim {

class ArGenerator {
 public:
  ArGenerator(const std::string& checkpoint_dir, ArCond cond);
  std::vector<std::vector<float>> generate(const std::vector<std::string>& captions, const ArSampleOptions& opt,
                                           Generator& gen) const;
  int64_t tokens_for_seconds(double seconds) const;
  const ArGpt& gpt() const { return *ar_.model; }
  const std::string& gpt_path() const { return ar_path_; }

 private:
  std::string ar_path_;
  std::unique_ptr<ArTextEncoder> text_;
  VqBundle vq_;
  ArBundle ar_;
};

}  // namespace t2m::casim
