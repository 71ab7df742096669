// The sensor's fast paths held to their definitions, bit for bit, at 1, 2 and 3 threads:
//  * the block Philox words on every path this CPU has (scalar, AVX2, AVX-512) against
//    rng.h's scalar random_words(), and the Poisson draws of poisson_fill on each path;
//  * the lens-glare pyramid (sensor/glare.cpp: level 1 made row by row inside the first
//    (1,3,3,1) step, row passes and row blurs kept in per-thread rings, images reused from a
//    per-thread workspace) against a direct whole-image transcription of its definition
//    (include/photosite/sensor/glare.h), one pass per step, no threads, no rings, fresh images;
//  * the photon stage with the glare's mix fused into its row loop (sensor/pipeline.cpp,
//    glared_electrons_row) against the glared image made whole (the definition: keep·L +
//    s_c·bilinear(acc_1), glare_mix per sample) and then the photon stage without glare, and
//    expose() against sense() of that;
//  * the sense stage's analog row (detail::analog_row: AVX-512 8 pixels a step where the CPU has
//    it) against sense_electrons and sense_raw_dn applied pixel by pixel.
#include <gtest/gtest.h>
#include <omp.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <limits>
#include <string>
#include <vector>

#include <unistd.h>

#include "core/isa_detail.h"
#include "photosite/rng.h"
#include "photosite/sensor/glare.h"
#include "photosite/sensor/pipeline.h"
#include "photosite/sensor/poisson.h"
#include "photosite/sensor/preset.h"
#include "sensor/glare_detail.h"
#include "sensor/pixel_detail.h"
#include "sensor/poisson_detail.h"

