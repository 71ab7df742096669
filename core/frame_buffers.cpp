// The cache of freed whole-frame buffers (include/photosite/frame_buffers.h).
#include "photosite/frame_buffers.h"

#include <pthread.h>
#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

#include <algorithm>
#include <list>
#include <mutex>
#include <new>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace photosite {
namespace {

struct Cache {
  struct Entry {
    size_t bytes;
    void* p;
    uint64_t freed_at;  // `requests` when it was freed
  };
  using Held = std::list<Entry>;  // the least recently freed first
  std::mutex m;
  size_t limit = 0, held = 0, min_bytes = kFrameBufferMinBytes;
  uint64_t reused = 0, allocated = 0;
  // The stale rule (frame_buffers.h). `requests` counts the allocations of at least min_bytes (the
  // clock, in the program's own steps, so a pause between frames ages nothing); `longest_wait` is
  // the most requests a reused buffer waited in the cache.
  bool free_stale = false;
  uint64_t requests = 0, longest_wait = 0;
  // Per size, when the last buffer the rule freed had been freed: a later request of that size is
  // a wait the rule had not seen (a size that comes back every few frames), and longest_wait learns
  // it, so the next such buffers are kept. At most kForgotten sizes (cleared when full).
  static constexpr size_t kForgotten = 256;
  std::unordered_map<size_t, uint64_t> forgotten;
  // Every buffer of at least kFrameBufferMinBytes handed out and not yet back, whatever the limit,
  // and the most of them at once since the process started (reported, for a user sizing the limit).
  size_t in_use = 0, peak = 0;
  Held order;
  // Per size, its buffers in `order`, the most recently freed last.
  std::unordered_map<size_t, std::vector<Held::iterator>> by_size;

  // Frees the least recently freed buffer (under the lock). Per size the buffers stand in `order`
  // in the order of their vector, so the list's first is its size's first.
  void evict_oldest() {
    const Entry e = order.front();
    auto it = by_size.find(e.bytes);
    it->second.erase(it->second.begin());
    if (it->second.empty()) by_size.erase(it);
    order.pop_front();
    held -= e.bytes;
    ::operator delete(e.p);
  }
  void trim_to(size_t target) {
    while (held > target) evict_oldest();
  }
  // The most requests a held buffer may wait under the stale rule.
  // A quarter more than the longest wait seen: room for the jitter of a loop's waits (threads
  // free in varying order); a wait beyond it costs one new buffer and is learnt (learn_wait).
  uint64_t stale_after() const {
    return std::max(longest_wait + longest_wait / 4, 2 * kFrameBufferStaleFloorRequests);
  }
  // Under the stale rule, frees the held buffers that have waited longer than stale_after() (under
  // the lock). `order` is by the time of freeing, so they stand at its front.
  void free_stale_buffers() {
    if (!free_stale) return;
    const uint64_t horizon = stale_after();
    while (!order.empty() && requests - order.front().freed_at > horizon) {
      try {
        if (forgotten.size() >= kForgotten) forgotten.clear();
        forgotten[order.front().bytes] = order.front().freed_at;
      } catch (...) {  // no memory for the entry: the wait is not learnt
      }
      evict_oldest();
    }
  }
  // A request of a size the rule freed: learns the wait it would have had (under the lock).
  void learn_wait(size_t bytes) {
    if (forgotten.empty()) return;
    const auto it = forgotten.find(bytes);
    if (it == forgotten.end()) return;
    longest_wait = std::max(longest_wait, requests - it->second);
    forgotten.erase(it);
  }
  // Frees every held buffer smaller than min_bytes (under the lock).
  void drop_below_min() {
    for (auto it = by_size.begin(); it != by_size.end();) {
      if (it->first >= min_bytes) {
        ++it;
        continue;
      }
      for (const auto& h : it->second) {
        ::operator delete(h->p);
        held -= h->bytes;
        order.erase(h);
      }
      it = by_size.erase(it);
    }
  }
};

Cache* g_cache = nullptr;  // made once by cache(), read by the fork handlers

// Never destroyed: Images with static storage may be freed after any other static's destructor,
// and a buffer handed back then must still find the cache. At exit the held buffers go with the
// process. A fork (a DataLoader's workers) while another thread holds the lock would leave the
// child's copy locked for good, so the lock is taken around fork() and released on both sides.
Cache& cache() {
  static Cache* c = [] {
    g_cache = new Cache;
    pthread_atfork([] { g_cache->m.lock(); }, [] { g_cache->m.unlock(); }, [] { g_cache->m.unlock(); });
    return g_cache;
  }();
  return *c;
}

// Transparent huge pages for the buffers of at least kHugePageAdviseMinBytes (Linux): each whole 2
// MiB-aligned block inside a new buffer is backed by one huge page from its next first touch on.
// Every new buffer's blocks are advised (MADV_HUGEPAGE, one call), so that the kernel faults each
// in as one huge page where THP is "madvise" (the usual default:
// /sys/kernel/mm/transparent_hugepage/enabled; "always" does so anyway, "never" ignores the advice;
// without a free huge page it falls back to small pages); and the first time a block is seen it is
// emptied before (MADV_DONTNEED: its old 4 KiB pages, if the heap had used that memory before, go
// back to the kernel, and the next touch faults in a huge page; a new buffer's contents are not
// read before they are written, image.h). The blocks seen are kept (a set of their addresses), so a
// buffer on memory the heap reuses frame after frame (the command keeps freed memory in its heap:
// cli/main.cpp) is not emptied again, and its huge pages stay; a block whose memory went back to
// the kernel and was mapped anew at the same address (glibc's large buffers in a program that keeps
// neither them nor its heap) is fresh, and the advice alone gives it huge pages. Only the buffers'
// interiors: the heap's small allocations keep small pages, so the resident set does not grow
// (advising the whole heap, tried, put 5-8 MB more in a night run's peak: docs/benchmarks.md
// "Twenty-sixth session: light map", with the measurements). Why: the chain's passes read and write
// several whole-frame images row by row (the light map's row pass alone: labels, depth, façade
// regions, texture, L and the composed radiance), each 4 KiB page an entry of the TLB (Zen 4: 3,072
// in its L2 TLB, 12 MiB), so every few rows of each image took a page walk; a 2 MiB page covers 512
// times as much. The advice moves no value; it is only advice, so its result is not checked. A
// photosite choice for speed.
// 4 MiB: a buffer this large holds at least one whole 2 MiB-aligned block wherever it lies.
constexpr size_t kHugePageAdviseMinBytes = size_t{1} << 22;
constexpr uintptr_t kHugePageBytes = uintptr_t{1} << 21;
void advise_huge_pages(void* p, size_t bytes) noexcept {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  if (bytes < kHugePageAdviseMinBytes) return;
  const uintptr_t a = (reinterpret_cast<uintptr_t>(p) + kHugePageBytes - 1) & ~(kHugePageBytes - 1);
  const uintptr_t b = (reinterpret_cast<uintptr_t>(p) + bytes) & ~(kHugePageBytes - 1);
  static std::mutex m;
  static std::unordered_set<uintptr_t>* seen = new std::unordered_set<uintptr_t>;  // (never destroyed: cache())
  std::lock_guard<std::mutex> lock(m);
  try {
    for (uintptr_t r = a; r < b;) {  // each run of blocks not seen before, one call per run
      if (seen->count(r)) {
        r += kHugePageBytes;
        continue;
      }
      uintptr_t e = r;
      while (e < b && !seen->count(e)) seen->insert(e), e += kHugePageBytes;
      (void)madvise(reinterpret_cast<void*>(r), e - r, MADV_DONTNEED);
      r = e;
    }
  } catch (...) {  // no memory for the set: the rest of the buffer is advised below, not emptied
  }
  (void)madvise(reinterpret_cast<void*>(a), b - a, MADV_HUGEPAGE);
#else
  (void)p;
  (void)bytes;
#endif
}

}  // namespace

