// allocator.h — the caching allocator behind every Storage. Freed blocks go to size-class free lists and are
// reused; memory is never handed back to the OS during training (first-touch page faults are very expensive on
// these VMs). Blocks are 64-byte aligned. Thread safe.
#pragma once
#include <cstddef>
#include <cstdint>

namespace t2m {

struct AllocatorStats {
  size_t bytes_in_use = 0;     // handed out and not yet freed
  size_t bytes_cached = 0;     // held in free lists
  size_t peak_bytes_in_use = 0;
  uint64_t allocs = 0;         // total allocate() calls
  uint64_t os_allocs = 0;      // of which went to the OS (cache misses)
};

void* cached_alloc(size_t nbytes);
void cached_free(void* p, size_t nbytes);
AllocatorStats allocator_stats();
void allocator_release_cache();  // returns all cached blocks to the OS (e.g. between unrelated jobs)

}  // namespace t2m
