// The cache of freed frame buffers (include/photosite/frame_buffers.h): off by default, reuse by
// exact size within its limit, and results that do not depend on what a reused buffer held.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "photosite/frame_buffers.h"
#include "photosite/image.h"
#include "photosite/scene/night.h"
#include "photosite/scene/rig.h"
#include "photosite/scene/scene_preset.h"

using namespace photosite;

namespace {
// Each test leaves the process's cache as it found it (off, in this binary).
struct CacheLimit {
  explicit CacheLimit(size_t bytes) { set_frame_buffer_cache_limit(bytes); }
  ~CacheLimit() { set_frame_buffer_cache_limit(0); }
};
bool same_bits(const ImageF& a, const ImageF& b) {
  return a.same_shape(b) && a.channels() == b.channels() &&
         std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}
}  // namespace

TEST(FrameBuffers, OffByDefaultThenReusedByExactSizeWithinTheLimit) {
  ASSERT_EQ(frame_buffer_cache_stats().limit_bytes, 0u) << "a program turns the cache on; the library does not";
  const FrameBufferCacheStats s0 = frame_buffer_cache_stats();
  { ImageF a(1024, 512, 1, 0.f); }  // 2 MiB, freed with the cache off: not held
  EXPECT_EQ(frame_buffer_cache_stats().held_bytes, 0u);

  const size_t plane = size_t{1024} * 512 * sizeof(float);  // 2 MiB
  CacheLimit on(3 * plane);
  const float* first;
  {
    ImageF a(1024, 512, 1, 0.f);
    first = a.data();
  }
  EXPECT_EQ(frame_buffer_cache_stats().held_bytes, plane);
  {
    ImageF other(512, 512, 1, 0.f);  // another size: not the held buffer
    EXPECT_NE(other.data(), first);
    ImageF b(1024, 512, 1, uninitialized);  // the same size: the held buffer
    EXPECT_EQ(b.data(), first);
  }
  FrameBufferCacheStats s = frame_buffer_cache_stats();
  EXPECT_EQ(s.reused - s0.reused, 1u);
  EXPECT_EQ(s.held_bytes, plane + plane / 2);  // b's 2 MiB and other's 1 MiB, freed into the cache
  EXPECT_EQ(s.held_buffers, 2u);
  // Five planes freed into a cache of three (holding b's plane and other's half plane): it makes
  // room by freeing what was freed longest ago, so it ends with the last three planes freed, and
  // hands out the most recently freed first.
  std::vector<const float*> freed;
  {
    std::vector<ImageF> v;
    for (int i = 0; i < 5; ++i) v.emplace_back(1024, 512, 1, 1.f);
    for (auto& im : v) freed.push_back(im.data());
  }  // destroyed in order v[0] .. v[4]
  s = frame_buffer_cache_stats();
  EXPECT_EQ(s.held_bytes, 3 * plane);
  EXPECT_EQ(s.held_buffers, 3u);  // b's plane went first (freed before other), then other's, v[0] and v[1]
  {
    ImageF c1(1024, 512, 1, uninitialized), c2(1024, 512, 1, uninitialized), c3(1024, 512, 1, uninitialized);
    EXPECT_EQ(c1.data(), freed[4]);
    EXPECT_EQ(c2.data(), freed[3]);
    EXPECT_EQ(c3.data(), freed[2]);
  }
  s = frame_buffer_cache_stats();
  { ImageU8 small(512, 512, 1, 0); }  // 256 KiB: below kFrameBufferMinBytes, never held
  EXPECT_EQ(frame_buffer_cache_stats().held_bytes, s.held_bytes);
  set_frame_buffer_cache_limit(plane);  // a lower limit frees what is held beyond it at once
  EXPECT_LE(frame_buffer_cache_stats().held_bytes, plane);
  set_frame_buffer_cache_limit(0);
  EXPECT_EQ(frame_buffer_cache_stats().held_bytes, 0u);
  EXPECT_EQ(frame_buffer_cache_stats().held_buffers, 0u);
}

