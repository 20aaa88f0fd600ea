// loss_classification.h — softmax cross-entropy with ignore_index and label smoothing, and top-k accuracy.
//
// cross_entropy(logits, targets, opt): logits (..., C) float (the class dim is the LAST one, unlike
//   torch's dim 1), targets int64 of logits' shape without the last dim. With p = softmax(logits) over C
//   (computed as log_softmax, stable for any logit size), ε = label_smoothing ∈ [0, 1]:
//     ℓ_n = (1 − ε) · (−log p_{n, y_n}) + ε · (1/C) Σ_c (−log p_{n, c})      (torch's label smoothing)
//     loss = mean of ℓ_n over the positions n whose target != ignore_index.
//   When every target is ignored the loss is 0 with zero gradient (torch gives NaN). Gradient to logits only.
//   Errors ("cross_entropy: ..."): logits 0-d or C = 0, targets not int64 or the wrong shape (names both shapes),
//   a target outside [0, C) that is not ignore_index (names the value and position), ε outside [0, 1].
//
// accuracy(logits, targets, ignore_index, k): fraction of non-ignored positions whose target is among the top k
//   logits, counting a position correct when fewer than k classes have a logit STRICTLY greater than the
//   target's (ties count in the target's favour). Plain tensors, no graph; returns 0 when every target is
//   ignored. Errors ("accuracy: ..."): as cross_entropy, plus k < 1.
#pragma once
#include <cstdint>

#include "autograd/variable.h"

namespace t2m::nn {

struct CrossEntropyOptions {
  int64_t ignore_index = -100;
  double label_smoothing = 0.0;
};

ag::Variable cross_entropy(const ag::Variable& logits, const Tensor& targets, const CrossEntropyOptions& opt = {});

double accuracy(const Tensor& logits, const Tensor& targets, int64_t ignore_index = -100, int64_t k = 1);

}  // namespace t2m::nn
