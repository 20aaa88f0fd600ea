// scratch.h — thread-local cached scratch memory for the fused kernels (the "workspace" of MuJoCo's mjData,
// kept per calling thread so that kernels allocate nothing after their first call at a given size).
//
// fused_scratch<T>(slot, n) returns a 64-byte aligned buffer of at least n elements of T, owned by the calling
// thread, stable until the next call with the same slot on the same thread (which may grow and move it).
// Contents are unspecified (not zeroed). Slots 0..kScratchSlots-1 let one kernel hold several buffers at once.
// Memory only grows; fused_scratch_release() frees the calling thread's buffers.
// Throws Error for a slot out of range or n < 0.
#pragma once
#include <cstddef>
#include <cstdint>

namespace t2m::fused {

constexpr int kScratchSlots = 8;

void* fused_scratch_bytes(int slot, size_t nbytes);
void fused_scratch_release();

template <typename T>
T* fused_scratch(int slot, int64_t n) {
  return static_cast<T*>(fused_scratch_bytes(slot, (n < 0 ? SIZE_MAX : (size_t)n * sizeof(T))));
}

}  // namespace t2m::fused
