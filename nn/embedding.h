// embedding.h — the Embedding module: a (V, D) table looked up by int64 ids of any shape (ag::embedding).
// Parameter "weight" (V, D) drawn from N(0, 1) (PyTorch's default) with the given Generator.
// forward(ids) -> (ids.shape..., D). Errors: V < 1 or D < 1 at construction; bad ids from ag::embedding (the
// message names the id and V).
#pragma once
#include <cstdint>

#include "autograd/variable.h"
#include "nn/module.h"
#include "tensor/rng.h"

namespace t2m::nn {

class Embedding : public Module {
 public:
  Embedding(int64_t num_embeddings, int64_t dim, Generator& gen);
  ag::Variable forward(const Tensor& ids) const;
  ag::Variable operator()(const Tensor& ids) const { return forward(ids); }
  const ag::Variable& weight() const { return weight_; }
  int64_t num_embeddings() const { return V_; }
  int64_t dim() const { return D_; }

 private:
  int64_t V_, D_;
  ag::Variable weight_;
};

}  // namespace t2m::nn
