// allocator.cpp — caching allocator: size classes with free lists behind one mutex.
//
// Size classes: requests round up to a multiple of 64 bytes; above 512 bytes to the next of four steps per power
// of two (1, 1.25, 1.5, 1.75 × 2^k), so at most 25% is wasted. A zero-byte request gets a 64-byte block (every
// Storage has a valid, aligned pointer). bytes_in_use / bytes_cached count class sizes, not requested sizes.
// Classes from 256 KB up to 2 MB are carved one after the other from 32 MB arenas marked for huge pages (a block of
// its own would need a whole 2 MB page each, or get 4 KB pages); a carve counts as a trip to the OS.
#include "tensor/allocator.h"

#include <sys/mman.h>

#include <cstdint>
#include <cstdlib>
#include <iterator>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

#include "tensor/tensor.h"

namespace t2m {
namespace {

constexpr size_t kAlign = 64;

size_t size_class(size_t n) {
  if (n <= 512) return n == 0 ? kAlign : (n + kAlign - 1) / kAlign * kAlign;
  // Highest power of two p <= n - 1; classes p, 1.25p, 1.5p, 1.75p, 2p.
  size_t p = 1;
  while (p <= (n - 1) / 2) p <<= 1;
  const size_t step = p / 4;
  const size_t c = (n + step - 1) / step * step;
  return (c + kAlign - 1) / kAlign * kAlign;
}

constexpr size_t kHugePage = size_t(2) << 20;
constexpr size_t kArenaMinClass = size_t(256) << 10;
constexpr size_t kArenaBytes = size_t(32) << 20;

struct Arena {
  char* base;
  size_t carved;  // bytes handed out from base, in order
};

struct Cache {
  std::mutex mu;
  std::unordered_map<size_t, std::vector<void*>> free_lists;
  std::vector<Arena> arenas;  // the last one is carved from
  AllocatorStats stats;
};

Cache& cache() {
  static Cache* c = new Cache();  // never destroyed: Storages may be freed during static destruction
  return *c;
}

int arena_of(const Cache& c, const void* p) {
  for (size_t i = 0; i < c.arenas.size(); ++i)
    if (p >= c.arenas[i].base && p < c.arenas[i].base + kArenaBytes) return int(i);
  return -1;
}

// A new block of class cls from the current arena (a new arena when it is full); nullptr when out of memory.
void* carve(Cache& c, size_t cls) {
  if (c.arenas.empty() || c.arenas.back().carved + cls > kArenaBytes) {
    void* a = aligned_alloc_pages(kArenaBytes, kHugePage);
    if (!a) return nullptr;
    c.arenas.push_back(Arena{static_cast<char*>(a), 0});
  }
  Arena& a = c.arenas.back();
  void* p = a.base + a.carved;
  a.carved += cls;
  return p;
}

// Frees every cached block, and every arena whose blocks are all cached; the cached blocks of an arena with a block
// still in use stay cached. Caller holds the lock.
void release_locked(Cache& c) {
  std::vector<size_t> cached(c.arenas.size(), 0);
  for (auto& [sz, list] : c.free_lists)
    for (void* p : list) {
      const int a = arena_of(c, p);
      if (a < 0)
        std::free(p);
      else
        cached[a] += sz;
    }
  std::vector<bool> gone(c.arenas.size());
  for (size_t i = 0; i < c.arenas.size(); ++i) gone[i] = cached[i] == c.arenas[i].carved;
  c.stats.bytes_cached = 0;
  for (auto it = c.free_lists.begin(); it != c.free_lists.end();) {
    std::vector<void*> kept;
    for (void* p : it->second) {
      const int a = arena_of(c, p);
      if (a >= 0 && !gone[a]) kept.push_back(p);
    }
    c.stats.bytes_cached += kept.size() * it->first;
    it->second.swap(kept);
    it = it->second.empty() ? c.free_lists.erase(it) : std::next(it);
  }
  std::vector<Arena> live;
  for (size_t i = 0; i < c.arenas.size(); ++i) {
    if (gone[i])
      std::free(c.arenas[i].base);
    else
      live.push_back(c.arenas[i]);
  }
  c.arenas.swap(live);
}

}  // namespace

void* aligned_alloc_pages(size_t nbytes, size_t align) {
  const size_t a = nbytes < kHugePage ? align : kHugePage;
  void* p = nullptr;
  if (posix_memalign(&p, a, nbytes == 0 ? a : nbytes) != 0) return nullptr;
  // Advice only (the kernel may run without transparent huge pages), and only for the whole 2 MB pages inside the
  // block: a partly used huge page would count its unused rest in the resident set.
  if (nbytes >= kHugePage) madvise(p, nbytes / kHugePage * kHugePage, MADV_HUGEPAGE);
  return p;
}

void* cached_alloc(size_t nbytes) {
  const size_t cls = size_class(nbytes);
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mu);
  ++c.stats.allocs;
  auto it = c.free_lists.find(cls);
  void* p = nullptr;
  if (it != c.free_lists.end() && !it->second.empty()) {
    p = it->second.back();
    it->second.pop_back();
    c.stats.bytes_cached -= cls;
  } else {
    auto fresh = [&] {
      return cls >= kArenaMinClass && cls < kHugePage ? carve(c, cls) : aligned_alloc_pages(cls, kAlign);
    };
    p = fresh();
    if (!p) {  // out of memory: give the cache back to the OS and try once more
      release_locked(c);
      p = fresh();
    }
    if (!p) throw Error("cached_alloc: out of memory allocating " + std::to_string(nbytes) + " bytes");
    ++c.stats.os_allocs;
  }
  c.stats.bytes_in_use += cls;
  if (c.stats.bytes_in_use > c.stats.peak_bytes_in_use) c.stats.peak_bytes_in_use = c.stats.bytes_in_use;
  return p;
}

void cached_free(void* p, size_t nbytes) {
  if (!p) return;
  const size_t cls = size_class(nbytes);
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mu);
  c.free_lists[cls].push_back(p);
  c.stats.bytes_in_use -= cls;
  c.stats.bytes_cached += cls;
}

AllocatorStats allocator_stats() {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mu);
  return c.stats;
}

void allocator_release_cache() {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mu);
  release_locked(c);
}

}  // namespace t2m
