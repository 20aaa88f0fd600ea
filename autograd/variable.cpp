// variable.cpp — Variable state accessors (backward lives in engine.cpp, views in ops_shape.cpp).
#include "autograd/variable.h"

namespace t2m::ag {

Variable::Variable(Tensor data, bool requires_grad, std::string name) : impl_(std::make_shared<VariableImpl>()) {
  if (!data.defined()) throw Error("Variable: cannot wrap an undefined tensor (name '" + name + "')");
  if (requires_grad && data.dtype() == DType::i64)
    throw Error("Variable: an int64 tensor cannot require grad (name '" + name + "')");
  impl_->data = std::move(data);
  impl_->requires_grad = requires_grad;
  impl_->name = std::move(name);
}

Variable Variable::parameter(Tensor data, std::string name) { return Variable(std::move(data), true, std::move(name)); }

Variable Variable::from_node(Tensor data, std::shared_ptr<Node> node) {
  Variable v(std::move(data));
  v.impl_->requires_grad = true;
  node->output = v.impl_;
  v.impl_->grad_fn = std::move(node);
  return v;
}

const VariableImpl& Variable::checked() const {
  if (!impl_) throw Error("Variable: use of an undefined Variable");
  return *impl_;
}

Tensor& Variable::data() const {
  checked();
  return impl_->data;
}

void Variable::set_data(Tensor data) const {
  checked();
  if (impl_->grad_fn) throw Error("Variable::set_data: '" + impl_->name + "' is not a leaf");
  if (!data.defined()) throw Error("Variable::set_data: undefined tensor for '" + impl_->name + "'");
  impl_->data = std::move(data);
}

Tensor& Variable::grad() const {
  checked();
  return impl_->current_grad();
}

void Variable::zero_grad() const {
  checked();
  if (impl_->grad.defined()) impl_->grad_stale = true;  // zeroed lazily: overwritten by the next gradient
}

void Variable::clear_grad() const {
  checked();
  impl_->grad = Tensor();
  impl_->grad_stale = false;
}

bool Variable::requires_grad() const { return checked().requires_grad; }

void Variable::set_requires_grad(bool r) const {
  checked();
  if (impl_->grad_fn)
    throw Error("Variable::set_requires_grad: '" + impl_->name + "' is not a leaf (produced by op '" +
                impl_->grad_fn->op + "'); use detach()");
  if (r && impl_->data.dtype() == DType::i64)
    throw Error("Variable::set_requires_grad: int64 tensor '" + impl_->name + "' cannot require grad");
  impl_->requires_grad = r;
}

bool Variable::is_leaf() const { return checked().grad_fn == nullptr; }

void Variable::retain_grad() const {
  checked();
  impl_->retains_grad = true;
}

const std::string& Variable::name() const { return checked().name; }
void Variable::set_name(std::string name) const {
  checked();
  impl_->name = std::move(name);
}
const std::shared_ptr<Node>& Variable::grad_fn() const { return checked().grad_fn; }

Variable Variable::detach() const { return Variable(checked().data, false, impl_->name); }

const Shape& Variable::shape() const { return checked().data.shape(); }
int64_t Variable::dim() const { return checked().data.dim(); }
int64_t Variable::size(int64_t d) const { return checked().data.size(d); }
int64_t Variable::numel() const { return checked().data.numel(); }
DType Variable::dtype() const { return checked().data.dtype(); }
double Variable::item() const { return checked().data.item(); }

}  // namespace t2m::ag