// The command keeps only the buffers glibc would map afresh (cli/main.cpp: its minimum is the mmap
// threshold, 32 MiB): a size below the minimum is neither held nor counted, one at or above it is
// reused as before; raising the minimum frees the held buffers below it at once, and a minimum
// below kFrameBufferMinBytes is raised to it. Failed before the minimum existed (the 2 MiB plane
// was held).
TEST(FrameBuffers, ASmallestHeldSizeLeavesSmallerBuffersToTheAllocator) {
  ASSERT_EQ(frame_buffer_cache_stats().min_bytes, kFrameBufferMinBytes) << "the library's default";
  const size_t plane = size_t{1024} * 512 * sizeof(float);  // 2 MiB
  CacheLimit on(16 * plane);
  struct MinBytes {
    ~MinBytes() { set_frame_buffer_cache_min_bytes(kFrameBufferMinBytes); }
  } restore;
  { ImageF a(1024, 512, 1, 0.f), b(2048, 512, 1, 0.f); }  // 2 and 4 MiB, held
  FrameBufferCacheStats s = frame_buffer_cache_stats();
  EXPECT_EQ(s.held_bytes, 3 * plane);
  set_frame_buffer_cache_min_bytes(2 * plane);  // the 2 MiB buffer freed, the 4 MiB one kept
  s = frame_buffer_cache_stats();
  EXPECT_EQ(s.min_bytes, 2 * plane);
  EXPECT_EQ(s.held_bytes, 2 * plane);
  EXPECT_EQ(s.held_buffers, 1u);
  {
    ImageF small(1024, 512, 1, 0.f);  // below the minimum: from the allocator, not counted
    ImageF big(2048, 512, 1, uninitialized);  // the held 4 MiB buffer
    (void)small;
    (void)big;
  }
  const FrameBufferCacheStats t = frame_buffer_cache_stats();
  EXPECT_EQ(t.reused - s.reused, 1u);
  EXPECT_EQ(t.allocated, s.allocated);
  EXPECT_EQ(t.held_bytes, 2 * plane) << "only the 4 MiB buffer is held again";
  EXPECT_EQ(t.held_buffers, 1u);
  set_frame_buffer_cache_min_bytes(1);  // raised to kFrameBufferMinBytes
  EXPECT_EQ(frame_buffer_cache_stats().min_bytes, kFrameBufferMinBytes);
}

// A buffer taken from the cache holds its last owner's samples, where fresh memory would be
// zero pages: a stage that read a sample before writing it would give other numbers after another
// scene. Scene A alone (cache off), then B and A again with the cache on: A's radiance, light map
// and depth are the same bits, and the second A took buffers from the cache (else the check
// would not have exercised it).
TEST(FrameBuffers, ReusedBuffersDoNotChangeResults) {
  using namespace photosite::scene;
  const int W = 768, H = 384;
  auto options = [&](std::vector<SyntheticBox> boxes) {
    SyntheticCameraOptions o;
    o.width = W;
    o.height = H;
    VanishingPoint none;
    o.camera = camera_geometry(load_camera_rig("cityscapes"), W, H, none);
    o.boxes = std::move(boxes);
    return o;
  };
  const SyntheticCameraScene a = make_synthetic_camera_scene(options({{-3.5, 12, 1.8, 1.5, 4.5}, {0.0, 32, 2.5, 3.0, 10}}));
  const SyntheticCameraScene b = make_synthetic_camera_scene(
      options({{2.5, 8, 1.8, 1.5, 4.5}, {-4.0, 15, 2.2, 2.8, 8}, {3.0, 40, 1.8, 1.5, 4.5}}));
  const ScenePreset p = load_scene_preset("night-urban");
  const NightScene ref = night_scene(a.day_linear_srgb, a.labels, p, 1);

  CacheLimit on(kFrameBufferDefaultLimit);
  { const NightScene nb = night_scene(b.day_linear_srgb, b.labels, p, 1); }
  const uint64_t reused0 = frame_buffer_cache_stats().reused;
  const NightScene again = night_scene(a.day_linear_srgb, a.labels, p, 1);
  EXPECT_GT(frame_buffer_cache_stats().reused, reused0) << "scene A took no buffer from the cache";
  EXPECT_TRUE(same_bits(ref.radiance, again.radiance));
  EXPECT_TRUE(same_bits(ref.lights, again.lights));
  EXPECT_TRUE(same_bits(ref.depth, again.depth));
}