FrameBufferCacheStats frame_buffer_cache_stats() {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.m);
  return {c.limit, c.min_bytes, c.held, c.order.size(), c.reused, c.allocated,
          c.free_stale, c.free_stale ? c.stale_after() : 0, c.in_use, c.peak};
}

void set_frame_buffer_cache_limit(size_t bytes) {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.m);
  c.limit = bytes;
  c.trim_to(bytes);
}

void set_frame_buffer_cache_min_bytes(size_t bytes) {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.m);
  c.min_bytes = std::max(bytes, kFrameBufferMinBytes);
  c.drop_below_min();
}

size_t frame_buffer_cache_machine_limit() {
#if defined(__linux__)
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  if (pages > 0 && page > 0) return static_cast<size_t>(pages) / 4 * static_cast<size_t>(page);
#endif
  return kFrameBufferDefaultLimit;
}

void set_frame_buffer_cache_free_stale(bool on) {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.m);
  c.free_stale = on;
  c.forgotten.clear();
  c.free_stale_buffers();
}

namespace detail {

void* frame_buffer_allocate(size_t bytes) {
  if (bytes >= kFrameBufferMinBytes) {
    Cache& c = cache();
    std::lock_guard<std::mutex> lock(c.m);
    if (bytes >= c.min_bytes) ++c.requests;  // (a size below min_bytes is never held)
    c.in_use += bytes;  // counted before it is there: a second thread sees it at once
    c.peak = std::max(c.peak, c.in_use);
    const auto it = c.by_size.find(bytes);
    if (it != c.by_size.end()) {  // the most recently freed of this size (warmest in the caches)
      const auto held_it = it->second.back();
      void* p = held_it->p;
      c.longest_wait = std::max(c.longest_wait, c.requests - held_it->freed_at);
      it->second.pop_back();
      if (it->second.empty()) c.by_size.erase(it);
      c.order.erase(held_it);
      c.held -= bytes;
      ++c.reused;
      c.free_stale_buffers();
      return p;
    }
    if (bytes >= c.min_bytes) {
      ++c.allocated;
      c.learn_wait(bytes);
    }
    c.free_stale_buffers();
  }
  void* p;
  try {
    p = ::operator new(bytes);
  } catch (...) {
    if (bytes >= kFrameBufferMinBytes) {
      Cache& c = cache();
      std::lock_guard<std::mutex> lock(c.m);
      c.in_use -= bytes;
    }
    throw;
  }
  advise_huge_pages(p, bytes);
  return p;
}

void frame_buffer_release(void* p, size_t bytes) noexcept {
  if (bytes >= kFrameBufferMinBytes) {
    Cache& c = cache();
    std::lock_guard<std::mutex> lock(c.m);
    c.in_use -= bytes;
    if (bytes <= c.limit && bytes >= c.min_bytes) {
      // Room is made by freeing the least recently freed buffers: a loop whose sizes change
      // (KITTI's frames differ by a few pixels) keeps the sizes it is using now, not stale ones.
      try {
        c.trim_to(c.limit - bytes);
        const auto held_it = c.order.insert(c.order.end(), Cache::Entry{bytes, p, c.requests});
        try {
          c.by_size[bytes].push_back(held_it);
        } catch (...) {
          c.order.erase(held_it);
          throw;
        }
        c.held += bytes;
        return;
      } catch (...) {  // no memory for the entry: free the buffer instead
      }
    }
  }
  ::operator delete(p);
}

}  // namespace detail
}  // namespace photosite
