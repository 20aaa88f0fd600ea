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

// Aligned block straight from the C library (std::free releases it). Blocks of 2 MB and more are 2 MB aligned
// and the whole 2 MB pages inside them are marked for transparent huge pages (madvise): under a VM's nested
// paging every TLB miss of a 4 KB page walks two page tables, and the streaming kernels (norms, transforms,
// optimizer) touch tens of MB per step. `align` (a power of two, at least 64) applies below 2 MB. Returns nullptr when out of memory.
void* aligned_alloc_pages(size_t nbytes, size_t align);

// Blocks from 256 KB up to 2 MB are carved from 32 MB arenas of huge pages (the activations and the 512x512
// weights of the generator: on 4 KB pages their GEMMs and elementwise passes ran ~4 % slower per fm-paper step).
void* cached_alloc(size_t nbytes);
void cached_free(void* p, size_t nbytes);
AllocatorStats allocator_stats();
// Returns the cached blocks to the OS (e.g. between unrelated jobs); an arena goes back only once all its blocks are
// free, and until then its cached blocks stay cached.
void allocator_release_cache();

}  // namespace t2m
