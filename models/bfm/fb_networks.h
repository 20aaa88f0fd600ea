// fb_networks.h — the three networks of the FB agent (Meta Motivo's "simple" architecture, the anchor's fb
// classes in ../shared/anchor/torch_ref.py), as nn::Modules built from autograd ops. float32 (float64 via to()).
//
// FbEmbedding(in, h): Linear(in, h) -> LayerNorm(h) -> Tanh -> Linear(h, h/2) -> ReLU.      x [N, in] -> [N, h/2]
//   children "fc1", "ln", "fc2".
// ForwardMap(D, A, d, h): F(s, a, z) = fc2(relu(fc1([embed_z([s, z]), embed_sa([s, a])])))
//   children "embed_z" (D+d -> h/2), "embed_sa" (D+A -> h/2), "fc1" Linear(h, h), "fc2" Linear(h, d).
//   s [N, D], a [N, A], z [N, d] -> [N, d].
// BackwardMap(D, d, h): B(s) = Proj(fc3(relu(fc2(tanh(ln(fc1(s))))))), Proj(u) = sqrt(d) u / max(|u|, 1e-12)
//   (Text2BFM's Proj_z; F.normalize's eps). children "fc1" Linear(D, h), "ln", "fc2" Linear(h, h), "fc3" Linear(h, d).
//   s [N, D] -> [N, d], each row of norm sqrt(d).
// Actor(D, A, d, h): mu(s, z) = tanh(fc2(relu(fc1([embed_z([s, z]), embed_s(s)]))))   (the policy mean; the std
//   is fixed by the agent). children "embed_z" (D+d -> h/2), "embed_s" (D -> h/2), "fc1" Linear(h, h),
//   "fc2" Linear(h, A). s [N, D], z [N, d] -> [N, A] in (-1, 1).
// forward_joined: the same networks from inputs already joined ([s, z] [N, D+d], [s, a] [N, D+A]): a caller that
//   evaluates several members (or the actor and F) on one batch joins each input pair once (the same bits).
// LayerNorm -> Tanh runs as one fused op (layer_norm_tanh.h); the "ln" child holds its weight and bias.
// Initialisation: PyTorch's default Linear init from the Generator, in registration order; LayerNorm 1/0.
// Errors (t2m::Error naming the network): dims < 1, h odd or < 2; forward inputs whose last dims do not match.
#pragma once
#include <cstdint>
#include <memory>

#include "autograd/variable.h"
#include "nn/linear.h"
#include "nn/module.h"
#include "nn/norm.h"
#include "tensor/rng.h"

namespace t2m::bfm {

class FbEmbedding : public nn::Module {
 public:
  FbEmbedding(int64_t in, int64_t h, Generator& gen);
  ag::Variable forward(const ag::Variable& x) const;  // [N, in] -> [N, h/2]

 private:
  std::shared_ptr<nn::Linear> fc1_, fc2_;
  std::shared_ptr<nn::LayerNorm> ln_;
};

class ForwardMap : public nn::Module {
 public:
  ForwardMap(int64_t obs_dim, int64_t action_dim, int64_t z_dim, int64_t h, Generator& gen);
  ag::Variable forward(const ag::Variable& s, const ag::Variable& a, const ag::Variable& z) const;
  ag::Variable forward_joined(const ag::Variable& sz, const ag::Variable& sa) const;  // [s, z], [s, a]

 private:
  int64_t D_, A_, d_;
  std::shared_ptr<FbEmbedding> embed_z_, embed_sa_;
  std::shared_ptr<nn::Linear> fc1_, fc2_;
};

class BackwardMap : public nn::Module {
 public:
  BackwardMap(int64_t obs_dim, int64_t z_dim, int64_t h, Generator& gen);
  ag::Variable forward(const ag::Variable& s) const;
  int64_t z_dim() const { return d_; }

 private:
  int64_t D_, d_;
  std::shared_ptr<nn::Linear> fc1_, fc2_, fc3_;
  std::shared_ptr<nn::LayerNorm> ln_;
};

class Actor : public nn::Module {
 public:
  Actor(int64_t obs_dim, int64_t action_dim, int64_t z_dim, int64_t h, Generator& gen);
  ag::Variable forward(const ag::Variable& s, const ag::Variable& z) const;  // the mean mu(s, z)
  ag::Variable forward_joined(const ag::Variable& sz, const ag::Variable& s) const;  // [s, z], s

 private:
  int64_t D_, A_, d_;
  std::shared_ptr<FbEmbedding> embed_z_, embed_s_;
  std::shared_ptr<nn::Linear> fc1_, fc2_;
};

}  // namespace t2m::bfm