namespace photosite {
namespace {

// Runs f at 1, 2 and 3 OpenMP threads, restoring the count after.
template <class F>
void at_thread_counts(F&& f) {
  const int saved = omp_get_max_threads();
  for (int t : {1, 2, 3}) {
    omp_set_num_threads(t);
    f(t);
  }
  omp_set_num_threads(saved);
}

std::vector<detail::PhiloxPath> cpu_paths() {
  std::vector<detail::PhiloxPath> p;
  for (int i = 0; i <= static_cast<int>(detail::best_philox_path()); ++i) p.push_back(static_cast<detail::PhiloxPath>(i));
  return p;
}

// Every path's words are random_words()'s, over lengths that leave every tail (AVX2's runs of
// four interleaved vectors, 16, 8, scalar) and ranges that cross a 2^32 pixel boundary (where
// the vector paths fall back; from 2^32 - 45 the AVX2 path runs one block of four, then single
// vectors, then the scalar tail), for keys,
// frames and streams whose words have high and low bits set (the vector paths make the round
// keys and the first round's product of the frame once per call).
TEST(Philox, BlockWordsEqualScalarOnEveryPath) {
  std::printf("Philox paths on this CPU: %zu (0 scalar, 1 AVX2, 2 AVX-512)\n", cpu_paths().size());
  struct Counter {
    uint64_t key;
    uint32_t frame, stream;
  };
  for (const Counter c : {Counter{0x1234567890abcdefull, 9, 300}, Counter{0, 0, 0},
                          Counter{0xffffffffffffffffull, 0xffffffffu, 0xffffffffu},
                          Counter{0x8000000180000001ull, 0x80000001u, 0x7fffffffu}})
    for (const auto path : cpu_paths())
      for (const uint64_t first : {uint64_t{0}, uint64_t{777}, (uint64_t{1} << 32) - 21, (uint64_t{1} << 32) - 45})
        for (const int n : {1, 7, 8, 15, 16, 17, 31, 32, 33, 40, 63, 64, 65, 100, 256}) {
          std::vector<uint32_t> w(4 * 256);
          detail::philox_block_words(path, c.key, c.frame, first, c.stream, n, w.data(), w.data() + 256,
                                     w.data() + 512, w.data() + 768);
          for (int j = 0; j < n; ++j) {
            const auto want = random_words(c.key, c.frame, first + j, static_cast<Stream>(c.stream));
            for (int k = 0; k < 4; ++k)
              ASSERT_EQ(w[256 * k + j], want[k]) << "path " << static_cast<int>(path) << " pixel " << first + j
                                                 << " key " << c.key << " frame " << c.frame;
          }
        }
}

// The sampler's draws (exact and cornish-fisher) do not depend on the Philox path or the
// thread count: means over every regime (0, inversion, PTRS with retries near 10, large).
TEST(Philox, PoissonDrawsEqualOnEveryPathAndThreadCount) {
  const int n = 40000;
  std::vector<float> mean(n);
  for (int i = 0; i < n; ++i) mean[i] = i % 11 == 0 ? 0.f : static_cast<float>(0.05 * std::pow(2e5, (i % 4000) / 4000.0));
  const uint64_t first = (uint64_t{1} << 32) - 5000;
  for (const auto method : {PoissonMethod::Exact, PoissonMethod::CornishFisher}) {
    std::vector<float> ref(n);
    const auto saved = detail::set_philox_path(detail::PhiloxPath::Scalar);
    poisson_fill(mean.data(), ref.data(), n, first, 31, 2, 1, method);
    for (const auto path : cpu_paths())
      at_thread_counts([&](int t) {
        detail::set_philox_path(path);
        std::vector<float> out(n);
        poisson_fill(mean.data(), out.data(), n, first, 31, 2, 1, method);
        EXPECT_EQ(0, std::memcmp(out.data(), ref.data(), n * sizeof(float)))
            << "path " << static_cast<int>(path) << ", " << t << " threads, " << to_string(method);
      });
    detail::set_philox_path(saved);
  }
}

// The sampler's lane packing (sensor/poisson.cpp, pack_lanes: AVX-512 compresses on that path,
// index selection and gathers on the others) and its block passes, held to the per-pixel
// definition: ptrs_sample for mean >= 10, poisson_inversion below, 0 for zero, negative and NaN
// means, and the read-noise normal normal_from_words_f(w2, w3), on every path, at 1, 2 and 3
// threads (poisson_fill splits into chunks of 4096), and at sizes that end inside a 16-lane
// group, a block (2048 pixels) or a chunk. Means: runs of dark, lit and mixed pixels, lit near
// 10 where PTRS retries most, so every packed pass (undecided, rejected, retried twice, the lit
// lanes of a mostly dark block, the dark lanes of any block) has lanes.
TEST(Philox, PoissonBlockEqualsPerPixelDefinitionOnEveryPathAtOddSizes) {
  const int n_max = 9000;
  std::vector<float> mean(n_max);
  for (int i = 0; i < n_max; ++i) {
    const auto r = random_words(4242, 0, static_cast<uint64_t>(i), Stream::Test);  // deterministic test data
    const int kind = (i / 700) % 4;  // 0: all dark, 1: all lit, 2: half lit, 3: one in eight lit
    const bool lit = kind == 1 || (kind >= 2 && (r[1] & (kind == 2 ? 1u : 7u)) == 0);
    const double u = uniform_open(r[0]);
    mean[i] = lit ? static_cast<float>(10.0 + 40.0 * u * u) : static_cast<float>(10.0 * u);
    if (!lit && i % 89 == 0) mean[i] = i % 2 ? -1.f : (i % 3 ? 0.f : std::numeric_limits<float>::quiet_NaN());
  }
  const uint64_t first = (uint64_t{1} << 32) - 3001, key = 0x5eed;
  const uint32_t frame = 3, stream = 1;
  std::vector<float> want(n_max), want_z(n_max);
  int retried = 0;
  for (int i = 0; i < n_max; ++i) {
    const auto w = random_words(key, frame, first + i, static_cast<Stream>(stream));
    if (mean[i] >= 10.f) {
      want[i] = detail::ptrs_sample(mean[i], w[0], w[1], key, frame, first + i, stream);
      retried += detail::ptrs_attempt(detail::ptrs_setup(mean[i]), w[0], w[1]) < 0.f;
    } else {
      want[i] = mean[i] > 0.f ? detail::poisson_inversion(mean[i], w[0]) : 0.f;
    }
    want_z[i] = detail::normal_from_words_f(w[2], w[3]);
  }
  ASSERT_GT(retried, 100);
  const auto saved = detail::set_philox_path(detail::PhiloxPath::Scalar);
  for (const auto path : cpu_paths()) {
    detail::set_philox_path(path);
    for (const int n : {1, 15, 17, 333, 1023, 1025, 2047, 2049, 4097, n_max}) {
      std::vector<float> out(n), z(n);
      poisson_block(mean.data(), out.data(), z.data(), n, first, key, frame, stream, PoissonMethod::Exact);
      for (int i = 0; i < n; ++i) {
        ASSERT_EQ(out[i], want[i]) << "path " << static_cast<int>(path) << " n " << n << " pixel " << i << " mean " << mean[i];
        ASSERT_EQ(z[i], want_z[i]) << "path " << static_cast<int>(path) << " n " << n << " pixel " << i;
      }
    }
    at_thread_counts([&](int t) {
      for (const int n : {4097, n_max}) {
        std::vector<float> out(n);
        poisson_fill(mean.data(), out.data(), n, first, key, frame, stream, PoissonMethod::Exact);
        EXPECT_EQ(0, std::memcmp(out.data(), want.data(), n * sizeof(float)))
            << "path " << static_cast<int>(path) << ", " << t << " threads, n " << n;
      }
    });
  }
  detail::set_philox_path(saved);
}

// The sampler's lane packing (pack_lanes: AVX-512 compresses; AVX2 the left-packing permutations
// of a 2 KB byte table, widened by vpmovzxbd; on the scalar path select_lanes' indices, by the same
// table where the CPU has AVX2, and a gather) keeps the lanes whose flag is non-zero, in order, and
// their values, on every Philox path (the PHOTOSITE_MAX_ISA caps), at counts that end inside a
// group of 8 and of 16 lanes. Every one of the 256 masks of 8 lanes occurs twice (group g's mask
// is 37g + ⌊g/256⌋ mod 256: 37 is odd, so g ↦ 37g mod 256 runs through all 256); negative zero is
// not kept, NaN is (the scalar definition keep[i] != 0).
TEST(Philox, PackLanesKeepTheFlaggedLanesInOrderOnEveryPath) {
  const int n_max = 8 * 256 * 2 + 13;
  std::vector<float> keep(n_max), src(n_max);
  for (int i = 0; i < n_max; ++i) {
    const int group = i / 8, lane = i % 8, mask = (group * 37 + group / 256) % 256;  // every mask, shifted
    keep[i] = mask >> lane & 1 ? (i % 3 == 0 ? std::numeric_limits<float>::quiet_NaN() : 1.f + i) : (i % 5 ? 0.f : -0.f);
    src[i] = 0.25f * static_cast<float>(i) - 100.f;
  }
  const auto saved = detail::set_philox_path(detail::PhiloxPath::Scalar);
  for (const auto path : cpu_paths()) {
    detail::set_philox_path(path);
    for (const int m : {1, 7, 8, 9, 15, 16, 17, 255, 2048, n_max}) {
      std::vector<int> idx(m + detail::kPackLanesRoom, -1);
      std::vector<float> dst(m + detail::kPackLanesRoom, -1.f);
      const int n = detail::pack_lanes_for_test(keep.data(), m, idx.data(), src.data(), dst.data());
      int j = 0;
      for (int i = 0; i < m; ++i) {
        if (keep[i] == 0.f) continue;
        ASSERT_LT(j, n) << "path " << static_cast<int>(path) << " m " << m;
        ASSERT_EQ(idx[j], i) << "path " << static_cast<int>(path) << " m " << m << " kept lane " << j;
        ASSERT_EQ(dst[j], src[i]) << "path " << static_cast<int>(path) << " m " << m << " kept lane " << j;
        ++j;
      }
      EXPECT_EQ(n, j) << "path " << static_cast<int>(path) << " m " << m;
    }
  }
  detail::set_philox_path(saved);
}

// The sampler's retry attempts (ptrs_attempt_lanes with the squeeze first: the full test only
// on the lanes the squeeze left undecided, compacted) equal the definition (ptrs_attempt on
// every lane, the full test evaluated everywhere) and ptrs_attempt lane by lane, bit for bit: at
// lane counts from one vector to a whole block, means from 10 (where PTRS rejects most) to 2e6,
// with the words of retry streams, on every Philox path (pack_lanes' compaction differs by path).
// Each verdict occurs: accepted by the squeeze, accepted and rejected by the full test, rejected
// outright.
TEST(Philox, PtrsAttemptsEqualTheirDefinition) {
  const int n_max = 1024;
  std::vector<float> mu(n_max);
  std::vector<uint32_t> wu(n_max), wv(n_max);
  for (int i = 0; i < n_max; ++i) {
    const auto r = random_words(606, 0, static_cast<uint64_t>(i), Stream::Test);  // deterministic test data
    const double u = uniform_open(r[0]);
    mu[i] = static_cast<float>(i % 3 == 0 ? 10.0 + 5.0 * u : 10.0 * std::pow(2e5, u));
    wu[i] = r[1];
    wv[i] = r[2];
  }
  int squeezed = 0, full_accepted = 0, full_rejected = 0, rejected = 0;
  std::vector<float> want(n_max);
  for (int i = 0; i < n_max; ++i) {
    const detail::PtrsSetup st = detail::ptrs_setup(mu[i]);
    want[i] = detail::ptrs_attempt(st, wu[i], wv[i]);
    const detail::PtrsCandidate c = detail::ptrs_candidate(st, wu[i], wv[i]);
    squeezed += c.verdict == 1.f;
    rejected += c.verdict == -1.f;
    if (c.verdict == 0.f) (want[i] < 0.f ? full_rejected : full_accepted) += 1;
  }
  EXPECT_GT(squeezed, 0);
  EXPECT_GT(full_accepted, 0);
  EXPECT_GT(full_rejected, 0);
  EXPECT_GT(rejected, 0);
  const auto saved = detail::set_philox_path(detail::PhiloxPath::Scalar);
  for (const auto path : cpu_paths()) {
    detail::set_philox_path(path);
    for (const int m : {8, 16, 24, 136, 1000, n_max}) {
      for (const bool squeeze_first : {true, false}) {
        std::vector<float> k(m, 7.f);
        detail::ptrs_attempt_lanes(squeeze_first, mu.data(), wu.data(), wv.data(), k.data(), m);
        EXPECT_EQ(0, std::memcmp(k.data(), want.data(), m * sizeof(float)))
            << "path " << static_cast<int>(path) << " m " << m << " squeeze first " << squeeze_first;
      }
    }
  }
  detail::set_philox_path(saved);
}

// fast_cos_2pi (kernels/common/fastmath.glsl) folds u = |v − round(v)| in [0, ½] to
// min(u, ½ − u), which replaced the select flip ? ½ − u : u (flip = u > ¼) that GCC vectorized
// as two polynomials. Held bit for bit to the function as it was (its select, its Taylor
// polynomial to x¹², sign by flip: transcribed here as the reference) on every input of the
// read-noise normal (v on the 2^-24 grid of normal_from_words_f: all 2^24 of them) and on two
// million other floats of [0, 1); the vectorized normals equal the scalar ones
// (Philox.PoissonBlockEqualsPerPixelDefinitionOnEveryPathAtOddSizes).
float cos_2pi_with_select(float v) {
  float u = std::fabs(v - std::floor(v + 0.5f));
  const bool flip = u > 0.25f;
  u = flip ? 0.5f - u : u;
  const float x = 6.28318531f * u, x2 = x * x;
  const float c = 1.0f + x2 * (-0.5f + x2 * (4.16666667e-2f + x2 * (-1.38888889e-3f + x2 * (2.48015873e-5f +
                  x2 * (-2.75573192e-7f + x2 * 2.08767570e-9f)))));
  return flip ? -c : c;
}
TEST(FastMath, CosFoldByMinEqualsTheSelectItReplaced) {
  auto bits = [](float f) {
    uint32_t b;
    std::memcpy(&b, &f, 4);
    return b;
  };
  int64_t bad = 0;
  auto check = [&](float v) { bad += bits(detail::fast_cos_2pi(v)) != bits(cos_2pi_with_select(v)); };
  for (uint32_t j = 0; j < (1u << 24); ++j) check(static_cast<float>(j) * 5.9604644775390625e-8f);
  for (uint64_t i = 0; i < 1000000; ++i) {
    const auto r = random_words(77, 0, i, Stream::Test);
    for (const uint32_t w : {r[0], r[1]}) {
      const float v = static_cast<float>(w >> 8) * 5.9604644775390625e-8f + static_cast<float>(w & 0xffu) * 0x1p-32f;
      check(v < 1.f ? v : 0.f);
    }
  }
  EXPECT_EQ(bad, 0);
}

// ---- the glare pyramid's definition, transcribed whole-image (glare.h; kernels/common/glare.glsl) ----
using shader::glare_lerp;
using shader::glare_mirror;
using shader::glare_up_tap;

ImageF ref_down2(const ImageF& s) {
  const int w = s.width(), h = s.height(), w2 = (w + 1) / 2, h2 = (h + 1) / 2;
  ImageF d(w2, h2, 3);
  for (int y = 0; y < h2; ++y)
    for (int x = 0; x < w2; ++x)
      for (int c = 0; c < 3; ++c) {
        const int x1 = std::min(2 * x + 1, w - 1), y1 = std::min(2 * y + 1, h - 1);
        d.at(x, y, c) = ((s.at(2 * x, 2 * y, c) + s.at(x1, 2 * y, c)) + (s.at(2 * x, y1, c) + s.at(x1, y1, c))) * 0.25f;
      }
  return d;
}
float taps1331(float a, float b, float c, float d) { return (0.125f * a + 0.375f * b) + (0.375f * c + 0.125f * d); }
ImageF ref_down1331(const ImageF& s) {
  const int w = s.width(), h = s.height(), w2 = (w + 1) / 2, h2 = (h + 1) / 2;
  ImageF t(w2, h, 3), d(w2, h2, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w2; ++x)
      for (int c = 0; c < 3; ++c)
        t.at(x, y, c) = taps1331(s.at(glare_mirror(2 * x - 1, w), y, c), s.at(glare_mirror(2 * x, w), y, c),
                                 s.at(glare_mirror(2 * x + 1, w), y, c), s.at(glare_mirror(2 * x + 2, w), y, c));
  for (int y = 0; y < h2; ++y)
    for (int x = 0; x < w2; ++x)
      for (int c = 0; c < 3; ++c)
        d.at(x, y, c) = taps1331(t.at(x, glare_mirror(2 * y - 1, h), c), t.at(x, glare_mirror(2 * y, h), c),
                                 t.at(x, glare_mirror(2 * y + 1, h), c), t.at(x, glare_mirror(2 * y + 2, h), c));
  return d;
}
// Bilinear 2x upsampling of c to w x h: vertical interpolation first, then horizontal.
ImageF ref_up(const ImageF& c, int w, int h) {
  const int cw = c.width(), ch = c.height();
  ImageF v(cw, h, 3), u(w, h, 3);
  for (int y = 0; y < h; ++y) {
    const auto ty = glare_up_tap(y, ch);
    for (int x = 0; x < cw; ++x)
      for (int k = 0; k < 3; ++k) v.at(x, y, k) = glare_lerp(ty.w0, c.at(x, ty.i0, k), ty.w1, c.at(x, ty.i1, k));
  }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const auto tx = glare_up_tap(x, cw);
      for (int k = 0; k < 3; ++k) u.at(x, y, k) = glare_lerp(tx.w0, v.at(tx.i0, y, k), tx.w1, v.at(tx.i1, y, k));
    }
  return u;
}
// acc = wt·blur(level) + up (blur: rows then columns, taps summed from −R to R from 0).
ImageF ref_blur_add(const ImageF& s, float wt, const ImageF* up, const std::array<float, kGlareBlurRadius + 1>& g) {
  const int w = s.width(), h = s.height(), R = kGlareBlurRadius;
  ImageF t(w, h, 3), a(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        float o = 0.f;
        for (int k = -R; k <= R; ++k) o = o + g[std::abs(k)] * s.at(glare_mirror(x + k, w), y, c);
        t.at(x, y, c) = o;
      }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        float o = 0.f;
        for (int k = -R; k <= R; ++k) o = o + g[std::abs(k)] * t.at(x, glare_mirror(y + k, h), c);
        a.at(x, y, c) = up ? wt * o + up->at(x, y, c) : wt * o;
      }
  return a;
}
struct RefSkirt {
  ImageF acc1;
  std::array<float, 3> scale;
};
RefSkirt ref_skirt(const ImageF& in, const GlarePlan& p) {
  const auto g = glare_blur_taps();
  std::vector<ImageF> lv(p.hi + 1);
  lv[1] = ref_down2(in);
  for (int l = 2; l <= p.hi; ++l) lv[l] = ref_down1331(lv[l - 1]);
  ImageF acc;
  for (int l = p.hi; l >= 1; --l) {
    ImageF up = acc.empty() ? ImageF() : ref_up(acc, lv[l].width(), lv[l].height());
    acc = l >= p.lo ? ref_blur_add(lv[l], p.weight[l - p.lo], acc.empty() ? nullptr : &up, g) : up;
  }
  RefSkirt r{acc, {}};
  const auto e_in = glare_level1_energy(lv[1], in.width(), in.height());
  const auto e_skirt = glare_level1_energy(acc, in.width(), in.height());
  for (int c = 0; c < 3; ++c) r.scale[c] = e_skirt[c] > 0 ? static_cast<float>(p.eta * e_in[c] / e_skirt[c]) : 0.f;
  return r;
}

