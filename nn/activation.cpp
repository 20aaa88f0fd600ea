// activation.cpp — dispatch from the Activation enum to the autograd ops.
#include "nn/activation.h"

#include "autograd/ops_activation.h"
#include "autograd/ops_unary.h"

namespace t2m::nn {

ag::Variable apply_activation(Activation a, const ag::Variable& x) {
  switch (a) {
    case Activation::identity: return x;
    case Activation::relu: return ag::relu(x);
    case Activation::silu: return ag::silu(x);
    case Activation::tanh: return ag::tanh(x);
    case Activation::gelu_tanh: return ag::gelu_tanh(x);
  }
  throw Error("apply_activation: invalid activation value " + std::to_string((int)a));
}

Activation activation_from_name(const std::string& name) {
  if (name == "identity") return Activation::identity;
  if (name == "relu") return Activation::relu;
  if (name == "silu") return Activation::silu;
  if (name == "tanh") return Activation::tanh;
  if (name == "gelu_tanh" || name == "gelu") return Activation::gelu_tanh;
  throw Error("activation: unknown name '" + name + "' (identity, relu, silu, tanh, gelu_tanh)");
}

const char* activation_name(Activation a) {
  switch (a) {
    case Activation::identity: return "identity";
    case Activation::relu: return "relu";
    case Activation::silu: return "silu";
    case Activation::tanh: return "tanh";
    case Activation::gelu_tanh: return "gelu_tanh";
  }
  return "invalid";
}

}  // namespace t2m::nn
