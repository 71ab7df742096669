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
// The stale rule (set_frame_buffer_cache_free_stale): a held buffer that has waited longer than
// the longest wait of any buffer reused so far and a quarter more (at least twice
// kFrameBufferStaleFloorRequests) is freed. Waits are counted in the program's requests for
// buffers of at least the smallest held size, not in seconds, so a pause between frames ages
// nothing. A loop over frames of one size reuses each buffer within about one frame's requests, so
// the rule frees none of them; where the sizes change (KITTI's frames differ by a few pixels, a
// data set of mixed resolutions) the sizes it no longer asks for are freed a few frames later,
// instead of staying until the limit needs room. A size the rule freed and the program then asks
// for again (one that comes back every few frames) teaches the rule that wait, so its buffers are
// kept from then on. The limit still caps what is held.
//
// The limit is 0 (no cache) and the stale rule off until a program sets them: the command sets
// frame_buffer_cache_machine_limit() and the stale rule, the Python module, when it is imported,
// the smaller of that and kFrameBufferDefaultLimit and the stale rule (`photosite.frame_buffer_cache()`
// reads and changes both). Thread-safe.
#pragma once
#include <cstddef>
#include <cstdint>

namespace photosite {

inline constexpr size_t kFrameBufferMinBytes = size_t{1} << 20;       // 1 MiB: smaller ones stay with malloc
// 1 GiB: the Python module's limit, at most a quarter of the machine's memory. A 2048x1024 night
// frame frees 220 MB of these buffers, a 4096x2048 one 778 MB (`ps.night` then `del`, measured:
// docs/python.md); each of a data loader's worker processes holds its own cache, so the limit is
// per process and kept well below the machine's memory.
inline constexpr size_t kFrameBufferDefaultLimit = size_t{1} << 30;
// A quarter of the machine's physical memory (sysconf; kFrameBufferDefaultLimit where that is
// unknown): the command's limit (one process per run; with the stale rule it holds the sizes a run
// keeps asking for, such as an 8192x4096 frame's, and frees the others).
size_t frame_buffer_cache_machine_limit();
// The stale rule's least wait, in requests, before it has seen any: small, so that sizes no longer
// asked for go within a few frames whatever the frame's count of requests (a 2048x1024 night frame
// asks for 27 buffers of 1 MiB or more, `ps.night` counted with ps.frame_buffer_cache(); the
// command's buffers of 32 MiB and more are fewer). The cost: in the second frame a buffer that
// waited longer than twice this is freed before its reuse, and its size's next request teaches the
// rule that wait (measured in docs/benchmarks.md, "Fifty-fourth session").
inline constexpr uint64_t kFrameBufferStaleFloorRequests = 8;

struct FrameBufferCacheStats {
  size_t limit_bytes = 0;  // the most the cache holds
  size_t min_bytes = kFrameBufferMinBytes;  // the smallest buffer it holds
  size_t held_bytes = 0;   // freed buffers held now
  size_t held_buffers = 0;
  uint64_t reused = 0;     // allocations of at least kFrameBufferMinBytes served from the cache
  uint64_t allocated = 0;  // ... and those of at least min_bytes that went to the allocator
  bool free_stale = false;         // the stale rule above
  uint64_t stale_after_requests = 0;  // under it, the most requests a held buffer waits (0: off)
  size_t in_use_bytes = 0;   // buffers of at least kFrameBufferMinBytes allocated and not yet freed
  size_t peak_bytes = 0;     // the most of those in use at once since the process started
};

FrameBufferCacheStats frame_buffer_cache_stats();
// Sets the limit; buffers held beyond it are freed at once (0 frees them all and turns the cache off).
void set_frame_buffer_cache_limit(size_t bytes);
// Sets the smallest buffer the cache holds (at least kFrameBufferMinBytes; smaller values are
// raised to it); held buffers below it are freed at once. The command sets it to glibc's mmap
// threshold (cli/main.cpp): smaller buffers stay in its heap, which it keeps, and the cache takes
// only those glibc would map afresh and unmap on every free.
void set_frame_buffer_cache_min_bytes(size_t bytes);
// Turns the stale rule (above) on or off.
void set_frame_buffer_cache_free_stale(bool on);

namespace detail {
// The allocation and release of Image buffers (DefaultInitAllocator). `bytes` is the buffer's
// exact size; memory comes from and goes back to ::operator new / ::operator delete.
void* frame_buffer_allocate(size_t bytes);
void frame_buffer_release(void* p, size_t bytes) noexcept;
}  // namespace detail

}  // namespace photosite
