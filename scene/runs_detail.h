// Private (not installed): the end of a run of equal 16-bit labels (or 32-bit region numbers), shared by the stages that walk
// label images run by run (scene/geometry.cpp, scene/darken.cpp); and the connected components
// of a byte mask by its runs (scene/facade_windows.cpp, scene/lanes.cpp).
#pragma once
#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <type_traits>
#include <vector>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace photosite::scene {

// The end of the run of values equal to p[x] in p[x..limit): the first index whose value differs,
// or limit. For 16- and 32-bit values: with SSE2 (every x86-64), sixteen bytes of them at a time
// by a lane compare (the first differing lane from the lowest clear bit of the byte mask);
// elsewhere eight bytes at a time as one 64-bit word (the first differing lane from the lowest
// set bit of the XOR, on little-endian machines); the rest one at a time.
template <class T, class Index>
inline Index run_end(const T* p, Index x, Index limit) {
  static_assert(sizeof(T) == 2 || sizeof(T) == 4);
  const T v = p[x];
  Index e = x + 1;
#if defined(__SSE2__)
  constexpr int lanes = 16 / sizeof(T);
  const __m128i vv = sizeof(T) == 2 ? _mm_set1_epi16(static_cast<short>(v)) : _mm_set1_epi32(static_cast<int>(v));
  for (; e + lanes <= limit; e += lanes) {
    const __m128i w = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p + e));
    const int eq = _mm_movemask_epi8(sizeof(T) == 2 ? _mm_cmpeq_epi16(w, vv) : _mm_cmpeq_epi32(w, vv));
    if (eq != 0xffff) return e + static_cast<Index>(std::countr_zero(static_cast<unsigned>(~eq)) / sizeof(T));
  }
#else
  if constexpr (std::endian::native == std::endian::little) {
    constexpr int lanes = 8 / sizeof(T);
    using U = std::conditional_t<sizeof(T) == 2, uint16_t, uint32_t>;
    const uint64_t vv = static_cast<U>(v) * (sizeof(T) == 2 ? 0x0001000100010001ull : 0x0000000100000001ull);
    for (; e + lanes <= limit; e += lanes) {
      uint64_t w;
      std::memcpy(&w, p + e, sizeof w);
      if (const uint64_t d = w ^ vv) return e + static_cast<Index>(std::countr_zero(d) / (8 * sizeof(T)));
    }
  }
#endif
  while (e < limit && p[e] == v) ++e;
  return e;
}

// The connected components of a w x h byte mask (nonzero: set, rows of w bytes) by its horizontal
// runs, for sparse masks where a pass over a label image per pixel costs more than the runs: the
// runs in raster order (so a run's index is the raster order of its first cell), each joined
// (union-find) to every run of the row above that touches it: sharing a column (4-connected) or,
// with `diagonal`, also only a corner (8-connected). A union keeps the smaller index as the root,
// so each component's root is its first run; `root` holds it for every run.
struct MaskRun {
  int x0, x1, y;  // cells x0 .. x1 − 1 of row y
  int root;
};
inline std::vector<MaskRun> mask_runs(const uint8_t* mask, int w, int h, bool diagonal) {
  std::vector<MaskRun> runs;
  auto find = [&](int r) {
    while (runs[r].root != r) r = runs[r].root = runs[runs[r].root].root;
    return r;
  };
  const int corner = diagonal ? 1 : 0;
  size_t above0 = 0, above1 = 0;  // the row above's runs
  for (int y = 0; y < h; ++y) {
    const uint8_t* m = mask + static_cast<size_t>(y) * w;
    const size_t here0 = runs.size();
    size_t a = above0;
    for (int x = 0; x < w;) {
      x = static_cast<int>(std::find_if(m + x, m + w, [](uint8_t v) { return v != 0; }) - m);
      if (x == w) break;
      const int x0 = x;
      while (x < w && m[x]) ++x;
      const int me = static_cast<int>(runs.size());
      runs.push_back({x0, x, y, me});
      // The runs above that end before x0 (before x0 − 1 with corners) are passed for good: the
      // next run of this row starts after x. Those left touch this run while they start before
      // x (at x with corners).
      while (a < above1 && runs[a].x1 + corner <= x0) ++a;
      for (size_t b = a; b < above1 && runs[b].x0 < x + corner; ++b) {
        const int ra = find(static_cast<int>(b)), rb = find(me);
        if (ra < rb) runs[rb].root = ra;
        else if (rb < ra) runs[ra].root = rb;
      }
    }
    above0 = here0;
    above1 = runs.size();
  }
  for (size_t r = 0; r < runs.size(); ++r) runs[r].root = find(static_cast<int>(r));
  return runs;
}

}  // namespace photosite::scene
