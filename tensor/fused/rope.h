// rope.h — rotary position embedding (RoFormer, Su et al. 2021), "rotate-half" pairing: within each head
// vector of size d, element i (< d/2) is paired with element i + d/2 and the pair is rotated by angle
// pos * theta_i, theta_i = base^(-2i/d).
//   y[i]       = x[i] cos - x[i + d/2] sin
//   y[i + d/2] = x[i] sin + x[i + d/2] cos
// The backward is the rotation by the opposite angle; it writes dinp (=). In-place (out == inp) is allowed.
// Errors: t2m::Error for odd d, N < 0, T < 1, d < 2, base <= 0, null pointers.
#pragma once
#include <cstdint>

namespace t2m::fused {

// cos_tab/sin_tab (T, d/2): the table for positions pos0, pos0 + 1, ..., pos0 + T - 1 (computed in double).
template <typename T>
void rope_table(T* cos_tab, T* sin_tab, int64_t Tlen, int64_t d, double base = 10000.0, int64_t pos0 = 0);

// inp (N, T, d) with N = B*H (the (B, H, T, d) attention layout); cos/sin (T, d/2); out (N, T, d).
template <typename T>
void rope_forward(T* out, const T* inp, const T* cos_tab, const T* sin_tab, int64_t N, int64_t Tlen, int64_t d);
// dout (N, T, d); dinp (N, T, d).
template <typename T>
void rope_backward(T* dinp, const T* dout, const T* cos_tab, const T* sin_tab, int64_t N, int64_t Tlen, int64_t d);


// One head vector (the loop of the two above, for kernels that rotate rows they gather themselves, such as
// attention_heads.h): y (2h) = x rotated by the angles whose cos/sin are c/s (h), sign +1 forward, -1 backward.
// y == x is allowed.
template <typename T>
void rope_rotate_row(T* y, const T* x, const T* c, const T* s, int64_t h, T sign);

}  // namespace t2m::fused