ImageF test_radiance(int w, int h, uint64_t seed) {
  ImageF r(w, h, 3, 0.f, unit::radiance);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        const uint32_t u = random_words(seed, 0, static_cast<uint64_t>(y) * w + x, Stream::Test)[c];
        r.at(x, y, c) = static_cast<float>(std::exp(16.0 * uniform_open(u) - 12.0));
      }
  return r;
}
GlarePlan test_plan(double core_deg, double reach_deg) {
  LensGlare g;
  g.enabled = true;
  g.veiling_glare_index = 0.05;
  g.core_deg = core_deg;
  g.reach_deg = reach_deg;
  return plan_glare(g, 35);
}
bool same_bits(const ImageF& a, const ImageF& b) {
  return a.width() == b.width() && a.height() == b.height() && a.channels() == b.channels() &&
         std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// Sizes: even and odd, one pixel wide or high, and 2048 x 600 (level 1 above 2^18 pixels, so the
// passes run in parallel); plans with level 1 blurred (lo = 1: level 1 kept as an image) and not
// (lo >= 2: made row by row inside the first step), and lo = hi. Calls in a row of different
// sizes reuse and reshape the workspace's images. make(in, plan) gives each case's skirt, held
// to the whole-image definition bit for bit at 1, 2 and 3 threads.
template <class Make>
void expect_skirts_of_the_definition(int seed, const Make& make) {
  struct Case {
    int w, h;
    double core_deg, reach_deg;
  };
  const Case cases[] = {{2048, 600, 0.1, 20}, {333, 101, 0.02, 20}, {333, 101, 0.1, 20}, {64, 7, 0.1, 5},
                        {1, 9, 0.1, 20},      {9, 1, 0.02, 3},     {5, 4, 0.02, 0.05}, {2048, 600, 0.02, 20}};
  for (const Case& c : cases) {
    const ImageF in = test_radiance(c.w, c.h, c.w * seed + c.h);
    const GlarePlan plan = test_plan(c.core_deg, c.reach_deg);
    ASSERT_TRUE(plan.active);
    const RefSkirt want = ref_skirt(in, plan);
    at_thread_counts([&](int t) {
      const GlareSkirt s = make(in, plan);
      ASSERT_TRUE(s.active());
      EXPECT_TRUE(same_bits(*s.acc1, want.acc1))
          << c.w << "x" << c.h << " lo " << plan.lo << " hi " << plan.hi << ", " << t << " threads";
      EXPECT_EQ(s.scale, want.scale) << c.w << "x" << c.h << ", " << t << " threads";
    });
  }
}
TEST(GlareFastPath, SkirtEqualsTheWholeImageDefinition) {
  expect_skirts_of_the_definition(31, [](const ImageF& in, const GlarePlan& plan) { return glare_skirt(in, plan); });
}

// Level 1 made by a caller row by row (glare_level1_row: the scene's compose pass makes it so, in
// whatever order its threads finish the row pairs), here in reverse order, and its sums in uneven
// spans (glare_level1_sums), gives the skirt of the whole-image definition, bit for bit, on the
// cases above (odd heights: the last level row from one input row; plans with level 1 blurred and
// not: level 2 from it by the (1,3,3,1) step); and the photon stage and expose() handed it give
// the same electrons. A level 1 of another size is refused.
TEST(GlareFastPath, Level1MadeByTheCallerGivesTheSameSkirt) {
  expect_skirts_of_the_definition(29, [](const ImageF& in, const GlarePlan& plan) {
    GlareLevel1 l1(in.width(), in.height());
    for (int j = l1.image.height() - 1; j >= 0; --j) glare_level1_row(in, j, l1);
    for (int j0 = 0, n = 1; j0 < l1.image.height(); j0 += n, n = n % 11 + 1)
      glare_level1_sums(l1, j0, std::min(l1.image.height(), j0 + n));
    return glare_skirt(in, plan, &l1);
  });
  const CameraPreset cam = load_camera_preset("onsemi-ar0331");
  LensPreset lens = load_lens_preset(cam.default_lens);
  ASSERT_TRUE(plan_glare(lens.glare, px_per_degree(lens.focal_length_mm, cam.pixel_pitch_um)).active);
  ExposureSettings es;
  es.seed = 5;
  const ResolvedExposure ex = resolve(cam, lens, es);
  const FixedPatternMaps no_fpn;
  const ImageF in = test_radiance(333, 101, 12);
  GlareLevel1 l1(333, 101);
  for (int j = 0; j < l1.image.height(); ++j) glare_level1_row(in, j, l1);
  glare_level1_sums(l1, 0, l1.image.height());
  EXPECT_TRUE(same_bits(mean_signal_electrons(in, cam, lens, ex, &l1), mean_signal_electrons(in, cam, lens, ex)));
  const SensorOutput a = expose(in, cam, lens, es, no_fpn, &l1), b = expose(in, cam, lens, es, no_fpn);
  EXPECT_TRUE(same_bits(a.electrons, b.electrons) && same_bits(a.raw_dn, b.raw_dn) && same_bits(a.rgb, b.rgb));
  const GlareLevel1 other(332, 101);
  EXPECT_THROW(glare_skirt(in, test_plan(0.1, 20), &other), std::exception);
}

// The pyramid's level-1 row sums, eight rows at a time (detail::glare_level1_row_sums: eight
// independent chains, AVX2 where the CPU has it) equal glare_level1_energy's row by row (its
// sum over a one-row image with full height 1 is the row's sum times 1), bit for bit: at 1 to 8
// rows, widths that end the 4-float loads at every offset, even and odd full widths (the last
// pixel's n = 1 or 2), values over twelve decades so that any other order of the adds would
// round differently.
TEST(GlareFastPath, Level1RowSumsEqualTheRowByRowSums) {
  int rounding_visible = 0;
  for (const int w : {1, 2, 3, 4, 5, 17, 1024, 1025})
    for (const int full_width : {2 * w - 1, 2 * w}) {
      std::vector<ImageF> rows;
      for (int i = 0; i < 8; ++i) {
        ImageF r(w, 1, 3, 0.f, unit::radiance);
        for (int x = 0; x < w; ++x)
          for (int c = 0; c < 3; ++c) {
            const auto u = random_words(31, 0, static_cast<uint64_t>(w) * 100000 + i * 5000 + x, Stream::Test);
            r.at(x, 0, c) = static_cast<float>(std::pow(10.0, 12.0 * uniform_open(u[c]) - 6.0));
          }
        rows.push_back(std::move(r));
      }
      for (int nr = 1; nr <= 8; ++nr) {
        std::vector<const float*> p;
        for (int i = 0; i < nr; ++i) p.push_back(rows[i].row(0));
        std::vector<std::array<double, 3>> got(nr);
        detail::glare_level1_row_sums(p.data(), nr, w, full_width, got.data());
        for (int i = 0; i < nr; ++i) {
          const auto want = glare_level1_energy(rows[i], full_width, 1);
          for (int c = 0; c < 3; ++c) {
            EXPECT_EQ(std::memcmp(&got[i][c], &want[c], sizeof(double)), 0)
                << "w " << w << " full width " << full_width << " rows " << nr << " row " << i << " channel " << c;
            if (w >= 17) {  // the same values summed from the other end round differently somewhere
              double back = 0;
              for (int x = w - 1; x >= 0; --x)
                back += (2 * x + 1 < full_width ? 2.0 : 1.0) * static_cast<double>(rows[i].at(x, 0, c));
              rounding_visible += back != want[c];
            }
          }
        }
      }
    }
  EXPECT_GT(rounding_visible, 0) << "the test values must make the order of the adds visible";
}

// A skirt still held keeps its acc_1: the next call writes a new buffer; once no skirt holds the
// workspace's buffer, the next call reuses it (the same pages) and still gives the definition.
TEST(GlareFastPath, HeldSkirtsKeepTheirBuffersAndFreedOnesAreReused) {
  const ImageF a = test_radiance(300, 200, 1), b = test_radiance(300, 200, 2);
  const GlarePlan plan = test_plan(0.1, 20);
  const RefSkirt want_a = ref_skirt(a, plan), want_b = ref_skirt(b, plan);
  const ImageF* second = nullptr;
  {
    const GlareSkirt sa = glare_skirt(a, plan);
    const GlareSkirt sb = glare_skirt(b, plan);  // sa still held
    EXPECT_NE(sa.acc1.get(), sb.acc1.get());
    EXPECT_TRUE(same_bits(*sa.acc1, want_a.acc1));
    EXPECT_TRUE(same_bits(*sb.acc1, want_b.acc1));
    second = sb.acc1.get();
  }
  const GlareSkirt again = glare_skirt(a, plan);
  EXPECT_EQ(again.acc1.get(), second);  // the freed buffer, written again
  EXPECT_TRUE(same_bits(*again.acc1, want_a.acc1));
}

// The glared image by its definition, whole: g = glare_mix(keep, L, s_c, u) per sample, u the
// bilinear 2x upsampling of acc_1 (ref_up), from the pyramid glare_skirt() makes (itself held to
// its definition by SkirtEqualsTheWholeImageDefinition).
ImageF ref_glared(const ImageF& in, const GlareSkirt& s) {
  const ImageF u = ref_up(*s.acc1, in.width(), in.height());
  ImageF g(in.width(), in.height(), 3, 0.f, in.unit());
  for (int y = 0; y < in.height(); ++y)
    for (int x = 0; x < in.width(); ++x)
      for (int c = 0; c < 3; ++c) g.at(x, y, c) = shader::glare_mix(s.keep, in.at(x, y, c), s.scale[c], u.at(x, y, c));
  return g;
}

// The photon stage with the glare's mix fused into its rows equals the glared image made whole
// and then the photon stage without glare, bit for bit, at 1, 2 and 3 threads: odd and even
// sizes, one pixel wide or high, with and without the cos⁴ falloff; and expose() (the photon
// rows fused with sense) equals sense() of that mean signal, at every vector level the CPU has
// (detail::photon_row_max_isa): on AVX-512 the glared rows run 16 pixels a step, on AVX2 8
// (PhotonStage::glared_row_simd), and the rest by the plain row: widths 21 (one AVX-512 block of
// pixels 2-17, one AVX2 block of pixels 2-9) and 20 (no AVX-512 block), 17 (one AVX2 block) and
// 16 (none), 64, 333 and 2048 put the blocks' ends and the row's rest at different places.
TEST(GlareFastPath, FusedPhotonRowEqualsGlareThenPhotons) {
  const CameraPreset cam = load_camera_preset("onsemi-ar0331");
  const FixedPatternMaps no_fpn;
  ExposureSettings es;
  es.seed = 3;
  const int sizes[][2] = {{333, 101}, {64, 7}, {1, 9}, {9, 1}, {2048, 40}, {21, 5}, {20, 3}, {17, 4}, {16, 3}};
  struct UncapOnExit {
    ~UncapOnExit() { detail::photon_row_max_isa(2); }
  } uncap;
  for (int isa = 0; isa <= detail::machine_isa_level(); ++isa)
    for (const bool cos4 : {true, false})
      for (const auto& wh : sizes) {
        detail::photon_row_max_isa(isa);
        LensPreset lens = load_lens_preset(cam.default_lens);
        lens.cos4_falloff = cos4;
        lens.glare.enabled = true;
        lens.glare.veiling_glare_index = 0.05;
        lens.glare.core_deg = 0.1;
        lens.glare.reach_deg = 20;
        LensPreset plain = lens;
        plain.glare = LensGlare{};
        const ImageF in = test_radiance(wh[0], wh[1], wh[0] * 7 + wh[1]);
        const ResolvedExposure ex = resolve(cam, lens, es);
        const GlareSkirt skirt =
            glare_skirt(in, plan_glare(lens.glare, px_per_degree(lens.focal_length_mm, cam.pixel_pitch_um)));
        ASSERT_TRUE(skirt.active());
        const ImageF want = mean_signal_electrons(ref_glared(in, skirt), cam, plain, ex);
        const SensorOutput want_out = sense(want, cam, ex, es, no_fpn);
        at_thread_counts([&](int t) {
          EXPECT_TRUE(same_bits(mean_signal_electrons(in, cam, lens, ex), want))
              << wh[0] << "x" << wh[1] << " cos4 " << cos4 << ", " << t << " threads, isa " << isa;
          const SensorOutput got = expose(in, cam, lens, es, no_fpn);
          EXPECT_TRUE(same_bits(got.electrons, want_out.electrons) && same_bits(got.raw_dn, want_out.raw_dn) &&
                      same_bits(got.rgb, want_out.rgb))
              << "expose " << wh[0] << "x" << wh[1] << " cos4 " << cos4 << ", " << t << " threads, isa " << isa;
        });
      }
}

// apply_glare (glare_row: on AVX-512 the interior pixel pairs upsampled and mixed in registers,
// the row's ends by the per-pixel step and mix_row) equals the glared image made whole, bit for
// bit, at 1, 2 and 3 threads: widths 21 (one block of pairs) and 20 (none), 333, 64, 2048, one
// pixel wide or high, and 5 (acc_1 3 pixels wide: no block).
TEST(GlareFastPath, GlaredImageEqualsTheWholeImageDefinition) {
  LensGlare g;
  g.enabled = true;
  g.veiling_glare_index = 0.05;
  g.core_deg = 0.1;
  g.reach_deg = 20;
  const int sizes[][2] = {{333, 101}, {64, 7}, {1, 9}, {9, 1}, {2048, 40}, {21, 5}, {20, 3}, {5, 4}};
  for (const auto& wh : sizes) {
    const ImageF in = test_radiance(wh[0], wh[1], wh[0] * 5 + wh[1]);
    const GlareSkirt skirt = glare_skirt(in, plan_glare(g, 35));
    ASSERT_TRUE(skirt.active());
    const ImageF want = ref_glared(in, skirt);
    at_thread_counts([&](int t) {
      EXPECT_TRUE(same_bits(apply_glare(in, g, 35), want)) << wh[0] << "x" << wh[1] << ", " << t << " threads";
    });
  }
}

// A radiance that is not physical (NaN, Inf, negative, or R + G + B overflowing) is reported at
// its pixel by the glared photon stage wherever it lies in the row: in the AVX-512 blocks' first,
// middle and last lanes and in the row's rest (pixels 0, 1 and past the last block).
TEST(GlareFastPath, GlaredRowsReportRadianceThatIsNotPhysical) {
  const CameraPreset cam = load_camera_preset("onsemi-ar0331");
  LensPreset lens = load_lens_preset(cam.default_lens);
  lens.glare.enabled = true;
  lens.glare.veiling_glare_index = 0.05;
  lens.glare.core_deg = 0.1;
  lens.glare.reach_deg = 20;
  const ResolvedExposure ex = resolve(cam, lens, ExposureSettings{});
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const float big = std::numeric_limits<float>::max();
  const int w = 333, h = 6, y = 4;
  for (const int x : {0, 1, 2, 9, 17, 18, 150, 321, 322, 332})
    for (const std::array<float, 3> bad :
         {std::array<float, 3>{nan, 1.f, 1.f}, {1.f, inf, 1.f}, {1.f, 1.f, -2.f}, {big, big, 1.f}}) {
      ImageF in = test_radiance(w, h, 5);
      for (int c = 0; c < 3; ++c) in.at(x, y, c) = bad[c];
      std::string msg;
      try {
        mean_signal_electrons(in, cam, lens, ex);
      } catch (const std::exception& e) {
        msg = e.what();
      }
      EXPECT_NE(msg.find("(" + std::to_string(x) + ", " + std::to_string(y) + ")"), std::string::npos)
          << "x " << x << ": '" << msg << "'";
    }
}

// detail::analog_row (the full well, the analog chain to DN and the mosaic above black; an
// AVX-512 path of 8 pixels a step where the CPU has it) equals sense_electrons then sense_raw_dn
// (kernels/common/sensor_pixel.glsl) pixel by pixel, bit for bit, and so does the per-pixel
// loop analog_row_definition: at lengths that leave every tail of the 8-wide path, with
// electrons below 0 and above the full well, codes clipped at 0 and at max_code, and NaN, ±inf,
// −0 and the largest float among the inputs.
TEST(SenseFastPath, AnalogRowEqualsItsDefinition) {
  const float fw = 10000.f, rn = 3.5f, row_noise = -1.25f;
  const double K = 0.5, black = 64, max_code = 4095;
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const float special[] = {nan, inf, -inf, -0.f, std::numeric_limits<float>::max(), fw, -128.f};
  auto unit = [](uint32_t u) { return static_cast<float>(u) * 0x1p-32f; };
  int checked = 0;
  for (const int w : {1, 7, 8, 9, 15, 16, 17, 23, 40, 2051}) {
    std::vector<float> e(w), off(w), read(w), col(w);
    for (int x = 0; x < w; ++x) {
      const auto r = random_words(91, 0, static_cast<uint64_t>(w) * 4096 + x, Stream::Test);
      e[x] = (unit(r[0]) * 1.4f - 0.2f) * fw;  // -2000 .. 14000 e: both clips of the 12-bit ADC
      off[x] = (unit(r[1]) - 0.5f) * 40.f;
      read[x] = (unit(r[2]) - 0.5f) * 10.f;
      col[x] = (unit(r[3]) - 0.5f) * 4.f;
      if (x % 5 == 3) {  // a special value in one of the four inputs
        float* in[] = {e.data(), off.data(), read.data(), col.data()};
        in[(x / 5) % 4][x] = special[(x / 20) % 7];
      }
    }
    std::vector<float> e_fast = e, d_fast(w), ab_fast(w), e_def = e, d_def(w), ab_def(w), e_px(w), d_px(w), ab_px(w);
    detail::analog_row(e_fast.data(), off.data(), read.data(), col.data(), row_noise, rn, fw, K, black, max_code, w,
                       d_fast.data(), ab_fast.data());
    detail::analog_row_definition(e_def.data(), off.data(), read.data(), col.data(), row_noise, rn, fw, K, black,
                                  max_code, w, d_def.data(), ab_def.data());
    for (int x = 0; x < w; ++x) {
      e_px[x] = shader::sense_electrons(e[x], fw);
      d_px[x] = shader::sense_raw_dn(e_px[x], off[x], rn, read[x], row_noise, col[x], K, black, max_code);
      ab_px[x] = d_px[x] - static_cast<float>(black);
    }
    for (const auto* got : {&e_fast, &e_def})
      EXPECT_EQ(std::memcmp(got->data(), e_px.data(), 4 * static_cast<size_t>(w)), 0) << "electrons, w " << w;
    for (const auto* got : {&d_fast, &d_def})
      EXPECT_EQ(std::memcmp(got->data(), d_px.data(), 4 * static_cast<size_t>(w)), 0) << "DN, w " << w;
    for (const auto* got : {&ab_fast, &ab_def})
      EXPECT_EQ(std::memcmp(got->data(), ab_px.data(), 4 * static_cast<size_t>(w)), 0) << "above black, w " << w;
    for (int x = 0; x < w; ++x) checked += d_px[x] == 0.f || d_px[x] == static_cast<float>(max_code) ? 1 : 0;
  }
  EXPECT_GT(checked, 100) << "the inputs reach both clips of the ADC";
}

}  // namespace
// The paths below the machine's level, tested on it: PHOTOSITE_MAX_ISA (core/isa_detail.h) caps
// the level of a process, so the fast-path tests run again in child processes of this test
// program at the AVX2 and scalar caps (on an AVX-512 machine its AVX2 paths, which the
// whole-image and definition tests then hold to the same bits). IsaCaps.LevelIsAtMostTheCap,
// run in each child, checks that the cap took (the level read by the library, against the
// variable read here). The target_clones functions keep the CPU's clone (isa_detail.h).
TEST(IsaCaps, LevelIsAtMostTheCap) {
  const char* cap = std::getenv("PHOTOSITE_MAX_ISA");
  if (!cap) GTEST_SKIP() << "PHOTOSITE_MAX_ISA not set (IsaCaps.FastPathTestsPassAtEachCap sets it in its children)";
  const std::string c(cap);
  const int level = c == "scalar" ? 0 : c == "avx2" ? 1 : 2;
  EXPECT_LE(detail::machine_isa_level(), level) << "PHOTOSITE_MAX_ISA=" << c;
}
TEST(IsaCaps, FastPathTestsPassAtEachCap) {
  if (std::getenv("PHOTOSITE_MAX_ISA")) GTEST_SKIP() << "already a child with a cap";
  const std::string filter = "IsaCaps.LevelIsAtMostTheCap:GlareFastPath.*:Glare.*:SenseFastPath.*:Philox.*:FastMath.*:"
                             "SceneGeometry.FastSrgb*:SceneGeometry.WorkLuma*:SceneDarken.*:SceneLights.*";
  const std::string log = (std::filesystem::temp_directory_path() / ("photosite-isa-caps-" + std::to_string(getpid()) + ".txt")).string();
  const std::string self = std::filesystem::read_symlink("/proc/self/exe").string();  // this test program
  for (const char* cap : {"avx2", "scalar"}) {
    setenv("PHOTOSITE_MAX_ISA", cap, 1);
    const int rc = std::system(("'" + self + "' --gtest_brief=1 --gtest_filter='" + filter + "' > '" + log + "' 2>&1").c_str());
    unsetenv("PHOTOSITE_MAX_ISA");
    std::stringstream out;
    out << std::ifstream(log).rdbuf();
    EXPECT_EQ(rc, 0) << "PHOTOSITE_MAX_ISA=" << cap << ":\n" << out.str();
    EXPECT_NE(out.str().find("PASSED"), std::string::npos) << out.str();
  }
  std::remove(log.c_str());
}

}  // namespace photosite