// Whole-frame buffers are advised for transparent huge pages (core/frame_buffers.cpp,
// advise_huge_pages): every whole 2 MiB-aligned block inside a new buffer of 4 MiB or more is
// marked MADV_HUGEPAGE, which the kernel shows as the "hg" flag of the mapping holding it
// (/proc/self/smaps, VmFlags; whatever THP's mode, so the test does not depend on the machine's
// setting). Filled through the image's constructor after the advice (whose MADV_DONTNEED empties
// the blocks first), the values are the fill. Skipped where the kernel has no THP (no
// /sys/kernel/mm/transparent_hugepage) or glibc advises its own mappings
// (GLIBC_TUNABLES=glibc.malloc.hugetlb: the flag would be there without photosite's advice).
// Failed before the advice (no "hg" on the frame's blocks).
namespace {
// The VmFlags of the mapping of /proc/self/smaps that holds address a ("" where none does).
std::string vm_flags_at(uintptr_t a) {
  std::ifstream f("/proc/self/smaps");
  std::string line;
  bool inside = false;
  while (std::getline(f, line)) {
    unsigned long lo = 0, hi = 0;
    if (std::sscanf(line.c_str(), "%lx-%lx ", &lo, &hi) == 2 && line.find(':') > line.find('-')) {
      inside = a >= lo && a < hi;
      continue;
    }
    if (inside && line.rfind("VmFlags:", 0) == 0) return line;
  }
  return "";
}
bool has_flag(const std::string& vm_flags, const std::string& flag) {
  std::istringstream s(vm_flags.substr(8));
  std::string f;
  while (s >> f)
    if (f == flag) return true;
  return false;
}
}  // namespace

TEST(FrameBuffers, WholeFrameBuffersAreAdvisedForHugePages) {
#if !defined(__linux__)
  GTEST_SKIP() << "SKIPPED: transparent huge pages are Linux's";
#else
  if (!std::filesystem::exists("/sys/kernel/mm/transparent_hugepage")) GTEST_SKIP() << "SKIPPED: no THP in this kernel";
  if (const char* t = std::getenv("GLIBC_TUNABLES"); t && std::strstr(t, "hugetlb"))
    GTEST_SKIP() << "SKIPPED: glibc advises its own mappings here (GLIBC_TUNABLES)";
  ASSERT_EQ(frame_buffer_cache_stats().limit_bytes, 0u);
  const uintptr_t huge = uintptr_t{1} << 21;
  const ImageF frame(2048, 1024, 3, 0.5f);  // 24 MiB
  const uintptr_t p = reinterpret_cast<uintptr_t>(frame.data());
  const uintptr_t first = (p + huge - 1) & ~(huge - 1), last = ((p + frame.size() * sizeof(float)) & ~(huge - 1)) - huge;
  ASSERT_LT(first, last);
  for (const uintptr_t block : {first, first + huge, last}) {
    const std::string flags = vm_flags_at(block);
    ASSERT_FALSE(flags.empty()) << "no mapping holds the buffer's block at " << block;
    EXPECT_TRUE(has_flag(flags, "hg")) << flags;
  }
  EXPECT_EQ(frame.at(0, 0, 0), 0.5f);
  EXPECT_EQ(frame.at(2047, 1023, 2), 0.5f);
  EXPECT_EQ(frame.at(1024, 512, 1), 0.5f);
#endif
}

