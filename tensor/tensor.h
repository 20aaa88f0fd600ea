// tensor.h — the n-dimensional array of t2m-engine: storage shared by views, shape and strides, dtype.
//
// A Tensor is a cheap handle (shared storage + offset + shape + strides). Views (reshape of contiguous data,
// transpose, permute, slice, expand, squeeze/unsqueeze, select) share storage; every op that needs contiguous
// input makes it so explicitly. Storage comes from the caching allocator (tensor/allocator.h).
// Dtypes: float32 and float64 (kernels are templates over the scalar type), int64 for index tensors.
// Errors: every op throws t2m::Error whose message names the op and the offending shapes/values.
// Ops (math, reductions, matmul, indexing) live in tensor/ops.h; the RNG in tensor/rng.h.
#pragma once
#include <cstdint>
#include <initializer_list>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace t2m {

enum class DType : uint8_t { f32, f64, i64 };
const char* dtype_name(DType d);
size_t dtype_size(DType d);

using Shape = std::vector<int64_t>;
std::string shape_str(const Shape& s);  // "[2, 3, 4]"
int64_t shape_numel(const Shape& s);

// The one exception type of the engine. Message style: "op: what is wrong (shapes/values)".
struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A block of memory from the caching allocator; freed back to the cache when the last reference goes.
struct Storage {
  void* data = nullptr;
  size_t nbytes = 0;
  explicit Storage(size_t nbytes);
  ~Storage();
  Storage(const Storage&) = delete;
  Storage& operator=(const Storage&) = delete;
};

class Tensor {
 public:
  Tensor() = default;  // undefined tensor: defined() == false

  // Creation (contiguous, row-major).
  static Tensor empty(const Shape& shape, DType dtype = DType::f32);
  static Tensor zeros(const Shape& shape, DType dtype = DType::f32);
  static Tensor ones(const Shape& shape, DType dtype = DType::f32);
  static Tensor full(const Shape& shape, double value, DType dtype = DType::f32);
  static Tensor scalar(double value, DType dtype = DType::f32);              // 0-d tensor
  static Tensor arange(int64_t n, DType dtype = DType::f32);                 // [0, 1, ..., n-1]
  static Tensor from_vector(const std::vector<float>& v, const Shape& shape);
  static Tensor from_vector(const std::vector<double>& v, const Shape& shape);
  static Tensor from_vector(const std::vector<int64_t>& v, const Shape& shape);

  // Metadata.
  bool defined() const { return storage_ != nullptr; }
  DType dtype() const { return dtype_; }
  const Shape& shape() const { return shape_; }
  const Shape& strides() const { return strides_; }  // in elements
  int64_t dim() const { return (int64_t)shape_.size(); }
  int64_t size(int64_t d) const;                      // negative d counts from the end
  int64_t numel() const;
  int64_t offset() const { return offset_; }          // in elements
  bool is_contiguous() const;
  bool shares_storage(const Tensor& o) const { return storage_ == o.storage_; }
  const std::shared_ptr<Storage>& storage() const { return storage_; }

  // Raw access. data<T>() points at element [0,...,0] (storage + offset); checks T matches dtype.
  template <typename T> T* data();
  template <typename T> const T* data() const;
  // Element read/write by multi-index (slow; for tests and small glue code). Value converted to/from double.
  double at(std::initializer_list<int64_t> idx) const;
  void set(std::initializer_list<int64_t> idx, double v);
  double item() const;                                // numel() must be 1
  template <typename T> std::vector<T> to_vector() const;  // contiguous copy in row-major order

  // Views (share storage).
  Tensor view(const Shape& shape) const;              // requires a compatible layout; one -1 allowed
  Tensor reshape(const Shape& shape) const;           // view when possible, else contiguous copy; one -1 allowed
  Tensor transpose(int64_t d0, int64_t d1) const;
  Tensor permute(const std::vector<int64_t>& dims) const;
  Tensor slice(int64_t dim, int64_t start, int64_t end, int64_t step = 1) const;  // python-like, clamps
  Tensor select(int64_t dim, int64_t index) const;    // removes dim
  Tensor narrow(int64_t dim, int64_t start, int64_t length) const;
  Tensor expand(const Shape& shape) const;            // size-1 dims broadcast with stride 0; -1 keeps size
  Tensor squeeze(int64_t dim) const;
  Tensor unsqueeze(int64_t dim) const;
  Tensor flatten(int64_t start_dim = 0, int64_t end_dim = -1) const;

  // Copies.
  Tensor contiguous() const;                          // self when already contiguous
  Tensor clone() const;                               // always a fresh contiguous copy
  Tensor to(DType dtype) const;                       // converted contiguous copy (self if same dtype)
  void copy_(const Tensor& src);                      // src broadcast to this shape; dtype converted
  void fill_(double value);
  void zero_() { fill_(0.0); }

  // Internal constructor for kernels: a view of existing storage.
  Tensor(std::shared_ptr<Storage> storage, DType dtype, Shape shape, Shape strides, int64_t offset);

 private:
  std::shared_ptr<Storage> storage_;
  DType dtype_ = DType::f32;
  Shape shape_;
  Shape strides_;
  int64_t offset_ = 0;
};

// Contiguous row-major strides for a shape.
Shape contiguous_strides(const Shape& shape);
// Normalises a possibly negative dim against ndim; throws Error naming `op` when out of range.
int64_t wrap_dim(int64_t dim, int64_t ndim, const char* op);
// The broadcast shape of a and b (numpy rules); throws Error naming `op` and both shapes when incompatible.
Shape broadcast_shapes(const Shape& a, const Shape& b, const char* op);

}  // namespace t2m
