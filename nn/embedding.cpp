// embedding.cpp — Embedding module over ag::embedding.
#include "nn/embedding.h"

#include <string>

#include "autograd/ops_embedding.h"

namespace t2m::nn {

Embedding::Embedding(int64_t num_embeddings, int64_t dim, Generator& gen) : V_(num_embeddings), D_(dim) {
  if (V_ < 1 || D_ < 1)
    throw Error("Embedding: num_embeddings and dim must be >= 1, got " + std::to_string(V_) + ", " +
                std::to_string(D_));
  weight_ = register_parameter("weight", rand_normal({V_, D_}, gen));
}

ag::Variable Embedding::forward(const Tensor& ids) const { return ag::embedding(weight_, ids); }

}  // namespace t2m::nn
