// fb_networks.cpp — FbEmbedding, ForwardMap, BackwardMap, Actor: registration order and forward composition.
#include "models/bfm/fb_networks.h"

#include <cmath>
#include <string>

#include "autograd/ops_join.h"
#include "autograd/ops_unary.h"
#include "models/bfm/layer_norm_tanh.h"
#include "models/bfm/sphere_projection.h"

namespace t2m::bfm {

namespace {

void check_dims(const char* net, std::initializer_list<int64_t> dims, int64_t h) {
  for (int64_t v : dims)
    if (v < 1) throw Error(std::string(net) + ": dimensions must be >= 1, got " + std::to_string(v));
  if (h < 2 || h % 2 != 0) throw Error(std::string(net) + ": hidden width must be even and >= 2, got " + std::to_string(h));
}

void check_last(const char* net, const char* arg, const ag::Variable& x, int64_t want) {
  if (!x.defined() || x.dim() != 2 || x.size(1) != want)
    throw Error(std::string(net) + ": " + arg + " must be [N, " + std::to_string(want) + "], got " +
                (x.defined() ? shape_str(x.shape()) : std::string("undefined")));
}

void check_rows(const char* net, const ag::Variable& a, const ag::Variable& b) {
  if (a.size(0) != b.size(0))
    throw Error(std::string(net) + ": inputs have different row counts " + shape_str(a.shape()) + " vs " +
                shape_str(b.shape()));
}

}  // namespace

FbEmbedding::FbEmbedding(int64_t in, int64_t h, Generator& gen) {
  check_dims("FbEmbedding", {in}, h);
  fc1_ = register_module("fc1", std::make_shared<nn::Linear>(in, h, true, gen));
  ln_ = register_module("ln", std::make_shared<nn::LayerNorm>(h));
  fc2_ = register_module("fc2", std::make_shared<nn::Linear>(h, h / 2, true, gen));
}

// x [N, in] -> relu(fc2(tanh(ln(fc1(x))))) [N, h/2]
ag::Variable FbEmbedding::forward(const ag::Variable& x) const {
  return fc2_->forward_relu(layer_norm_tanh(fc1_->forward(x), ln_->weight(), ln_->bias()));
}

ForwardMap::ForwardMap(int64_t D, int64_t A, int64_t d, int64_t h, Generator& gen) : D_(D), A_(A), d_(d) {
  check_dims("ForwardMap", {D, A, d}, h);
  embed_z_ = register_module("embed_z", std::make_shared<FbEmbedding>(D + d, h, gen));
  embed_sa_ = register_module("embed_sa", std::make_shared<FbEmbedding>(D + A, h, gen));
  fc1_ = register_module("fc1", std::make_shared<nn::Linear>(h, h, true, gen));
  fc2_ = register_module("fc2", std::make_shared<nn::Linear>(h, d, true, gen));
}

// s [N, D], a [N, A], z [N, d] -> F(s, a, z) [N, d]
ag::Variable ForwardMap::forward(const ag::Variable& s, const ag::Variable& a, const ag::Variable& z) const {
  check_last("ForwardMap", "s", s, D_);
  check_last("ForwardMap", "a", a, A_);
  check_last("ForwardMap", "z", z, d_);
  check_rows("ForwardMap", s, a);
  check_rows("ForwardMap", s, z);
  return forward_joined(ag::concat({s, z}, 1), ag::concat({s, a}, 1));
}

ag::Variable ForwardMap::forward_joined(const ag::Variable& sz, const ag::Variable& sa) const {
  check_last("ForwardMap", "[s, z]", sz, D_ + d_);
  check_last("ForwardMap", "[s, a]", sa, D_ + A_);
  check_rows("ForwardMap", sz, sa);
  const ag::Variable hz = embed_z_->forward(sz);
  const ag::Variable hsa = embed_sa_->forward(sa);
  return fc2_->forward(fc1_->forward_relu(ag::concat({hz, hsa}, 1)));
}

BackwardMap::BackwardMap(int64_t D, int64_t d, int64_t h, Generator& gen) : D_(D), d_(d) {
  check_dims("BackwardMap", {D, d}, h);
  fc1_ = register_module("fc1", std::make_shared<nn::Linear>(D, h, true, gen));
  ln_ = register_module("ln", std::make_shared<nn::LayerNorm>(h));
  fc2_ = register_module("fc2", std::make_shared<nn::Linear>(h, h, true, gen));
  fc3_ = register_module("fc3", std::make_shared<nn::Linear>(h, d, true, gen));
}

// s [N, D] -> sqrt(d) * normalize(fc3(relu(fc2(tanh(ln(fc1(s))))))) [N, d]
ag::Variable BackwardMap::forward(const ag::Variable& s) const {
  check_last("BackwardMap", "s", s, D_);
  const ag::Variable u =
      fc3_->forward(fc2_->forward_relu(layer_norm_tanh(fc1_->forward(s), ln_->weight(), ln_->bias())));
  return sphere_project(u, std::sqrt((double)d_));
}

Actor::Actor(int64_t D, int64_t A, int64_t d, int64_t h, Generator& gen) : D_(D), A_(A), d_(d) {
  check_dims("Actor", {D, A, d}, h);
  embed_z_ = register_module("embed_z", std::make_shared<FbEmbedding>(D + d, h, gen));
  embed_s_ = register_module("embed_s", std::make_shared<FbEmbedding>(D, h, gen));
  fc1_ = register_module("fc1", std::make_shared<nn::Linear>(h, h, true, gen));
  fc2_ = register_module("fc2", std::make_shared<nn::Linear>(h, A, true, gen));
}

// s [N, D], z [N, d] -> mu(s, z) = tanh(fc2(relu(fc1([embed_z([s, z]), embed_s(s)])))) [N, A]
ag::Variable Actor::forward(const ag::Variable& s, const ag::Variable& z) const {
  check_last("Actor", "s", s, D_);
  check_last("Actor", "z", z, d_);
  check_rows("Actor", s, z);
  return forward_joined(ag::concat({s, z}, 1), s);
}

ag::Variable Actor::forward_joined(const ag::Variable& sz, const ag::Variable& s) const {
  check_last("Actor", "[s, z]", sz, D_ + d_);
  check_last("Actor", "s", s, D_);
  check_rows("Actor", sz, s);
  const ag::Variable hz = embed_z_->forward(sz);
  const ag::Variable hs = embed_s_->forward(s);
  return ag::tanh(fc2_->forward(fc1_->forward_relu(ag::concat({hz, hs}, 1))));
}

}  // namespace t2m::bfm
