// node.cpp — recording nodes and freeing graphs without recursion.
#include "autograd/node.h"

#include "autograd/no_grad.h"
#include "autograd/profiler.h"
#include "autograd/variable.h"
#include "tensor/ops.h"

namespace t2m::ag {

void Node::release() {
  backward = nullptr;
  released = true;
}

// The default destructor would recurse Node -> Node -> ... once per op of a chain and overflow the stack on deep
// graphs. Instead, input nodes whose last owner is this node are moved to an explicit stack and freed one by one.
Node::~Node() {
  std::vector<std::shared_ptr<Node>> pending;
  auto detach_inputs = [&pending](Node& n) {
    for (auto& e : n.inputs)
      if (e.fn && e.fn.use_count() == 1) pending.push_back(std::move(e.fn));
    n.inputs.clear();
  };
  detach_inputs(*this);
  while (!pending.empty()) {
    std::shared_ptr<Node> n = std::move(pending.back());
    pending.pop_back();
    detach_inputs(*n);
    // n is destroyed here with no inputs left, so its destructor does not recurse.
  }
}

bool any_requires_grad(const std::vector<Variable>& inputs) {
  if (!GradMode::is_enabled()) return false;
  for (const auto& v : inputs)
    if (v.defined() && v.requires_grad()) return true;
  return false;
}

Variable record(const char* op, Tensor out, const std::vector<Variable>& inputs, BackwardFn backward) {
  if (Profiler* p = Profiler::active()) {
    std::vector<Shape> shapes;
    if (p->by_shape())
      for (const auto& v : inputs) shapes.push_back(v.defined() ? v.shape() : Shape{});
    p->on_forward(op, shapes);
  }
  if (!any_requires_grad(inputs)) return Variable(std::move(out));
  auto node = std::make_shared<Node>();
  node->op = op;
  node->inputs.reserve(inputs.size());
  node->input_shapes.reserve(inputs.size());
  node->input_dtypes.reserve(inputs.size());
  for (const auto& v : inputs) {
    Edge e;
    if (v.requires_grad()) {
      if (v.grad_fn()) e.fn = v.grad_fn();
      else e.leaf = v.impl();
    }
    node->inputs.push_back(std::move(e));
    node->input_shapes.push_back(v.shape());
    node->input_dtypes.push_back(v.dtype());
  }
  node->backward = std::move(backward);
  return Variable::from_node(std::move(out), std::move(node));
}

Tensor reduce_grad_to(const Tensor& g, const Shape& shape) {
  return g.shape() == shape && g.is_contiguous() ? g : sum_to(g, shape);
}

}  // namespace t2m::ag
