// ops.h — tensor math without autograd: elementwise (broadcasting), reductions, matmul, joins, indexing.
//
// Every op accepts any strides (non-contiguous views, stride-0 expands) and returns a fresh contiguous tensor
// unless it says "in place". float32 and float64 are supported everywhere (both inputs must share the dtype,
// else Error); index tensors are int64. Size-0 dimensions are allowed and give empty results (sum of an empty
// axis is 0, max of an empty axis throws). Large ops run across OpenMP threads; results do not depend on the
// thread count except for the summation order of reductions, which is fixed for a given thread count.
// (As implemented: sums/means accumulate in double over fixed-size blocks combined in order, so reductions are
// independent of the thread count as well; see tensor/reduce_iter.h.)
// Shape errors throw t2m::Error naming the op and the shapes, e.g. "add: cannot broadcast [2, 3] with [4]".
#pragma once
#include <vector>

#include "tensor/tensor.h"

namespace t2m {

// ---- elementwise binary, numpy broadcasting --------------------------------------------------------------
Tensor add(const Tensor& a, const Tensor& b);
Tensor sub(const Tensor& a, const Tensor& b);
Tensor mul(const Tensor& a, const Tensor& b);
Tensor div(const Tensor& a, const Tensor& b);
Tensor pow(const Tensor& a, const Tensor& b);
Tensor maximum(const Tensor& a, const Tensor& b);
Tensor minimum(const Tensor& a, const Tensor& b);
// with a scalar
Tensor add(const Tensor& a, double s);
Tensor mul(const Tensor& a, double s);
Tensor pow(const Tensor& a, double exponent);
// comparisons: result has a's dtype with values 0 or 1 (a mask)
Tensor gt(const Tensor& a, const Tensor& b);
Tensor lt(const Tensor& a, const Tensor& b);
Tensor ge(const Tensor& a, const Tensor& b);
Tensor le(const Tensor& a, const Tensor& b);
Tensor eq(const Tensor& a, const Tensor& b);
Tensor gt(const Tensor& a, double s);
Tensor lt(const Tensor& a, double s);
// where(cond, a, b): cond != 0 picks a, else b; all three broadcast together.
Tensor where(const Tensor& cond, const Tensor& a, const Tensor& b);

// ---- elementwise unary ------------------------------------------------------------------------------------
Tensor neg(const Tensor& a);
Tensor exp(const Tensor& a);
Tensor log(const Tensor& a);
Tensor sqrt(const Tensor& a);
Tensor rsqrt(const Tensor& a);
Tensor tanh(const Tensor& a);
Tensor sigmoid(const Tensor& a);
Tensor relu(const Tensor& a);
Tensor abs(const Tensor& a);
Tensor sign(const Tensor& a);
Tensor sin(const Tensor& a);
Tensor cos(const Tensor& a);
Tensor square(const Tensor& a);
Tensor reciprocal(const Tensor& a);
Tensor clamp(const Tensor& a, double lo, double hi);

// ---- in place (used by optimizers and gradient accumulation) -----------------------------------------------
void add_(Tensor& dst, const Tensor& src, double alpha = 1.0);  // dst += alpha * src (src broadcast to dst)
void mul_(Tensor& dst, double s);

// ---- reductions ---------------------------------------------------------------------------------------------
// dims may be negative; an empty dims list reduces over every dim. keepdim keeps reduced dims as size 1.
Tensor sum(const Tensor& a, const std::vector<int64_t>& dims = {}, bool keepdim = false);
Tensor mean(const Tensor& a, const std::vector<int64_t>& dims = {}, bool keepdim = false);
Tensor amax(const Tensor& a, const std::vector<int64_t>& dims = {}, bool keepdim = false);
Tensor amin(const Tensor& a, const std::vector<int64_t>& dims = {}, bool keepdim = false);
Tensor logsumexp(const Tensor& a, int64_t dim, bool keepdim = false);  // numerically stable
// max along one dim: values and int64 argmax indices (first maximum wins)
struct MaxResult { Tensor values, indices; };
MaxResult max(const Tensor& a, int64_t dim, bool keepdim = false);
Tensor argmax(const Tensor& a, int64_t dim, bool keepdim = false);
// Sums a broadcast result back to `shape` (the reverse of broadcasting; what autograd needs).
Tensor sum_to(const Tensor& a, const Shape& shape);

// ---- linear algebra (tensor/gemm.h underneath) --------------------------------------------------------------
// matmul: 1-D·1-D dot, 2-D·2-D, and batched with broadcasting of the leading dims (numpy matmul rules).
Tensor matmul(const Tensor& a, const Tensor& b);
// matmul with optional transposes of the last two dims of a and b, without materialising the transpose.
Tensor matmul_t(const Tensor& a, bool trans_a, const Tensor& b, bool trans_b);

// ---- joins and splits ---------------------------------------------------------------------------------------
Tensor concat(const std::vector<Tensor>& ts, int64_t dim);
Tensor stack(const std::vector<Tensor>& ts, int64_t dim);
std::vector<Tensor> split(const Tensor& a, const std::vector<int64_t>& sizes, int64_t dim);  // views
std::vector<Tensor> chunk(const Tensor& a, int64_t chunks, int64_t dim);                    // views

// ---- indexing (index tensors are int64; out-of-range indices throw, naming op, index and size) --------------
Tensor index_select(const Tensor& a, int64_t dim, const Tensor& index);  // index is 1-D
// gather: out[i][j][k] = a[i][index[i][j][k]][k] for dim = 1 (torch semantics; index has a's ndim)
Tensor gather(const Tensor& a, int64_t dim, const Tensor& index);
// scatter_add: returns a copy of `a` with out[i][index[i][j][k]][k] += src[i][j][k] (dim = 1)
Tensor scatter_add(const Tensor& a, int64_t dim, const Tensor& index, const Tensor& src);
// index_add: out = copy of a; out.select(dim, index[i]) += src.select(dim, i)  (backward of index_select)
Tensor index_add(const Tensor& a, int64_t dim, const Tensor& index, const Tensor& src);
// masked_fill: where mask != 0 (broadcast to a), value; else a.
Tensor masked_fill(const Tensor& a, const Tensor& mask, double value);

// ---- comparison helpers for tests ---------------------------------------------------------------------------
bool allclose(const Tensor& a, const Tensor& b, double rtol = 1e-5, double atol = 1e-8);
double max_abs_diff(const Tensor& a, const Tensor& b);

}  // namespace t2m
