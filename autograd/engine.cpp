// engine.cpp — Variable::backward: reverse-topological walk of the tape with gradient accumulation.
//
// 1. Iterative depth-first search from the root's node collects every Node reachable through input edges in
//    post-order (producers before consumers); reversing it gives a topological order.
// 2. Walking that order, each node's output gradient has been fully summed before the node runs. Gradients for
//    leaf inputs go straight into the leaf's .grad; non-leaves keep theirs only if they retain_grad().
// 3. Without retain_graph each node releases its saved tensors right after running.
#include <cmath>
#include <unordered_map>
#include <unordered_set>

#include "autograd/anomaly.h"
#include "autograd/profiler.h"
#include "autograd/variable.h"
#include "tensor/ops.h"

namespace t2m::ag {

namespace {

std::string label(const VariableImpl& v) { return v.name.empty() ? std::string() : " '" + v.name + "'"; }

// True when g is the only handle on a contiguous storage of exactly its size: the engine may keep it as a .grad
// without copying (nothing else can see or change it).
bool sole_owner(const Tensor& g) {
  const auto& st = g.storage();
  return st && st.use_count() == 1 && g.offset() == 0 && g.is_contiguous() &&
         st->nbytes == (size_t)g.numel() * dtype_size(g.dtype());
}

// v.grad (may be undefined) += g; .grad never aliases another tensor: the first gradient (no grad yet, or one
// marked stale by zero_grad(), or of another shape/dtype after set_data) is adopted when the engine holds the only
// handle on it, else copied (into the stale buffer when it fits). The same values as zeroing and adding, without
// the zeroing pass and, usually, without the copy.
void accumulate_into(VariableImpl& v, Tensor g) {
  Tensor& grad = v.grad;
  const bool fits = grad.defined() && grad.shape() == g.shape() && grad.dtype() == g.dtype();
  if (fits && !v.grad_stale) {
    add_(grad, g);
  } else if (sole_owner(g)) {
    grad = std::move(g);
  } else if (fits) {
    grad.copy_(g);
  } else {
    grad = g.clone();
  }
  v.grad_stale = false;
}

// True when every element is finite: sum(g * 0) is 0 unless some element is NaN or infinite.
bool all_finite(const Tensor& g) {
  if (g.numel() == 0) return true;
  return std::isfinite(t2m::sum(t2m::mul(g, 0.0)).item());
}

std::vector<Node*> post_order(Node* root) {
  std::vector<Node*> order;
  std::unordered_set<Node*> seen{root};
  std::vector<std::pair<Node*, size_t>> stack{{root, 0}};
  while (!stack.empty()) {
    Node* n = stack.back().first;
    size_t i = stack.back().second;
    if (i < n->inputs.size()) {
      stack.back().second = i + 1;
      Node* in = n->inputs[i].fn.get();
      if (in && seen.insert(in).second) stack.push_back({in, 0});
    } else {
      order.push_back(n);
      stack.pop_back();
    }
  }
  return order;
}

}  // namespace

void Variable::backward(const Tensor& seed, bool retain_graph) const {
  VariableImpl* root = impl_.get();
  if (!root) throw Error("backward: called on an undefined Variable");
  if (!root->requires_grad)
    throw Error("backward: variable" + label(*root) + " of shape " + shape_str(root->data.shape()) +
                " does not require grad and has no grad_fn");
  Tensor g0;
  if (!seed.defined()) {
    if (root->data.numel() != 1)
      throw Error("backward: output" + label(*root) + " of shape " + shape_str(root->data.shape()) +
                  " is not a scalar; pass a seed gradient of that shape");
    g0 = Tensor::ones(root->data.shape(), root->data.dtype());
  } else {
    if (seed.shape() != root->data.shape() || seed.dtype() != root->data.dtype())
      throw Error("backward: seed of shape " + shape_str(seed.shape()) + " (" + dtype_name(seed.dtype()) +
                  ") does not match output shape " + shape_str(root->data.shape()) + " (" +
                  dtype_name(root->data.dtype()) + ")");
    g0 = seed;
  }

  if (!root->grad_fn) {  // a leaf: its gradient is the seed
    accumulate_into(*root, std::move(g0));
    return;
  }
  Profiler* const prof = Profiler::active();
  if (prof) prof->on_engine("(untracked)");
  std::vector<Node*> order = post_order(root->grad_fn.get());
  std::unordered_map<Node*, Tensor> grads;  // gradient of each node's output, summed over its consumers
  grads[root->grad_fn.get()] = g0;
  for (auto it = order.rbegin(); it != order.rend(); ++it) {
    Node* n = *it;
    Tensor g;
    if (auto gi = grads.find(n); gi != grads.end()) {
      g = std::move(gi->second);
      grads.erase(gi);
    }
    if (!g.defined()) {
      if (!retain_graph) n->release();
      continue;
    }
    if (n->released || !n->backward)
      throw Error("backward: graph already freed at op '" + n->op +
                  "'; pass retain_graph=true to the first backward() to run backward through it again");
    if (auto out = n->output.lock(); out && out->retains_grad) accumulate_into(*out, g);
    std::vector<bool> need(n->inputs.size());
    for (size_t i = 0; i < need.size(); ++i) need[i] = n->inputs[i].defined();
    std::vector<Tensor> gin;
    if (prof) prof->on_engine("(engine)");
    try {
      gin = n->backward(g, need);
    } catch (const Error& e) {
      throw Error("backward of op '" + n->op + "': " + e.what());
    }
    if (prof) prof->on_backward(n->op, n->input_shapes);
    if (!retain_graph) n->release();
    if (gin.size() != n->inputs.size())
      throw Error("backward: op '" + n->op + "' returned " + std::to_string(gin.size()) + " gradients for " +
                  std::to_string(n->inputs.size()) + " inputs");
    for (size_t i = 0; i < gin.size(); ++i) {
      const Edge& e = n->inputs[i];
      if (!e.defined() || !gin[i].defined()) continue;
      if (gin[i].shape() != n->input_shapes[i])
        throw Error("backward: op '" + n->op + "' gave a gradient of shape " + shape_str(gin[i].shape()) +
                    " for input " + std::to_string(i) + " of shape " + shape_str(n->input_shapes[i]));
      if (gin[i].dtype() != n->input_dtypes[i])
        throw Error("backward: op '" + n->op + "' gave a " + dtype_name(gin[i].dtype()) + " gradient for " +
                    dtype_name(n->input_dtypes[i]) + " input " + std::to_string(i));
      if (AnomalyMode::is_enabled() && !all_finite(gin[i]))
        throw Error("backward: op '" + n->op + "' produced a non-finite gradient for input " + std::to_string(i) +
                    " of shape " + shape_str(n->input_shapes[i]));
      if (e.leaf) {
        accumulate_into(*e.leaf, std::move(gin[i]));
      } else {
        Tensor& slot = grads[e.fn.get()];
        if (!slot.defined())
          slot = std::move(gin[i]);
        else if (sole_owner(slot) && slot.shape() == gin[i].shape() && slot.dtype() == gin[i].dtype())
          add_(slot, gin[i]);  // the engine holds the only handle: sum in place (same values as add)
        else
          slot = add(slot, gin[i]);
      }
    }
    if (prof) prof->on_engine("(grad accumulate)");
  }
  if (prof) prof->on_engine("(engine)");
}

}  // namespace t2m::ag
