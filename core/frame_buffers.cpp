// The cache of freed whole-frame buffers (include/photosite/frame_buffers.h).
#include "photosite/frame_buffers.h"

#include <pthread.h>

#include <mutex>
#include <new>
#include <unordered_map>
#include <vector>

namespace photosite {
namespace {

struct Cache {
  std::mutex m;
  size_t limit = 0, held = 0, blocks = 0;
  uint64_t reused = 0, allocated = 0;
  std::unordered_map<size_t, std::vector<void*>> by_size;  // most recently freed last

  // Frees held buffers until at most `target` bytes remain (under the lock).
  void trim_to(size_t target) {
    for (auto it = by_size.begin(); held > target && it != by_size.end();) {
      auto& v = it->second;
      while (held > target && !v.empty()) {
        ::operator delete(v.front());  // the oldest of this size first
        v.erase(v.begin());
        held -= it->first;
        --blocks;
      }
      it = v.empty() ? by_size.erase(it) : std::next(it);
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

}  // namespace

FrameBufferCacheStats frame_buffer_cache_stats() {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.m);
  return {c.limit, c.held, c.blocks, c.reused, c.allocated};
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
    if (it != c.by_size.end() && !it->second.empty()) {
      void* p = it->second.back();
      it->second.pop_back();
      c.held -= bytes;
      --c.blocks;
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
    if (c.held + bytes <= c.limit) {
      try {
        c.by_size[bytes].push_back(p);
        c.held += bytes;
        ++c.blocks;
        return;
      } catch (...) {  // no memory for the entry: free the buffer instead
      }
    }
  }
  ::operator delete(p);
}

}  // namespace detail
}  // namespace photosite
