// gemm_buffer.h — internal to tensor/gemm*.cpp: the per-thread scratch the GEMM packs into (and its small-shape
// path works in).
#pragma once
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "tensor/allocator.h"
#include "tensor/tensor.h"

namespace t2m::gemm_detail {

// A grow-only, page-aligned scratch buffer per thread: packing never allocates once warm (first touches of
// fresh pages are very expensive on these VMs, so the memory is kept for the life of the thread).
struct PackBuffer {
  void* ptr = nullptr;
  size_t cap = 0;
  PackBuffer() = default;
  PackBuffer(const PackBuffer&) = delete;
  PackBuffer& operator=(const PackBuffer&) = delete;
  ~PackBuffer() { std::free(ptr); }
  template <typename T>
  T* get(int64_t n) {
    const size_t bytes = size_t(std::max<int64_t>(n, 1)) * sizeof(T);
    if (bytes > cap) {
      std::free(ptr);
      ptr = nullptr;
      cap = 0;
      // A few buffers per thread: whole huge pages (rounded up) rather than a small-page tail.
      const size_t huge = size_t(2) << 20;
      const size_t want = bytes >= huge ? (bytes + huge - 1) / huge * huge : (bytes + 4095) / 4096 * 4096;
      ptr = aligned_alloc_pages(want, 4096);
      if (!ptr) throw Error("gemm: cannot allocate " + std::to_string(want) + " bytes of packing buffer");
      cap = want;
    }
    return static_cast<T*>(ptr);
  }
};

}  // namespace t2m::gemm_detail
