// gemm_columns.h — internal to tensor/gemm.cpp: packing and storing matrices whose columns lie in segments
// (GemmColumns, gemm.h). The packed panels are exactly those of the plain packers (gemm_kernel.h), so the
// kernels and their bits do not change; only the addresses the packers read from and the tiles are stored to.
#pragma once
#include <algorithm>
#include <cstdint>

#include "tensor/gemm.h"

namespace t2m::gemm_detail {

// Stored column of logical column c.
inline int64_t segment_col(const GemmColumns& s, int64_t c) { return s.len ? c / s.len * s.stride + c % s.len : c; }

// Columns from c to the end of c's segment (any count when plain).
inline int64_t segment_left(const GemmColumns& s, int64_t c) { return s.len ? s.len - c % s.len : INT64_MAX; }

// Packs op(X)[p0 : p0 + np, d0 : d0 + nd] into W-wide panels (panel dimension p: M for A, N for B; depth d: K),
// panel q at out + q nd W, as `pack(src, np', nd', dst)` does for a plain block at src (row stride ld). The stored
// columns of X are in segments s and are either the panel dimension (cols_are_panels: element (p, d) at
// X + d ld + col(p)) or the depth (element (p, d) at X + p ld + col(d)).
// Panel columns within one segment go to `pack` as they are (several panels per call); a panel that straddles a
// segment boundary is gathered here, run by run. Depth that straddles one goes to `pack` piece by piece, one panel
// at a time (each piece at its rows of the panel).
template <typename T, typename Pack>
void pack_segmented(bool cols_are_panels, int W, const T* X, int64_t ld, const GemmColumns& s, int64_t p0,
                    int64_t np, int64_t d0, int64_t nd, T* out, Pack pack) {
  if (cols_are_panels) {
    for (int64_t q0 = 0; q0 < np;) {  // q0 stays a multiple of W
      const int64_t p = p0 + q0, left = segment_left(s, p);
      int64_t run = std::min(np - q0, left) / W * W;  // whole panels inside p's segment
      if (run == 0 && np - q0 <= left) run = np - q0;  // the last, short panel inside it
      T* o = out + q0 / W * nd * W;
      if (run > 0) {
        pack(X + d0 * ld + segment_col(s, p), run, nd, o);
        q0 += run;
        continue;
      }
      const int64_t w = std::min<int64_t>(W, np - q0);  // straddles a boundary: gather
      for (int64_t d = 0; d < nd; ++d) {
        const T* src = X + (d0 + d) * ld;
        T* row = o + d * W;
        for (int64_t j = 0; j < w;) {
          const int64_t n = std::min(w - j, segment_left(s, p + j));
          std::copy(src + segment_col(s, p + j), src + segment_col(s, p + j) + n, row + j);
          j += n;
        }
        std::fill(row + w, row + W, T(0));
      }
      q0 += w;
    }
    return;
  }
  if (segment_left(s, d0) >= nd) return pack(X + p0 * ld + segment_col(s, d0), np, nd, out);
  for (int64_t q0 = 0; q0 < np; q0 += W) {
    const int64_t w = std::min<int64_t>(W, np - q0);
    T* o = out + q0 / W * nd * W;
    for (int64_t d = 0; d < nd;) {
      const int64_t n = std::min(nd - d, segment_left(s, d0 + d));
      pack(X + (p0 + q0) * ld + segment_col(s, d0 + d), w, n, o + d * W);
      d += n;
    }
  }
}

}  // namespace t2m::gemm_detail
