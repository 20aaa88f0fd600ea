// test_allocator.cpp — caching allocator: reuse (cache hits), stats, alignment (huge-page blocks), huge-page arenas
// for medium blocks, release, thread safety.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <thread>
#include <vector>

#include "tensor/allocator.h"
#include "tensor/tensor.h"

using namespace t2m;

TEST(Allocator, SecondAllocOfSameSizeIsCacheHit) {
  allocator_release_cache();
  const size_t n = 123457;  // an odd size nobody else uses in this program
  void* p = cached_alloc(n);
  const AllocatorStats s1 = allocator_stats();
  cached_free(p, n);
  const AllocatorStats s2 = allocator_stats();
  EXPECT_LT(s2.bytes_in_use, s1.bytes_in_use);
  EXPECT_GE(s2.bytes_cached, n);
  void* q = cached_alloc(n);
  const AllocatorStats s3 = allocator_stats();
  EXPECT_EQ(q, p);                          // the same block came back
  EXPECT_EQ(s3.os_allocs, s2.os_allocs);    // no trip to the OS
  EXPECT_EQ(s3.allocs, s2.allocs + 1);
  EXPECT_EQ(s3.bytes_cached, s2.bytes_cached - (s1.bytes_in_use - s2.bytes_in_use));
  // A slightly smaller request falls in the same size class and is also a hit.
  cached_free(q, n);
  void* r = cached_alloc(n - 10);
  EXPECT_EQ(r, p);
  EXPECT_EQ(allocator_stats().os_allocs, s2.os_allocs);
  cached_free(r, n - 10);
}

TEST(Allocator, MissGoesToOsAndPeakTracks) {
  allocator_release_cache();
  const AllocatorStats s0 = allocator_stats();
  EXPECT_EQ(s0.bytes_cached, 0u);
  void* a = cached_alloc(1 << 20);
  void* b = cached_alloc(1 << 20);
  const AllocatorStats s1 = allocator_stats();
  EXPECT_EQ(s1.os_allocs, s0.os_allocs + 2);
  EXPECT_GE(s1.bytes_in_use, s0.bytes_in_use + (2u << 20));
  EXPECT_GE(s1.peak_bytes_in_use, s1.bytes_in_use);
  cached_free(a, 1 << 20);
  cached_free(b, 1 << 20);
  const AllocatorStats s2 = allocator_stats();
  EXPECT_EQ(s2.bytes_in_use, s0.bytes_in_use);
  EXPECT_EQ(s2.peak_bytes_in_use, s1.peak_bytes_in_use);  // peak stays
  EXPECT_GE(s2.bytes_cached, 2u << 20);
  allocator_release_cache();
  EXPECT_EQ(allocator_stats().bytes_cached, 0u);
  void* c = cached_alloc(1 << 20);  // cache was released: a miss again
  EXPECT_EQ(allocator_stats().os_allocs, s2.os_allocs + 1);
  cached_free(c, 1 << 20);
}

TEST(Allocator, AlignmentAndZeroBytes) {
  std::vector<std::pair<void*, size_t>> blocks;
  for (size_t n : {0ul, 1ul, 7ul, 63ul, 64ul, 65ul, 513ul, 1000ul, 4097ul, 100000ul, 3000001ul}) {
    void* p = cached_alloc(n);
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(reinterpret_cast<uintptr_t>(p) % 64, 0u) << n;
    if (n) static_cast<char*>(p)[n - 1] = 1;  // writable to the last byte
    blocks.push_back({p, n});
  }
  for (auto [p, n] : blocks) cached_free(p, n);
  Storage s(0);
  EXPECT_NE(s.data, nullptr);
  EXPECT_EQ(s.nbytes, 0u);
}

TEST(Allocator, TensorsReuseFreedStorage) {
  allocator_release_cache();
  const void* first;
  {
    Tensor t = Tensor::empty({1000, 37});
    first = t.data<float>();
  }
  const uint64_t os = allocator_stats().os_allocs;
  Tensor u = Tensor::empty({37, 1000});
  EXPECT_EQ(u.data<float>(), first);
  EXPECT_EQ(allocator_stats().os_allocs, os);
}

