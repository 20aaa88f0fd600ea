// gemm_steal.h — internal to tensor/gemm.cpp: the work-stealing range of the threaded GEMM's rounds.
#pragma once
#include <atomic>
#include <cstdint>

namespace t2m::gemm_detail {

// The (row block, B panel) work items of one thread's share of C in one (jc, pc) round: front and back indices in
// one atomic word (front in the low 32 bits). The owner takes items from the front; a thread that has finished its
// own share takes them from the back (work stealing: on these VMs one vCPU is often 20% slower than the other for
// seconds at a time, and a static split makes the faster one wait at every barrier).
struct alignas(64) StealRange {
  std::atomic<uint64_t> fb{0};
  std::atomic<int64_t> round{-1};  // the round whose items fb holds (split by columns: published without a barrier)
  void reset(int64_t n) { fb.store(uint64_t(n) << 32, std::memory_order_relaxed); }
  // After reset and after packing what the items read: a thief that sees `r` also sees both.
  void publish(int64_t r) { round.store(r, std::memory_order_release); }
  void wait_for(int64_t r) const {
    while (round.load(std::memory_order_acquire) != r) {
    }
  }
  // Front item (owner) or back item (thief), -1 when none is left.
  int64_t take(bool back) {
    uint64_t cur = fb.load(std::memory_order_relaxed);
    for (;;) {
      const uint64_t f = cur & 0xffffffffu, b = cur >> 32;
      if (f >= b) return -1;
      const uint64_t next = back ? (f | ((b - 1) << 32)) : ((f + 1) | (b << 32));
      if (fb.compare_exchange_weak(cur, next, std::memory_order_acq_rel, std::memory_order_relaxed))
        return int64_t(back ? b - 1 : f);
    }
  }
};

}  // namespace t2m::gemm_detail
