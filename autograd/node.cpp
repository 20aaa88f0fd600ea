// node.cpp — recording nodes and freeing graphs without recursion.
#include "autograd/node.h"

#include "autograd/no_grad.h"
#include "autograd/variable.h"

namespace t2m::ag {

void Node::release() {
  backward = nullptr;
  released = true;
}

// The default destructor would recurse Node -> VariableImpl -> Node ... once per op of a chain and overflow the
// stack on deep graphs. Instead, inputs whose last owner is this node hand their grad_fn to an explicit stack.
Node::~Node() {
  std::vector<std::shared_ptr<Node>> pending;
  auto detach_inputs = [&pending](Node& n) {
    for (auto& in : n.inputs) {
      if (in && in.use_count() == 1 && in->grad_fn && in->grad_fn.use_count() == 1) {
        pending.push_back(std::move(in->grad_fn));
      }
    }
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
  if (!any_requires_grad(inputs)) return Variable(std::move(out));
  auto node = std::make_shared<Node>();
  node->op = op;
  node->inputs.reserve(inputs.size());
  node->input_shapes.reserve(inputs.size());
  for (const auto& v : inputs) {
    node->inputs.push_back(v.requires_grad() ? v.impl() : nullptr);
    node->input_shapes.push_back(v.shape());
  }
  node->backward = std::move(backward);
  return Variable::from_node(std::move(out), std::move(node));
}

}  // namespace t2m::ag
