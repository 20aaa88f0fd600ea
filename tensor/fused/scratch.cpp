// scratch.cpp — per-thread growable aligned buffers, one per slot.
#include "tensor/fused/scratch.h"

#include <cstdlib>
#include <string>

#include "tensor/allocator.h"
#include "tensor/tensor.h"

namespace t2m::fused {

namespace {

struct ScratchSet {
  void* ptr[kScratchSlots] = {};
  size_t cap[kScratchSlots] = {};
  ~ScratchSet() {
    for (int i = 0; i < kScratchSlots; ++i) std::free(ptr[i]);
  }
};

thread_local ScratchSet tls_scratch;

}  // namespace

void* fused_scratch_bytes(int slot, size_t nbytes) {
  if (slot < 0 || slot >= kScratchSlots)
    throw Error("fused_scratch: slot " + std::to_string(slot) + " out of range [0, " +
                std::to_string(kScratchSlots) + ")");
  if (nbytes == SIZE_MAX) throw Error("fused_scratch: negative element count");
  ScratchSet& s = tls_scratch;
  if (nbytes > s.cap[slot] || s.ptr[slot] == nullptr) {
    size_t want = nbytes < 64 ? 64 : (nbytes + 63) / 64 * 64;
    if (want < s.cap[slot] + s.cap[slot] / 2) want = (s.cap[slot] + s.cap[slot] / 2 + 63) / 64 * 64;
    void* p = aligned_alloc_pages(want, 64);
    if (p == nullptr) throw Error("fused_scratch: out of memory asking for " + std::to_string(want) + " bytes");
    std::free(s.ptr[slot]);
    s.ptr[slot] = p;
    s.cap[slot] = want;
  }
  return s.ptr[slot];
}

void fused_scratch_release() {
  ScratchSet& s = tls_scratch;
  for (int i = 0; i < kScratchSlots; ++i) {
    std::free(s.ptr[i]);
    s.ptr[i] = nullptr;
    s.cap[i] = 0;
  }
}

}  // namespace t2m::fused
