// ops_copy.cpp — the strided copy/convert and fill kernels behind Tensor::copy_, contiguous, clone, to, fill_.
#include <cstring>

#include "tensor/kernels.h"
#include "tensor/strided_iter.h"

namespace t2m::detail {

// dst[i] = (Dst)src[i] with src broadcast to dst's shape. dst and src must not partially overlap.
void copy_strided(Tensor& dst, const Tensor& src, const char* op) {
  const Shape sst = broadcast_strides(src, dst.shape(), op);
  const std::array<Shape, 2> strides{dst.strides(), sst};
  dispatch_all(dst.dtype(), [&](auto dz) {
    using D = decltype(dz);
    D* pd = dst.data<D>();
    dispatch_all(src.dtype(), [&](auto sz) {
      using S = decltype(sz);
      const S* ps = src.data<S>();
      strided_for_each<2>(dst.shape(), strides,
                          [&](const std::array<int64_t, 2>& off, const std::array<int64_t, 2>& st, int64_t n) {
                            D* o = pd + off[0];
                            const S* x = ps + off[1];
                            if constexpr (std::is_same_v<D, S>) {
                              if (st[0] == 1 && st[1] == 1) {
                                std::memcpy(o, x, (size_t)n * sizeof(D));
                                return;
                              }
                            }
                            if (st[0] == 1 && st[1] == 1) {
                              for (int64_t i = 0; i < n; ++i) o[i] = (D)x[i];
                            } else if (st[0] == 1 && st[1] == 0) {
                              const D v = (D)x[0];
                              for (int64_t i = 0; i < n; ++i) o[i] = v;
                            } else {
                              for (int64_t i = 0; i < n; ++i) o[i * st[0]] = (D)x[i * st[1]];
                            }
                          });
    });
  });
}

// Every element of dst (any strides) set to value.
void fill_strided(Tensor& dst, double value) {
  const std::array<Shape, 1> strides{dst.strides()};
  dispatch_all(dst.dtype(), [&](auto dz) {
    using D = decltype(dz);
    D* pd = dst.data<D>();
    const D v = (D)value;
    strided_for_each<1>(dst.shape(), strides,
                        [&](const std::array<int64_t, 1>& off, const std::array<int64_t, 1>& st, int64_t n) {
                          D* o = pd + off[0];
                          if (st[0] == 1)
                            for (int64_t i = 0; i < n; ++i) o[i] = v;
                          else
                            for (int64_t i = 0; i < n; ++i) o[i * st[0]] = v;
                        });
  });
}

}  // namespace t2m::detail
