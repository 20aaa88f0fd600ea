// node.h — one recorded operation of the tape: its inputs and the backward function that maps the gradient of
// its output to gradients of its inputs (llm.c-style: the closure holds the tensors the forward saved).
//
// Ownership (as in PyTorch): a Variable produced by an op owns its Node (grad_fn); a Node owns the Nodes that
// produced its inputs and the leaf inputs that require grad, but NOT the values of intermediate inputs, so an
// activation no op saved for backward is freed as soon as the caller drops it. There are no cycles (a node sees
// its own output only through a weak pointer, for retain_grad). Destroying a long chain is iterative (no
// recursion), so graphs of any depth can be freed.
#pragma once
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "tensor/tensor.h"

namespace t2m::ag {

struct VariableImpl;
struct Node;
class Variable;

// grad_out has the output's shape and dtype. Returns one tensor per input: that input's gradient (same shape as
// the input; any strides) or an undefined Tensor when need[i] is false or no gradient flows to input i.
using BackwardFn = std::function<std::vector<Tensor>(const Tensor& grad_out, const std::vector<bool>& need)>;

// Where the gradient of one input goes: the node that produced it (non-leaf), or the leaf itself.
// Both empty for an input that does not require grad.
struct Edge {
  std::shared_ptr<Node> fn;
  std::shared_ptr<VariableImpl> leaf;
  bool defined() const { return fn != nullptr || leaf != nullptr; }
};

struct Node {
  std::string op;                       // op name for error messages ("mul", "matmul", ...)
  std::vector<Edge> inputs;             // one per input of the op
  std::vector<Shape> input_shapes;      // to check what backward returns
  std::vector<DType> input_dtypes;
  std::weak_ptr<VariableImpl> output;   // the Variable this node produced (for retain_grad)
  BackwardFn backward;                  // empty once released
  bool released = false;                // saved tensors freed by a backward without retain_graph

  // Frees the saved tensors (the closure); the graph structure stays so a second backward can say why it fails.
  void release();
  ~Node();
};

// Wraps the forward result `out` of op `op`. When grad mode is on and some input requires grad, the result is a
// non-leaf Variable whose grad_fn records the inputs and `backward`; otherwise a plain constant Variable (the
// closure and its saved tensors are dropped at once).
Variable record(const char* op, Tensor out, const std::vector<Variable>& inputs, BackwardFn backward);

// True when grad mode is on and at least one of the inputs requires grad (ops use it to skip saving tensors).
bool any_requires_grad(const std::vector<Variable>& inputs);

// A gradient g summed down to an input's shape (undoing broadcasting): g itself, no copy, when it already has that
// shape and is contiguous, else sum_to(g, shape). Sharing g is safe: the engine sums the gradients of a node out of
// place and adopts a tensor as a leaf's .grad only when it holds the sole handle on it.
Tensor reduce_grad_to(const Tensor& g, const Shape& shape);

}  // namespace t2m::ag
