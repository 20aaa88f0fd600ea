// tensor.cpp — Tensor: storage, creation, metadata, views, copies; shape helpers.
#include "tensor/tensor.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "tensor/allocator.h"
#include "tensor/kernels.h"

namespace t2m {

// ---- dtype and shape helpers ---------------------------------------------------------------------------------
const char* dtype_name(DType d) {
  switch (d) {
    case DType::f32: return "f32";
    case DType::f64: return "f64";
    case DType::i64: return "i64";
  }
  return "?";
}

size_t dtype_size(DType d) { return d == DType::f32 ? 4 : 8; }

std::string shape_str(const Shape& s) {
  std::string r = "[";
  for (size_t i = 0; i < s.size(); ++i) {
    if (i) r += ", ";
    r += std::to_string(s[i]);
  }
  return r + "]";
}

int64_t shape_numel(const Shape& s) {
  int64_t n = 1;
  for (int64_t v : s) n *= v;
  return n;
}

Shape contiguous_strides(const Shape& shape) {
  Shape st(shape.size());
  int64_t acc = 1;
  for (int64_t d = (int64_t)shape.size() - 1; d >= 0; --d) {
    st[d] = acc;
    acc *= std::max<int64_t>(shape[d], 1);
  }
  return st;
}

int64_t wrap_dim(int64_t dim, int64_t ndim, const char* op) {
  if (dim < -ndim || dim >= ndim)
    throw Error(std::string(op) + ": dim " + std::to_string(dim) + " out of range for a " + std::to_string(ndim) +
                "-d tensor");
  return dim < 0 ? dim + ndim : dim;
}

Shape broadcast_shapes(const Shape& a, const Shape& b, const char* op) {
  const size_t n = std::max(a.size(), b.size());
  Shape r(n);
  for (size_t i = 0; i < n; ++i) {
    const int64_t da = i < n - a.size() ? 1 : a[i - (n - a.size())];
    const int64_t db = i < n - b.size() ? 1 : b[i - (n - b.size())];
    if (da != db && da != 1 && db != 1)
      throw Error(std::string(op) + ": cannot broadcast " + shape_str(a) + " with " + shape_str(b));
    r[i] = da == 1 ? db : da;
  }
  return r;
}

static void check_shape(const Shape& s, const char* op) {
  for (int64_t v : s)
    if (v < 0) throw Error(std::string(op) + ": negative size in shape " + shape_str(s));
}

// ---- storage -------------------------------------------------------------------------------------------------
Storage::Storage(size_t n) : data(cached_alloc(n)), nbytes(n) {}
Storage::~Storage() { cached_free(data, nbytes); }

// ---- creation ------------------------------------------------------------------------------------------------
Tensor::Tensor(std::shared_ptr<Storage> storage, DType dtype, Shape shape, Shape strides, int64_t offset)
    : storage_(std::move(storage)), dtype_(dtype), shape_(std::move(shape)), strides_(std::move(strides)),
      offset_(offset) {
  if (shape_.size() != strides_.size())
    throw Error("Tensor: shape " + shape_str(shape_) + " and strides " + shape_str(strides_) + " differ in rank");
}

Tensor Tensor::empty(const Shape& shape, DType dtype) {
  check_shape(shape, "empty");
  auto st = std::make_shared<Storage>((size_t)shape_numel(shape) * dtype_size(dtype));
  return Tensor(std::move(st), dtype, shape, contiguous_strides(shape), 0);
}

Tensor Tensor::zeros(const Shape& shape, DType dtype) {
  Tensor t = empty(shape, dtype);
  std::memset(t.storage_->data, 0, t.storage_->nbytes);  // all-zero bits are 0 for f32, f64 and i64
  return t;
}

Tensor Tensor::ones(const Shape& shape, DType dtype) { return full(shape, 1.0, dtype); }

Tensor Tensor::full(const Shape& shape, double value, DType dtype) {
  Tensor t = empty(shape, dtype);
  t.fill_(value);
  return t;
}

Tensor Tensor::scalar(double value, DType dtype) { return full({}, value, dtype); }

Tensor Tensor::arange(int64_t n, DType dtype) {
  if (n < 0) throw Error("arange: n must be >= 0, got " + std::to_string(n));
  Tensor t = empty({n}, dtype);
  detail::dispatch_all(dtype, [&](auto z) {
    using T = decltype(z);
    T* p = t.data<T>();
    for (int64_t i = 0; i < n; ++i) p[i] = (T)i;
  });
  return t;
}

template <typename T>
static Tensor from_vec(const std::vector<T>& v, const Shape& shape, DType dt) {
  check_shape(shape, "from_vector");
  if ((int64_t)v.size() != shape_numel(shape))
    throw Error("from_vector: " + std::to_string(v.size()) + " values do not fill shape " + shape_str(shape));
  Tensor t = Tensor::empty(shape, dt);
  if (!v.empty()) std::memcpy(t.data<T>(), v.data(), v.size() * sizeof(T));
  return t;
}
Tensor Tensor::from_vector(const std::vector<float>& v, const Shape& s) { return from_vec(v, s, DType::f32); }
Tensor Tensor::from_vector(const std::vector<double>& v, const Shape& s) { return from_vec(v, s, DType::f64); }
Tensor Tensor::from_vector(const std::vector<int64_t>& v, const Shape& s) { return from_vec(v, s, DType::i64); }

// ---- metadata and raw access -----------------------------------------------------------------------------------
int64_t Tensor::size(int64_t d) const { return shape_[wrap_dim(d, dim(), "size")]; }
int64_t Tensor::numel() const { return shape_numel(shape_); }

bool Tensor::is_contiguous() const {
  int64_t expected = 1;
  for (int64_t d = dim() - 1; d >= 0; --d) {
    if (shape_[d] == 0) return true;
    if (shape_[d] == 1) continue;
    if (strides_[d] != expected) return false;
    expected *= shape_[d];
  }
  return true;
}

template <typename T> static constexpr DType dtype_of();
template <> constexpr DType dtype_of<float>() { return DType::f32; }
template <> constexpr DType dtype_of<double>() { return DType::f64; }
template <> constexpr DType dtype_of<int64_t>() { return DType::i64; }

template <typename T>
T* Tensor::data() {
  if (!storage_) throw Error("data: tensor is undefined");
  if (dtype_of<T>() != dtype_)
    throw Error(std::string("data: tensor is ") + dtype_name(dtype_) + ", requested " + dtype_name(dtype_of<T>()));
  return static_cast<T*>(storage_->data) + offset_;
}
template <typename T>
const T* Tensor::data() const {
  return const_cast<Tensor*>(this)->data<T>();
}
template float* Tensor::data<float>();
template double* Tensor::data<double>();
template int64_t* Tensor::data<int64_t>();
template const float* Tensor::data<float>() const;
template const double* Tensor::data<double>() const;
template const int64_t* Tensor::data<int64_t>() const;

// Element offset (relative to data()) of a multi-index; checks rank and bounds.
static int64_t element_offset(const Tensor& t, std::initializer_list<int64_t> idx, const char* op) {
  if ((int64_t)idx.size() != t.dim())
    throw Error(std::string(op) + ": " + std::to_string(idx.size()) + " indices for a tensor of shape " +
                shape_str(t.shape()));
  int64_t off = 0, d = 0;
  for (int64_t i : idx) {
    const int64_t n = t.shape()[d];
    if (i < -n || i >= n)
      throw Error(std::string(op) + ": index " + std::to_string(i) + " out of range for dim " + std::to_string(d) +
                  " of size " + std::to_string(n) + " (shape " + shape_str(t.shape()) + ")");
    off += (i < 0 ? i + n : i) * t.strides()[d];
    ++d;
  }
  return off;
}

double Tensor::at(std::initializer_list<int64_t> idx) const {
  detail::check_defined(*this, "at");
  const int64_t off = element_offset(*this, idx, "at");
  return detail::dispatch_all(dtype_, [&](auto z) { return (double)data<decltype(z)>()[off]; });
}

void Tensor::set(std::initializer_list<int64_t> idx, double v) {
  detail::check_defined(*this, "set");
  const int64_t off = element_offset(*this, idx, "set");
  detail::dispatch_all(dtype_, [&](auto z) {
    using T = decltype(z);
    data<T>()[off] = (T)v;
  });
}

double Tensor::item() const {
  detail::check_defined(*this, "item");
  if (numel() != 1) throw Error("item: tensor of shape " + shape_str(shape_) + " has " + std::to_string(numel()) +
                                " elements, expected 1");
  return detail::dispatch_all(dtype_, [&](auto z) { return (double)data<decltype(z)>()[0]; });
}

template <typename T>
std::vector<T> Tensor::to_vector() const {
  detail::check_defined(*this, "to_vector");
  const Tensor c = to(dtype_of<T>()).contiguous();
  const T* p = c.data<T>();
  return std::vector<T>(p, p + c.numel());
}
template std::vector<float> Tensor::to_vector<float>() const;
template std::vector<double> Tensor::to_vector<double>() const;
template std::vector<int64_t> Tensor::to_vector<int64_t>() const;

// ---- views ---------------------------------------------------------------------------------------------------
// Resolves one -1 in `shape` against numel; checks the element count.
static Shape infer_shape(const Shape& shape, int64_t numel, const Shape& from, const char* op) {
  Shape r = shape;
  int64_t infer = -1, known = 1;
  for (size_t i = 0; i < r.size(); ++i) {
    if (r[i] == -1) {
      if (infer >= 0) throw Error(std::string(op) + ": only one -1 allowed in " + shape_str(shape));
      infer = (int64_t)i;
    } else if (r[i] < 0) {
      throw Error(std::string(op) + ": invalid size in " + shape_str(shape));
    } else {
      known *= r[i];
    }
  }
  if (infer >= 0) {
    if (known == 0 || numel % known != 0)
      throw Error(std::string(op) + ": cannot reshape " + shape_str(from) + " to " + shape_str(shape));
    r[infer] = numel / known;
  }
  if (shape_numel(r) != numel)
    throw Error(std::string(op) + ": cannot reshape " + shape_str(from) + " (" + std::to_string(numel) +
                " elements) to " + shape_str(shape));
  return r;
}

// Strides that let `shape` view memory laid out as (old_shape, old_strides); false if impossible.
// Size-1 old dims are dropped; the rest group into runs that are contiguous among themselves (each dim steps
// exactly over the next). Every run must be covered exactly by consecutive new dims.
static bool view_strides(const Shape& old_shape, const Shape& old_strides, const Shape& shape, Shape& out) {
  out.assign(shape.size(), 0);
  Shape os, ost;
  for (size_t d = 0; d < old_shape.size(); ++d)
    if (old_shape[d] != 1) {
      os.push_back(old_shape[d]);
      ost.push_back(old_strides[d]);
    }
  if (os.empty() || shape_numel(os) == 0) {
    out = contiguous_strides(shape);
    return true;
  }
  int64_t nd = (int64_t)shape.size() - 1;  // next new dim to assign, from the back
  int64_t base = ost.back(), run = 1;
  for (int64_t d = (int64_t)os.size() - 1; d >= 0; --d) {
    run *= os[d];
    if (d == 0 || ost[d - 1] != run * base) {  // the run [d, ...] ends here
      int64_t v = 1;
      while (nd >= 0 && (v < run || shape[nd] == 1)) {
        out[nd] = v * base;
        v *= shape[nd];
        --nd;
      }
      if (v != run) return false;
      if (d > 0) {
        base = ost[d - 1];
        run = 1;
      }
    }
  }
  return nd < 0;
}

Tensor Tensor::view(const Shape& shape) const {
  detail::check_defined(*this, "view");
  const Shape s = infer_shape(shape, numel(), shape_, "view");
  Shape st;
  if (is_contiguous()) st = contiguous_strides(s);
  else if (!view_strides(shape_, strides_, s, st))
    throw Error("view: cannot view " + shape_str(shape_) + " with strides " + shape_str(strides_) + " as " +
                shape_str(s) + " (use reshape)");
  return Tensor(storage_, dtype_, s, st, offset_);
}

Tensor Tensor::reshape(const Shape& shape) const {
  detail::check_defined(*this, "reshape");
  const Shape s = infer_shape(shape, numel(), shape_, "reshape");
  Shape st;
  if (is_contiguous()) return Tensor(storage_, dtype_, s, contiguous_strides(s), offset_);
  if (view_strides(shape_, strides_, s, st)) return Tensor(storage_, dtype_, s, st, offset_);
  return contiguous().view(s);
}

Tensor Tensor::transpose(int64_t d0, int64_t d1) const {
  detail::check_defined(*this, "transpose");
  d0 = wrap_dim(d0, dim(), "transpose");
  d1 = wrap_dim(d1, dim(), "transpose");
  Shape s = shape_, st = strides_;
  std::swap(s[d0], s[d1]);
  std::swap(st[d0], st[d1]);
  return Tensor(storage_, dtype_, s, st, offset_);
}

Tensor Tensor::permute(const std::vector<int64_t>& dims) const {
  detail::check_defined(*this, "permute");
  if ((int64_t)dims.size() != dim())
    throw Error("permute: " + std::to_string(dims.size()) + " dims for a tensor of shape " + shape_str(shape_));
  Shape s(dims.size()), st(dims.size());
  std::vector<bool> seen(dims.size(), false);
  for (size_t i = 0; i < dims.size(); ++i) {
    const int64_t d = wrap_dim(dims[i], dim(), "permute");
    if (seen[d]) throw Error("permute: dim " + std::to_string(dims[i]) + " repeated in " + shape_str(dims));
    seen[d] = true;
    s[i] = shape_[d];
    st[i] = strides_[d];
  }
  return Tensor(storage_, dtype_, s, st, offset_);
}

Tensor Tensor::slice(int64_t d, int64_t start, int64_t end, int64_t step) const {
  detail::check_defined(*this, "slice");
  d = wrap_dim(d, dim(), "slice");
  if (step <= 0) throw Error("slice: step must be positive, got " + std::to_string(step));
  const int64_t n = shape_[d];
  auto clampi = [n](int64_t i) { return std::clamp<int64_t>(i < 0 ? i + n : i, 0, n); };
  start = clampi(start);
  end = std::max(clampi(end), start);
  Shape s = shape_, st = strides_;
  s[d] = (end - start + step - 1) / step;
  st[d] = strides_[d] * step;
  return Tensor(storage_, dtype_, s, st, offset_ + start * strides_[d]);
}

Tensor Tensor::select(int64_t d, int64_t index) const {
  detail::check_defined(*this, "select");
  d = wrap_dim(d, dim(), "select");
  const int64_t n = shape_[d];
  if (index < -n || index >= n)
    throw Error("select: index " + std::to_string(index) + " out of range for dim " + std::to_string(d) +
                " of size " + std::to_string(n));
  if (index < 0) index += n;
  Shape s = shape_, st = strides_;
  s.erase(s.begin() + d);
  st.erase(st.begin() + d);
  return Tensor(storage_, dtype_, s, st, offset_ + index * strides_[d]);
}

Tensor Tensor::narrow(int64_t d, int64_t start, int64_t length) const {
  detail::check_defined(*this, "narrow");
  d = wrap_dim(d, dim(), "narrow");
  const int64_t n = shape_[d];
  if (start < 0) start += n;
  if (start < 0 || length < 0 || start + length > n)
    throw Error("narrow: start " + std::to_string(start) + " length " + std::to_string(length) +
                " out of range for dim " + std::to_string(d) + " of size " + std::to_string(n));
  Shape s = shape_;
  s[d] = length;
  return Tensor(storage_, dtype_, s, strides_, offset_ + start * strides_[d]);
}

Tensor Tensor::expand(const Shape& shape) const {
  detail::check_defined(*this, "expand");
  const int64_t nd = (int64_t)shape.size();
  if (nd < dim()) throw Error("expand: cannot expand " + shape_str(shape_) + " to fewer dims " + shape_str(shape));
  Shape s(nd), st(nd);
  for (int64_t i = 0; i < nd; ++i) {
    const int64_t j = i - (nd - dim());  // matching dim of self, or < 0 for new leading dims
    if (j < 0) {
      if (shape[i] < 0) throw Error("expand: -1 not allowed for new leading dim in " + shape_str(shape));
      s[i] = shape[i];
      st[i] = 0;
    } else if (shape[i] == -1 || shape[i] == shape_[j]) {
      s[i] = shape_[j];
      st[i] = strides_[j];
    } else if (shape_[j] == 1 && shape[i] >= 0) {
      s[i] = shape[i];
      st[i] = 0;
    } else {
      throw Error("expand: cannot expand " + shape_str(shape_) + " to " + shape_str(shape));
    }
  }
  return Tensor(storage_, dtype_, s, st, offset_);
}

Tensor Tensor::squeeze(int64_t d) const {
  detail::check_defined(*this, "squeeze");
  d = wrap_dim(d, dim(), "squeeze");
  if (shape_[d] != 1) return *this;
  Shape s = shape_, st = strides_;
  s.erase(s.begin() + d);
  st.erase(st.begin() + d);
  return Tensor(storage_, dtype_, s, st, offset_);
}

Tensor Tensor::unsqueeze(int64_t d) const {
  detail::check_defined(*this, "unsqueeze");
  d = wrap_dim(d, dim() + 1, "unsqueeze");
  Shape s = shape_, st = strides_;
  const int64_t stride = d < dim() ? shape_[d] * strides_[d] : 1;
  s.insert(s.begin() + d, 1);
  st.insert(st.begin() + d, stride);
  return Tensor(storage_, dtype_, s, st, offset_);
}

Tensor Tensor::flatten(int64_t start_dim, int64_t end_dim) const {
  detail::check_defined(*this, "flatten");
  if (dim() == 0) return reshape({1});
  start_dim = wrap_dim(start_dim, dim(), "flatten");
  end_dim = wrap_dim(end_dim, dim(), "flatten");
  if (start_dim > end_dim)
    throw Error("flatten: start_dim " + std::to_string(start_dim) + " > end_dim " + std::to_string(end_dim));
  Shape s(shape_.begin(), shape_.begin() + start_dim);
  int64_t n = 1;
  for (int64_t d = start_dim; d <= end_dim; ++d) n *= shape_[d];
  s.push_back(n);
  s.insert(s.end(), shape_.begin() + end_dim + 1, shape_.end());
  return reshape(s);
}

// ---- copies --------------------------------------------------------------------------------------------------
Tensor Tensor::contiguous() const {
  detail::check_defined(*this, "contiguous");
  if (is_contiguous()) return *this;
  return clone();
}

Tensor Tensor::clone() const {
  detail::check_defined(*this, "clone");
  Tensor t = empty(shape_, dtype_);
  detail::copy_strided(t, *this, "clone");
  return t;
}

Tensor Tensor::to(DType dtype) const {
  detail::check_defined(*this, "to");
  if (dtype == dtype_) return *this;
  Tensor t = empty(shape_, dtype);
  detail::copy_strided(t, *this, "to");
  return t;
}

void Tensor::copy_(const Tensor& src) {
  detail::check_defined(*this, "copy_", "destination");
  detail::check_defined(src, "copy_", "source");
  // A source that shares our storage may overlap the destination: copy it out first.
  if (shares_storage(src)) detail::copy_strided(*this, src.clone(), "copy_");
  else detail::copy_strided(*this, src, "copy_");
}

void Tensor::fill_(double value) {
  detail::check_defined(*this, "fill_");
  detail::fill_strided(*this, value);
}

}  // namespace t2m
