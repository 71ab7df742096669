// The cache of freed whole-frame buffers (include/photosite/frame_buffers.h).
#include "photosite/frame_buffers.h"

#include <pthread.h>

#include <list>
#include <mutex>
#include <new>
#include <unordered_map>
#include <vector>

namespace photosite {
namespace {

struct Cache {
  using Held = std::list<std::pair<size_t, void*>>;  // (bytes, buffer), the least recently freed first
  std::mutex m;
  size_t limit = 0, held = 0;
  uint64_t reused = 0, allocated = 0;
  Held order;
  // Per size, its buffers in `order`, the most recently freed last.
  std::unordered_map<size_t, std::vector<Held::iterator>> by_size;

  // Frees the least recently freed buffer (under the lock). Per size the buffers stand in `order`
  // in the order of their vector, so the list's first is its size's first.
  void evict_oldest() {
    const auto [bytes, p] = order.front();
    auto it = by_size.find(bytes);
    it->second.erase(it->second.begin());
    if (it->second.empty()) by_size.erase(it);
    order.pop_front();
    held -= bytes;
    ::operator delete(p);
  }
  void trim_to(size_t target) {
    while (held > target) evict_oldest();
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

}  // namespace

FrameBufferCacheStats frame_buffer_cache_stats() {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.m);
  return {c.limit, c.held, c.order.size(), c.reused, c.allocated};
}

void set_frame_buffer_cache_limit(size_t bytes) {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.m);
  c.limit = bytes;
  c.trim_to(bytes);
}

namespace detail {

void* frame_buffer_allocate(size_t bytes) {
  if (bytes >= kFrameBufferMinBytes) {
    Cache& c = cache();
    std::lock_guard<std::mutex> lock(c.m);
    const auto it = c.by_size.find(bytes);
    if (it != c.by_size.end()) {  // the most recently freed of this size (warmest in the caches)
      const auto held_it = it->second.back();
      void* p = held_it->second;
      it->second.pop_back();
      if (it->second.empty()) c.by_size.erase(it);
      c.order.erase(held_it);
      c.held -= bytes;
      ++c.reused;
      return p;
    }
    ++c.allocated;
  }
  return ::operator new(bytes);
}

void frame_buffer_release(void* p, size_t bytes) noexcept {
  if (bytes >= kFrameBufferMinBytes) {
    Cache& c = cache();
    std::lock_guard<std::mutex> lock(c.m);
    if (bytes <= c.limit) {
      // Room is made by freeing the least recently freed buffers: a loop whose sizes change
      // (KITTI's frames differ by a few pixels) keeps the sizes it is using now, not stale ones.
      try {
        c.trim_to(c.limit - bytes);
        const auto held_it = c.order.emplace(c.order.end(), bytes, p);
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
