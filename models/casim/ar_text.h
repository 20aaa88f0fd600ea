// ar_text.h — the frozen text encoder (models/text/text_encoder.h, our stand-in for CLIP) as the GPT's condition:
// captions -> ArText {tokens y (B, L, 256), mask (B, L), pooled (B, 256)}, no graph. L = the longest caption of
// the call (<= the encoder's max_len; longer captions are cut by the tokenizer).
// Errors: those of encode_captions / TextEncoder::forward (empty list, a caption without tokens).
#pragma once
#include <string>
#include <vector>

#include "models/casim/ar_gpt.h"
#include "models/text/retrieval_model.h"
#include "models/text/text_encoder.h"

namespace t2m::casim {

class ArTextEncoder {
 public:
  explicit ArTextEncoder(const std::string& text_encoder_path);
  ArText encode(const std::vector<std::string>& captions) const;
  const text::TextEncoderConfig& config() const { return enc_->config(); }

 private:
  text::RetrievalBundle bundle_;
  const text::TextEncoder* enc_ = nullptr;
};

}  // namespace t2m::casim
