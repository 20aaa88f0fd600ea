// module.h — the base of every network: named parameters, child modules, train/eval mode, state save/load.
//
// A module registers its parameters (trainable leaves) and children in its constructor; names compose with dots
// in registration order ("blocks.0.attn.qkv.weight"), which is also the order parameters() returns and the
// optimizer walks. Variables are handles: a module member holding the Variable returned by register_parameter()
// sees optimizer updates. Initialisation takes a t2m::Generator so a seed fixes every weight.
// Errors (t2m::Error): duplicate or empty names; load_from with a missing name, an unexpected extra name under the
// prefix, or a shape/dtype mismatch (the message names the parameter and both shapes).
#pragma once
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "autograd/variable.h"
#include "nn/checkpoint.h"

namespace t2m::nn {

class Module {
 public:
  virtual ~Module() = default;
  Module() = default;
  Module(const Module&) = delete;
  Module& operator=(const Module&) = delete;

  std::vector<std::pair<std::string, ag::Variable>> named_parameters() const;
  std::vector<ag::Variable> parameters() const;
  int64_t num_parameters() const;  // total elements

  void train(bool on = true);      // recursive
  void eval() { train(false); }
  bool is_training() const { return training_; }
  void zero_grad();                // every parameter's grad to zero (kept allocated)

  // Parameters into / out of a checkpoint under "prefix" + name.
  void save_to(Checkpoint& ck, const std::string& prefix = "") const;
  void load_from(const Checkpoint& ck, const std::string& prefix = "");
  // Converts every parameter to dtype (float64 for gradchecks of whole modules).
  void to(DType dtype);

 protected:
  ag::Variable register_parameter(const std::string& name, Tensor init);
  template <typename M>
  std::shared_ptr<M> register_module(const std::string& name, std::shared_ptr<M> m) {
    add_child(name, m);
    return m;
  }

 private:
  void add_child(const std::string& name, std::shared_ptr<Module> m);
  void check_name(const std::string& name) const;
  std::vector<std::pair<std::string, ag::Variable>> params_;
  std::vector<std::pair<std::string, std::shared_ptr<Module>>> children_;
  bool training_ = true;
};

}  // namespace t2m::nn