TEST(Allocator, ThreadSafe) {
  const AllocatorStats s0 = allocator_stats();
  std::vector<std::thread> th;
  for (int t = 0; t < 4; ++t)
    th.emplace_back([t] {
      for (int i = 0; i < 2000; ++i) {
        const size_t n = 64 * (1 + (i * 7 + t) % 50);
        char* p = static_cast<char*>(cached_alloc(n));
        p[0] = (char)t;
        p[n - 1] = (char)i;
        cached_free(p, n);
      }
    });
  for (auto& x : th) x.join();
  const AllocatorStats s1 = allocator_stats();
  EXPECT_EQ(s1.bytes_in_use, s0.bytes_in_use);
  EXPECT_EQ(s1.allocs, s0.allocs + 8000);
}

TEST(Allocator, LargeBlocksAreHugePageAligned) {
  // Below 2 MB the requested alignment; from 2 MB on a 2 MB boundary (the block can then hold whole huge pages).
  struct Case {
    size_t bytes, align, want_align;
  } cases[] = {{0, 64, 64}, {100, 64, 64}, {5000, 4096, 4096}, {(size_t(2) << 20) - 64, 64, 64},
               {size_t(2) << 20, 64, size_t(2) << 20}, {(size_t(5) << 20) + 192, 64, size_t(2) << 20}};
  for (const Case& c : cases) {
    char* p = static_cast<char*>(aligned_alloc_pages(c.bytes, c.align));
    ASSERT_NE(p, nullptr) << c.bytes;
    EXPECT_EQ(reinterpret_cast<uintptr_t>(p) % c.want_align, 0u) << c.bytes;
    if (c.bytes > 0) {  // every byte is usable
      p[0] = 1;
      p[c.bytes - 1] = 2;
      EXPECT_EQ(p[0] + p[c.bytes - 1], 3);
    }
    std::free(p);
  }
  // The caching allocator's large classes come from the same path.
  const size_t n = (size_t(3) << 20) + 4096;
  void* q = cached_alloc(n);
  EXPECT_EQ(reinterpret_cast<uintptr_t>(q) % (size_t(2) << 20), 0u);
  cached_free(q, n);
}

TEST(Allocator, MediumBlocksShareHugePageArenas) {
  // Classes from 256 KB to 2 MB are carved in order from a 2 MB aligned arena; release frees an arena only when all
  // its blocks are free, and keeps the free blocks of an arena still in use cached (and reusable).
  allocator_release_cache();
  const size_t mb = size_t(1) << 20;
  char* a = static_cast<char*>(cached_alloc(mb));
  char* b = static_cast<char*>(cached_alloc(mb));
  EXPECT_EQ(reinterpret_cast<uintptr_t>(a) % (2 * mb), 0u);  // a fresh arena starts on a huge page
  EXPECT_EQ(b, a + mb);
  a[0] = 1, a[mb - 1] = 2, b[0] = 3, b[mb - 1] = 4;
  EXPECT_EQ(a[0] + a[mb - 1] + b[0] + b[mb - 1], 10);
  void* small = cached_alloc(4096);  // below 256 KB: not from the arena
  EXPECT_TRUE(static_cast<char*>(small) < a || static_cast<char*>(small) >= a + (32 * mb));
  cached_free(small, 4096);
  cached_free(b, mb);
  allocator_release_cache();  // a is in use: b stays cached
  const AllocatorStats s1 = allocator_stats();
  EXPECT_EQ(s1.bytes_cached, mb);
  void* b2 = cached_alloc(mb);
  EXPECT_EQ(b2, b);
  EXPECT_EQ(allocator_stats().os_allocs, s1.os_allocs);  // a cache hit
  cached_free(b2, mb);
  cached_free(a, mb);
  allocator_release_cache();  // every block of the arena is free: it goes back
  EXPECT_EQ(allocator_stats().bytes_cached, 0u);
  void* c = cached_alloc(mb);
  EXPECT_EQ(allocator_stats().os_allocs, s1.os_allocs + 1);
  cached_free(c, mb);
}
