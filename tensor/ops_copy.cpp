// ops_copy.cpp — the strided copy/convert and fill kernels behind Tensor::copy_, contiguous, clone, to, fill_.
#include <algorithm>
#include <cstring>

#include "tensor/kernels.h"
#include "tensor/strided_iter.h"

namespace t2m::detail {

namespace {

// A copy whose two innermost (coalesced) dims are transposed between dst and src: dst is unit-stride along the
// last dim, src along the one before. Walking dst row by row would touch a new src cache line per element, so
// it goes in 32x32 tiles instead. Returns false when the layout is not of that kind.
template <typename D, typename S>
bool copy_transposed_tiles(D* pd, const S* ps, const StridedPlan<2>& p) {
  const int64_t nd = (int64_t)p.shape.size();
  if (nd < 2) return false;
  const int64_t R = p.shape[nd - 2], C = p.shape[nd - 1];
  const int64_t dr = p.strides[0][nd - 2], sc = p.strides[1][nd - 1];
  if (p.strides[0][nd - 1] != 1 || p.strides[1][nd - 2] != 1 || sc <= 1 || R < 16 || C < 16) return false;
  constexpr int64_t kTile = 32;
  const int64_t outer = p.numel / (R * C), row_tiles = (R + kTile - 1) / kTile;
  const int nt = threads_for(p.numel);
#pragma omp parallel for if (nt > 1) num_threads(nt) schedule(static)
  for (int64_t it = 0; it < outer * row_tiles; ++it) {
    int64_t o = it / row_tiles, od = 0, os = 0;
    for (int64_t d = nd - 3; d >= 0; --d) {
      od += (o % p.shape[d]) * p.strides[0][d];
      os += (o % p.shape[d]) * p.strides[1][d];
      o /= p.shape[d];
    }
    const int64_t r0 = (it % row_tiles) * kTile, r1 = std::min(R, r0 + kTile);
    for (int64_t c0 = 0; c0 < C; c0 += kTile) {
      const int64_t c1 = std::min(C, c0 + kTile);
      for (int64_t r = r0; r < r1; ++r) {
        D* drow = pd + od + r * dr;
        const S* scol = ps + os + r;
        for (int64_t c = c0; c < c1; ++c) drow[c] = (D)scol[c * sc];
      }
    }
  }
  return true;
}

}  // namespace

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
      if (shape_numel(dst.shape()) >= 1024 && copy_transposed_tiles(pd, ps, make_plan<2>(dst.shape(), strides)))
        return;
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
