// ops_index.h — differentiable indexing (index tensors are int64, never differentiated).
//
// index_select(a, dim, index): index 1-D of length L; out = a with dim replaced by L; da = index_add(0, dim, index, g)
// (repeated indices accumulate). gather(a, dim, index): index has a's ndim; out has index's shape
// (torch semantics); da = scatter_add(0, dim, index, g). Errors: out-of-range indices, wrong index dtype/rank
// (from the tensor ops, naming op, index and size).
// scatter_add(a, dim, index, src): out = a with src added at index along dim (a: A, index and src: I);
// da = g, dsrc = gather(g, dim, index). index_add(a, dim, index, src): out = a with src.select(dim, i) added at
// a.select(dim, index[i]); da = g, dsrc = index_select(g, dim, index).
#pragma once
#include "autograd/variable.h"

namespace t2m::ag {

Variable index_select(const Variable& a, int64_t dim, const Tensor& index);
Variable gather(const Variable& a, int64_t dim, const Tensor& index);
Variable scatter_add(const Variable& a, int64_t dim, const Tensor& index, const Variable& src);
Variable index_add(const Variable& a, int64_t dim, const Tensor& index, const Variable& src);

}  // namespace t2m::ag
