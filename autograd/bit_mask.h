// bit_mask.h — INTERNAL to autograd/: v where a condition holds, else +0, by masking v's bits. The same value as
// `k ? v : (T)0`, but GCC keeps it branch-free, so element loops built on it vectorise (a select around a
// product is otherwise often compiled to a branch per element, and random masks mispredict).
#pragma once
#include <bit>
#include <cstdint>
#include <type_traits>

namespace t2m::ag {

template <typename T>
inline T keep_or_zero(T v, bool k) {
  using U = std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>;
  return std::bit_cast<T>(std::bit_cast<U>(v) & ((U)0 - (U)k));
}

}  // namespace t2m::ag