// The stale rule (frame_buffers.h, set_frame_buffer_cache_free_stale): a held buffer that has
// waited more than the longest wait of a reused one and a quarter more (at least twice the floor)
// is freed. A loop of one size keeps every buffer (no loss against the plain limit); after a
// change of size the old size's buffers are freed within that horizon, while with the limit alone
// they stay; a size that comes back after longer than the horizon teaches the rule its wait.
// Failed before the rule existed (the old size's buffers were held beside the new ones, up to the
// limit).
TEST(FrameBuffers, TheStaleRuleFreesSizesNoLongerAskedFor) {
  const size_t plane = size_t{1024} * 512 * sizeof(float);  // 2 MiB
  CacheLimit on(64 * plane);
  struct Stale {
    Stale() { set_frame_buffer_cache_free_stale(true); }
    ~Stale() { set_frame_buffer_cache_free_stale(false); }
  } rule;
  const FrameBufferCacheStats s0 = frame_buffer_cache_stats();
  ASSERT_TRUE(s0.free_stale);
  ASSERT_GE(s0.stale_after_requests, 2 * kFrameBufferStaleFloorRequests);
  auto frame = [&](int w, int h, int n) {  // n images of w x h floats in use at once, then freed
    std::vector<ImageF> v;
    for (int i = 0; i < n; ++i) v.emplace_back(w, h, 1, uninitialized);
    EXPECT_EQ(frame_buffer_cache_stats().in_use_bytes - s0.in_use_bytes, n * v[0].size() * sizeof(float));
  };
  frame(1024, 512, 3);
  FrameBufferCacheStats s = frame_buffer_cache_stats();
  EXPECT_EQ(s.held_bytes, 3 * plane);
  EXPECT_GE(s.peak_bytes - s0.in_use_bytes, 3 * plane);
  // Far more frames of the same size than the horizon has requests: every buffer reused, none freed.
  const int frames = static_cast<int>(s0.stale_after_requests);
  for (int k = 0; k < frames; ++k) frame(1024, 512, 3);
  FrameBufferCacheStats t = frame_buffer_cache_stats();
  EXPECT_EQ(t.reused - s.reused, 3u * frames);
  EXPECT_EQ(t.allocated, s.allocated);
  EXPECT_EQ(t.held_bytes, 3 * plane);
  // Another size from now on (1.5 planes): its first frames hold both sizes; once the old size has
  // waited past the horizon (stale_after_requests, each frame 2 requests) it is freed.
  const uint64_t horizon = t.stale_after_requests;
  frame(1024, 768, 2);
  EXPECT_EQ(frame_buffer_cache_stats().held_bytes, 6 * plane) << "the old size is not freed at once";
  for (uint64_t k = 0; k < horizon / 2 + 1; ++k) frame(1024, 768, 2);
  t = frame_buffer_cache_stats();
  EXPECT_EQ(t.held_bytes, 3 * plane) << "the new size's two buffers, the old size's three freed";
  EXPECT_EQ(t.held_buffers, 2u);
  // A size that comes back after longer than the horizon: freed by the rule the first time, then
  // its wait is learnt and it is kept (its next return takes its buffer from the cache).
  const uint64_t gap = horizon + 10;  // requests of the other size between its returns
  frame(512, 768, 1);  // 1.5 MiB
  for (uint64_t k = 0; k < gap / 2; ++k) frame(1024, 768, 2);
  FrameBufferCacheStats u = frame_buffer_cache_stats();
  frame(512, 768, 1);
  EXPECT_EQ(frame_buffer_cache_stats().allocated - u.allocated, 1u) << "freed by the rule: a new buffer";
  EXPECT_GT(frame_buffer_cache_stats().stale_after_requests, gap) << "the wait learnt";
  for (uint64_t k = 0; k < gap / 2; ++k) frame(1024, 768, 2);
  u = frame_buffer_cache_stats();
  frame(512, 768, 1);
  EXPECT_EQ(frame_buffer_cache_stats().allocated, u.allocated) << "kept: its buffer from the cache";
  // The limit still caps what is held.
  set_frame_buffer_cache_limit(plane);
  EXPECT_LE(frame_buffer_cache_stats().held_bytes, plane);
  set_frame_buffer_cache_limit(64 * plane);
  // Off: the old size's buffers stay beside the new (the plain limit alone), however long.
  set_frame_buffer_cache_free_stale(false);
  EXPECT_EQ(frame_buffer_cache_stats().stale_after_requests, 0u);
  set_frame_buffer_cache_limit(0);
  set_frame_buffer_cache_limit(64 * plane);
  frame(1024, 512, 3);
  for (uint64_t k = 0; k < horizon; ++k) frame(1024, 768, 2);
  EXPECT_EQ(frame_buffer_cache_stats().held_bytes, 6 * plane);
}
