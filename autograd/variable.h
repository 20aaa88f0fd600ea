// variable.h — the autograd handle: a Tensor plus its gradient and the op that produced it (define-by-run tape).
//
// A Variable is a cheap shared handle (copies refer to the same state). Leaves are created by the user (model
// parameters: requires_grad = true; inputs: false); every ag:: op on Variables returns a non-leaf whose grad_fn
// records how to propagate gradients back (autograd/node.h), unless grad mode is off (autograd/no_grad.h).
//
// backward(): reverse-topological walk of the graph (iterative: any depth), gradients of a variable used several
// times are summed, leaf .grad() accumulates across backward calls until zero_grad(). Non-leaf gradients are not
// kept unless retain_grad() was called. Without retain_graph the graph's saved tensors are freed afterwards.
// Errors (t2m::Error): backward on a variable that does not require grad; on a non-scalar without a seed (message
// names the shape); seed shape/dtype mismatch; a second backward through a freed graph; undefined Variable use;
// an op's backward returning the wrong number, shape or dtype of gradients (names the op); an Error thrown inside
// an op's backward is re-thrown prefixed with "backward of op 'NAME': "; non-finite gradients under AnomalyMode.
// Not thread-safe for one graph or shared leaves: run concurrent backward passes on disjoint graphs only.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "autograd/node.h"
#include "tensor/tensor.h"

namespace t2m::ag {

struct VariableImpl {
  Tensor data;
  Tensor grad;                     // undefined until a gradient arrives
  bool grad_stale = false;         // zero_grad() ran: grad's storage is logically zero (not yet written), so
                                   // the next gradient is copied in instead of added (saves a pass over memory)
  // The gradient with stale storage zeroed first (what every reader must use).
  Tensor& current_grad() {
    if (grad_stale) {
      grad.zero_();
      grad_stale = false;
    }
    return grad;
  }
  bool requires_grad = false;
  bool retains_grad = false;       // non-leaf keeps its grad (retain_grad())
  std::string name;
  std::shared_ptr<Node> grad_fn;   // null for leaves
};

class Variable {
 public:
  Variable() = default;  // undefined
  explicit Variable(Tensor data, bool requires_grad = false, std::string name = {});
  // A trainable leaf: requires_grad = true.
  static Variable parameter(Tensor data, std::string name = {});
  // Internal (used by record()): a non-leaf produced by `node`.
  static Variable from_node(Tensor data, std::shared_ptr<Node> node);

  bool defined() const { return impl_ != nullptr; }
  const std::shared_ptr<VariableImpl>& impl() const { return impl_; }

  // The value. The returned handle may be modified in place (optimizer steps) when no graph needs the old value.
  Tensor& data() const;
  void set_data(Tensor data) const;  // replaces the value (same shape not required; leaves only)
  // The accumulated gradient (undefined before the first backward reaches this variable).
  Tensor& grad() const;
  void zero_grad() const;            // fills an existing grad with zeros (keeps its memory)
  void clear_grad() const;           // drops the grad (undefined again)

  bool requires_grad() const;
  void set_requires_grad(bool r) const;  // leaves only; Error on a non-leaf
  bool is_leaf() const;
  void retain_grad() const;          // keep .grad() of a non-leaf after backward
  const std::string& name() const;
  void set_name(std::string name) const;
  const std::shared_ptr<Node>& grad_fn() const;
  // A new leaf sharing the data, cut from the graph (requires_grad = false).
  Variable detach() const;

  // Shape helpers (forward to data()).
  const Shape& shape() const;
  int64_t dim() const;
  int64_t size(int64_t d) const;
  int64_t numel() const;
  DType dtype() const;
  double item() const;

  // Reverse-mode differentiation from this variable. seed: dL/d(this), same shape and dtype; may be omitted only
  // when numel() == 1 (seed 1). retain_graph keeps the saved tensors so backward can run through it again.
  void backward(const Tensor& seed = Tensor(), bool retain_graph = false) const;

  // Differentiable views (see autograd/ops_shape.h).
  Variable view(const Shape& shape) const;
  Variable reshape(const Shape& shape) const;
  Variable transpose(int64_t d0, int64_t d1) const;
  Variable permute(const std::vector<int64_t>& dims) const;
  Variable slice(int64_t dim, int64_t start, int64_t end, int64_t step = 1) const;
  Variable select(int64_t dim, int64_t index) const;
  Variable narrow(int64_t dim, int64_t start, int64_t length) const;
  Variable expand(const Shape& shape) const;
  Variable squeeze(int64_t dim) const;
  Variable unsqueeze(int64_t dim) const;
  Variable flatten(int64_t start_dim = 0, int64_t end_dim = -1) const;
  Variable contiguous() const;

 private:
  const VariableImpl& checked() const;
  std::shared_ptr<VariableImpl> impl_;
};

}  // namespace t2m::ag
