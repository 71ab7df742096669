// A cache of freed whole-frame sample buffers, for programs that run the chain frame after frame
// in a process whose allocator they do not own (the Python module, another program linking
// libphotosite).
//
// Why: a 2048x1024 night frame allocates and frees about 100 MB of full-resolution images. glibc's
// malloc serves buffers this large by mmap or returns them to the kernel when they are freed at
// the top of the heap (M_TRIM_THRESHOLD), so the next frame's buffers are fresh pages: every page
// is faulted in and zeroed by the kernel again (measured on a 2-core VM: 26,600 page faults and
// about 90 ms of system time per `ps.night` call, docs/python.md). The command owns its process
// and changes malloc's thresholds instead (cli/main.cpp, docs/robustness.md); a library loaded
// into someone else's process must not, so it keeps its own freed buffers.
//
// What: Image buffers (include/photosite/image.h) of at least kFrameBufferMinBytes go, when freed,
// into a cache keyed by their exact size in bytes; an allocation of that exact size takes the most
// recently freed one. The cache holds at most its limit: to make room it frees the buffers freed
// longest ago, so a loop whose sizes change keeps the sizes it uses now. A video or data-set loop
// asks for the same sizes every frame, so after the first frame its buffers come from the cache. The
// contents of a reused buffer are whatever its last owner left: Image fills it when asked to, and
// an Image made `uninitialized` is written in full before it is read, as with fresh memory (test
// FrameBuffers.ReusedBuffersDoNotChangeResults, tests/python/test_api.py).
//
// The limit is 0 (no cache) until a program sets it: the Python module sets kFrameBufferDefaultLimit
// when it is imported (`photosite.frame_buffer_cache()` reads and changes it). Thread-safe.
#pragma once
#include <cstddef>
#include <cstdint>

namespace photosite {

inline constexpr size_t kFrameBufferMinBytes = size_t{1} << 20;       // 1 MiB: smaller ones stay with malloc
// 512 MiB: a 2048x1024 night frame's freed buffers are 220 MB (`ps.night` then `del`, measured).
inline constexpr size_t kFrameBufferDefaultLimit = size_t{1} << 29;

struct FrameBufferCacheStats {
  size_t limit_bytes = 0;  // the most the cache holds
  size_t min_bytes = kFrameBufferMinBytes;  // the smallest buffer it holds
  size_t held_bytes = 0;   // freed buffers held now
  size_t held_buffers = 0;
  uint64_t reused = 0;     // allocations of at least kFrameBufferMinBytes served from the cache
  uint64_t allocated = 0;  // ... and those of at least min_bytes that went to the allocator
};

FrameBufferCacheStats frame_buffer_cache_stats();
// Sets the limit; buffers held beyond it are freed at once (0 frees them all and turns the cache off).
void set_frame_buffer_cache_limit(size_t bytes);
// Sets the smallest buffer the cache holds (at least kFrameBufferMinBytes; smaller values are
// raised to it); held buffers below it are freed at once. The command sets it to glibc's mmap
// threshold (cli/main.cpp): smaller buffers stay in its heap, which it keeps, and the cache takes
// only those glibc would map afresh and unmap on every free.
void set_frame_buffer_cache_min_bytes(size_t bytes);

namespace detail {
// The allocation and release of Image buffers (DefaultInitAllocator). `bytes` is the buffer's
// exact size; memory comes from and goes back to ::operator new / ::operator delete.
void* frame_buffer_allocate(size_t bytes);
void frame_buffer_release(void* p, size_t bytes) noexcept;
}  // namespace detail

}  // namespace photosite
