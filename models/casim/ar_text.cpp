// ar_text.cpp — caption encoding with the frozen text encoder.
#include "models/casim/ar_text.h"

#include <algorithm>

#include "autograd/no_grad.h"
#include "models/text/text_motion_model.h"

namespace t2m::casim {

ArTextEncoder::ArTextEncoder(const std::string& path) : bundle_(text::load_text_motion_model(path)) {
  enc_ = &dynamic_cast<const text::TextMotionModel&>(*bundle_.model).text();
}

ArText ArTextEncoder::encode(const std::vector<std::string>& captions) const {
  ag::NoGradGuard ng;
  const auto eb = text::encode_captions(bundle_.tokenizer, captions, enc_->config().max_len);
  int64_t L = 1;
  for (int64_t l : eb.length) L = std::max(L, l);
  const Tensor ids = eb.ids.slice(1, 0, L).contiguous(), mask = eb.mask.slice(1, 0, L).contiguous();
  const text::TextFeatures f = enc_->forward(ids, mask);  // real positions do not depend on the padding
  return {f.tokens.data().contiguous(), mask, f.pooled.data().contiguous()};
}

}  // namespace t2m::casim
