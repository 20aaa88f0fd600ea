// activation.h — the pointwise nonlinearities a config can name, as an enum plus one apply function.
//
// Activation::identity (x), relu (max(x, 0)), silu (x sigmoid(x)), tanh, gelu_tanh (tanh-approximated GELU).
// apply_activation(a, x) returns x itself for identity (no copy) and the autograd op otherwise (any shape;
// float32/float64). activation_from_name parses "identity", "relu", "silu", "tanh", "gelu_tanh" (also "gelu");
// an unknown name throws t2m::Error listing the valid ones. activation_name is the inverse (canonical names).
#pragma once
#include <cstdint>
#include <string>

#include "autograd/variable.h"

namespace t2m::nn {

enum class Activation : uint8_t { identity, relu, silu, tanh, gelu_tanh };

ag::Variable apply_activation(Activation a, const ag::Variable& x);
Activation activation_from_name(const std::string& name);
const char* activation_name(Activation a);

}  // namespace t2m::nn
