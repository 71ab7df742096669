// `photosite bench sense`: where the sense stage's time goes (issue 16 §3). On the expose chain's
// bench frame (onsemi-ar0331, a radiance ramp over three decades, 2048x1024, all threads), in
// alternating rounds (best of each):
//  * sense() whole (noise, ADC and the bilinear demosaic), and the demosaic alone;
//  * the words alone, every pixel of the frame in blocks of 256 as the sense loop draws them:
//    Philox4x32-10 (the generator of every result) on the AVX2 path and, where the CPU has it,
//    on the AVX-512 path the sampler uses there (the same words); Philox4x32-7 and a keyed
//    lowbias32 counter hash (cheaper generators with the same keying, used for nothing but this
//    comparison): what the counter-based generator costs, and what a cheaper one would save;
//  * the memory floor of the noise + ADC part: one streaming pass with its traffic, reading the
//    mean signal and the three fixed-pattern maps and writing electrons and DN (6 floats,
//    24 bytes per pixel), with the sense's mean-electron arithmetic and nothing else; and the
//    floor as bytes over the machine's measured streaming bandwidth (a STREAM-like triad over
//    arrays far larger than the caches), for noise + ADC and for expose's whole traffic.
//  * the whole sensor as night and batch run it: expose() (photon stage with the lens glare and
//    the sense stage fused row by row), beside its two stages run apart (mean_signal_electrons()
//    then sense(), the mean signal going through memory) and the photon stage alone; and
//    expose() into a caller-owned SensorOutput kept across calls (no fresh output pages).
//  Since sense() fuses the bilinear demosaic into its row loop, "noise + ADC" (sense minus the
//  demosaic run alone) understates the noise + ADC part by what the fusion saves.
// Each is timed as the mean of --inner calls, twice: wall time, and the process's CPU time (all threads), which a loaded
// machine disturbs less (a preempted thread's wait is not counted); the ratios are taken on CPU
// time.
#include <omp.h>
#include <sys/resource.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>
#include <fmt/format.h>

#include "bench.h"
#include "photosite/error.h"
#include "photosite/scene/night.h"
#include "photosite/sensor/demosaic.h"
#include "photosite/sensor/fpn.h"
#include "photosite/sensor/pipeline.h"
#include "sensor/poisson_detail.h"

namespace photosite::bench {
namespace {

struct BenchSenseOptions {
  std::string out_dir;
  int repeats = 9;
  int inner = 20;  // calls per timing: the CPU clock of a loaded VM ticks in ~4 ms steps
  int width = 2048, height = 1024;
};

// Words for every pixel of a w x h frame in blocks of 256 (as the sense loop draws them), rows
// split over the threads, by gen(first_pixel, n, w0..w3); returns an xor of the words so
// nothing is optimised away.
template <class Gen>
uint32_t frame_words(int w, int h, const Gen& gen) {
  uint32_t sum = 0;
#pragma omp parallel reduction(^ : sum)
  {
    alignas(64) uint32_t w0[256], w1[256], w2[256], w3[256];
#pragma omp for schedule(static)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; x += 256) {
        const int n = std::min(256, w - x);
        gen(static_cast<uint64_t>(y) * w + x, n, w0, w1, w2, w3);
        for (int j = 0; j < n; ++j) sum ^= w0[j] ^ w1[j] ^ w2[j] ^ w3[j];
      }
  }
  return sum;
}
constexpr uint64_t kKey = 1234;
constexpr uint32_t kFrame = 7, kStream = 1;
auto philox_gen(int rounds, detail::PhiloxPath path) {
  return [rounds, path](uint64_t p, int n, uint32_t* w0, uint32_t* w1, uint32_t* w2, uint32_t* w3) {
    detail::philox_words_rounds(rounds, path, kKey, kFrame, p, kStream, n, w0, w1, w2, w3);
  };
}

// The cheaper generator of the comparison (never used for a result; its statistical quality is
// not tested): a keyed counter hash with Philox's input (key, frame, pixel, stream), built from
// C. Wellons' lowbias32 integer hash (x ^= x>>16; x *= 0x7feb352d; x ^= x>>15; x *= 0x846ca68b;
// x ^= x>>16: a bijection of 32-bit words, https://nullprogram.com/blog/2018/07/31/). The part
// of the input that is the same over a block (key's high word, pixel's high word, frame, stream)
// is hashed once into b; per pixel c = lb(lb(pixel_lo ^ key_lo) ^ b) and word i = lb(c ^ s_i)
// for four constants s_i: six hashes, twelve 32-bit multiplies (low halves) a pixel, against
// Philox-10's twenty 32x32->64 products. Plain C on 32-bit lanes, so the compiler vectorizes
// it for each width (vpmulld): hash_words_body is compiled into an AVX2 and an AVX-512
// function, as Philox has both paths.
inline uint32_t lowbias32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}
constexpr uint32_t kHashSalt[4] = {0x9E3779B9u, 0xBB67AE85u, 0x3C6EF372u, 0xA54FF53Au};
__attribute__((always_inline)) inline void hash_words_body(uint64_t key, uint32_t frame, uint64_t first_pixel,
                                                           uint32_t stream, int n, uint32_t* __restrict w0,
                                                           uint32_t* __restrict w1, uint32_t* __restrict w2,
                                                           uint32_t* __restrict w3) {
  // One block: the pixel's high half is first_pixel's for all n (hash_blocks cuts the blocks so).
  const uint32_t b = lowbias32(static_cast<uint32_t>(key >> 32) ^ static_cast<uint32_t>(first_pixel >> 32) ^
                               lowbias32(frame ^ lowbias32(stream)));
  const uint32_t klo = static_cast<uint32_t>(key), p0 = static_cast<uint32_t>(first_pixel);
  for (int j = 0; j < n; ++j) {
    const uint32_t c = lowbias32(lowbias32((p0 + static_cast<uint32_t>(j)) ^ klo) ^ b);
    w0[j] = lowbias32(c ^ kHashSalt[0]);
    w1[j] = lowbias32(c ^ kHashSalt[1]);
    w2[j] = lowbias32(c ^ kHashSalt[2]);
    w3[j] = lowbias32(c ^ kHashSalt[3]);
  }
}
// The block generator: pixels first_pixel.. cut where the pixel's high half changes.
template <class Body>
void hash_blocks(const Body& body, uint64_t key, uint32_t frame, uint64_t first_pixel, uint32_t stream, int n,
                 uint32_t* w0, uint32_t* w1, uint32_t* w2, uint32_t* w3) {
  for (int j = 0; j < n;) {
    const uint64_t p = first_pixel + j;
    const int m = static_cast<int>(std::min<uint64_t>(n - j, (uint64_t{1} << 32) - (p & 0xFFFFFFFFu)));
    body(key, frame, p, stream, m, w0 + j, w1 + j, w2 + j, w3 + j);
    j += m;
  }
}
__attribute__((noinline)) void hash_words_default(uint64_t key, uint32_t frame, uint64_t first, uint32_t stream, int n,
                                                  uint32_t* w0, uint32_t* w1, uint32_t* w2, uint32_t* w3) {
  hash_words_body(key, frame, first, stream, n, w0, w1, w2, w3);
}
__attribute__((target("avx2"))) void hash_words_avx2(uint64_t key, uint32_t frame, uint64_t first, uint32_t stream,
                                                     int n, uint32_t* w0, uint32_t* w1, uint32_t* w2, uint32_t* w3) {
  hash_words_body(key, frame, first, stream, n, w0, w1, w2, w3);
}
__attribute__((target("avx512f"))) void hash_words_avx512(uint64_t key, uint32_t frame, uint64_t first,
                                                          uint32_t stream, int n, uint32_t* w0, uint32_t* w1,
                                                          uint32_t* w2, uint32_t* w3) {
  hash_words_body(key, frame, first, stream, n, w0, w1, w2, w3);
}
auto hash_gen(bool avx512) {
  return [avx512](uint64_t p, int n, uint32_t* w0, uint32_t* w1, uint32_t* w2, uint32_t* w3) {
    hash_blocks(avx512 ? hash_words_avx512 : hash_words_avx2, kKey, kFrame, p, kStream, n, w0, w1, w2, w3);
  };
}
// The vector builds of the hash against the baseline build, one pixel at a time, across a 2^32
// pixel boundary (a benchmark of wrong words would mean nothing).
void check_hash_words(bool avx512) {
  alignas(64) uint32_t a[4][256], b[4][256];
  const uint64_t first = (uint64_t{1} << 32) - 100;
  hash_blocks(avx512 ? hash_words_avx512 : hash_words_avx2, kKey, kFrame, first, kStream, 256, a[0], a[1], a[2], a[3]);
  for (int j = 0; j < 256; ++j) hash_words_default(kKey, kFrame, first + j, kStream, 1, &b[0][j], &b[1][j], &b[2][j], &b[3][j]);
  if (std::memcmp(a, b, sizeof a) != 0) fail("bench sense: the vector counter hash differs from its baseline build");
}

using scene::process_cpu_ms;  // the process CPU clock in ms (scene/night.h)
// Wall and CPU time per call of f over `inner` calls, kept as the best of each over the rounds.
// Minor page faults per call too (getrusage; first touches of fresh pages, which the kernel
// zeroes: what a caller-owned output buffer saves), the mean over every call of every round
// (whether a fresh image faults depends on what the allocator has kept from earlier frees).
long minor_faults() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_minflt;
}
// Streaming bandwidth (GB/s, bytes read + written): a[i] = b[i] + s·c[i] over 3 arrays of
// `mb` MB each (far beyond the caches), all threads, best of `repeats`; timed by the process CPU
// clock over the thread count (a loaded machine's preemptions do not count as time).
double triad_gb_per_s(int repeats, size_t mb) {
  const size_t n = mb * (1u << 20) / sizeof(float);
  std::vector<float> a(n), b(n, 1.f), c(n, 2.f);
  auto pass = [&] {
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < static_cast<int64_t>(n); ++i) a[i] = b[i] + 0.5f * c[i];
  };
  pass();  // fault the pages in
  double best = 1e300;
  for (int r = 0; r < repeats; ++r) {
    const double c0 = process_cpu_ms();
    pass();
    best = std::min(best, (process_cpu_ms() - c0) / omp_get_max_threads());
  }
  return 3.0 * n * sizeof(float) / (best * 1e6);
}
struct Timing {
  int inner = 1;
  double wall = 1e300, cpu = 1e300, faults = 0;
  long fault_sum = 0, calls = 0;
  template <class F>
  void add(F&& f) {
    const double c0 = process_cpu_ms();
    const long f0 = minor_faults();
    wall = std::min(wall, time_ms([&] {
                      for (int i = 0; i < inner; ++i) f();
                    }) / inner);
    cpu = std::min(cpu, (process_cpu_ms() - c0) / inner);
    fault_sum += minor_faults() - f0;
    calls += inner;
    faults = static_cast<double>(fault_sum) / calls;
  }
};

void run_bench(const BenchSenseOptions& o) {
  const int w = o.width, h = o.height;
  if (w % 8 != 0) throw CLI::ValidationError("--width", "must be a multiple of 8");
  // "noise + ADC" is a difference of two best-of-rounds times (sense minus the demosaic alone).
  // One round is one sample of each, and on a loaded machine a thread preempted at an OpenMP
  // barrier stretches either call by milliseconds (seen: both 8 ms at 256x128, against 0.35 and
  // 0.07 ms unhindered), so --repeats 1 wrote negative durations; a best of 3 is the least that
  // leaves a round to lose.
  if (o.repeats < 3)
    throw CLI::ValidationError("--repeats", fmt::format("{} is not allowed: noise + ADC is the difference of two "
                                                        "best-of-rounds times and needs at least 3 rounds",
                                                        o.repeats));
  const CameraPreset cam = load_camera_preset("onsemi-ar0331");
  const LensPreset lens = load_lens_preset(cam.default_lens);
  ImageF radiance(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
        radiance.at(x, y, c) = static_cast<float>(1e-4 * std::pow(1e3, x / (w - 1.0)) * (1 + 0.3 * c));
  const FixedPatternMaps fpn = generate_fixed_pattern(cam, w, h, "bench");
  if (fpn.prnu_gain.empty() || fpn.dsnu_offset_e.empty() || fpn.dark_rate_factor.empty())
    fail("bench sense: the onsemi-ar0331 preset is expected to have PRNU, DSNU and dark-rate maps");
  const ExposureSettings s;
  const ResolvedExposure ex = resolve(cam, lens, s);
  const ImageF mean_e = mean_signal_electrons(radiance, cam, lens, ex);
  SensorOutput so = sense(mean_e, cam, ex, s, fpn);

  // The floor: the noise + ADC part's memory traffic with only its mean-electron arithmetic.
  const size_t n = static_cast<size_t>(w) * h;
  std::vector<float> el(n), dn(n);
  const float* sig = mean_e.data();
  const float* g = fpn.prnu_gain.data();
  const float* off = fpn.dsnu_offset_e.data();
  const float* df = fpn.dark_rate_factor.data();
  const float dark = static_cast<float>(ex.dark_current_e_per_s * ex.exposure_s);
  auto floor_pass = [&] {
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < static_cast<int64_t>(n); ++i) {
      const float m = sig[i] * g[i] + dark * df[i];
      el[i] = m;
      dn[i] = m + off[i];
    }
  };

  const bool avx512 = detail::best_philox_path() == detail::PhiloxPath::Avx512;
  check_hash_words(false);
  if (avx512) check_hash_words(true);
  Timing sense_t{o.inner}, demosaic_t{o.inner}, p10{o.inner}, p7{o.inner}, floor_t{o.inner};
  Timing p10w{o.inner}, p7w{o.inner}, hash_t{o.inner}, hash_w{o.inner};
  Timing expose_t{o.inner}, apart_t{o.inner}, photon_t{o.inner}, reused_t{o.inner};
  SensorOutput reused = so;  // caller-owned outputs, overwritten by every call of its row
  uint32_t sink = 0;
  for (int r = 0; r < o.repeats; ++r) {
    expose_t.add([&] { so = expose(radiance, cam, lens, s, fpn); });
    reused_t.add([&] { expose(radiance, cam, lens, s, fpn, reused); });
    apart_t.add([&] { so = sense(mean_signal_electrons(radiance, cam, lens, ex), cam, ex, s, fpn); });
    photon_t.add([&] { auto m = mean_signal_electrons(radiance, cam, lens, ex); });
    sense_t.add([&] { so = sense(mean_e, cam, ex, s, fpn); });
    demosaic_t.add([&] { auto rgb = demosaic(so.raw_dn, cam.cfa, DemosaicMethod::Bilinear); });
    p10.add([&] { sink += frame_words(w, h, philox_gen(10, detail::PhiloxPath::Avx2)); });
    p7.add([&] { sink += frame_words(w, h, philox_gen(7, detail::PhiloxPath::Avx2)); });
    if (avx512) {
      p10w.add([&] { sink += frame_words(w, h, philox_gen(10, detail::PhiloxPath::Avx512)); });
      p7w.add([&] { sink += frame_words(w, h, philox_gen(7, detail::PhiloxPath::Avx512)); });
    }
    hash_t.add([&] { sink += frame_words(w, h, hash_gen(false)); });
    if (avx512) hash_w.add([&] { sink += frame_words(w, h, hash_gen(true)); });
    floor_t.add(floor_pass);
  }
  double noise_adc_wall = sense_t.wall - demosaic_t.wall, noise_adc_cpu = sense_t.cpu - demosaic_t.cpu;
  // Still not positive (every round disturbed): no time, so NaN in the table, the CSV and the
  // ratios built on it rather than a negative duration.
  const bool noise_adc_resolved = noise_adc_wall > 0 && noise_adc_cpu > 0;
  if (!noise_adc_resolved) noise_adc_wall = noise_adc_cpu = std::numeric_limits<double>::quiet_NaN();
  const int threads = omp_get_max_threads();
  std::printf("photosite bench sense: onsemi-ar0331, %dx%d, %d threads, best of %d alternating rounds of %d calls\n", w, h,
              threads, o.repeats, o.inner);
  std::printf("machine: %s\n\n", machine_description().c_str());
  std::printf("                                            wall ms   CPU ms (all threads)   page faults/call\n");
  auto row = [](const char* name, double wall, double cpu) { std::printf("%-42s %8.2f %8.2f\n", name, wall, cpu); };
  auto frow = [](const char* name, const Timing& t) {
    std::printf("%-42s %8.2f %8.2f %12.0f\n", name, t.wall, t.cpu, t.faults);
  };
  frow("expose (photon + glare + sense, fused rows)", expose_t);
  frow("  the same into reused outputs", reused_t);
  frow("  the same two stages apart (via memory)", apart_t);
  row("  photon stage alone (with the lens glare)", photon_t.wall, photon_t.cpu);
  frow("sense (noise + ADC + bilinear demosaic)", sense_t);
  row("  bilinear demosaic alone", demosaic_t.wall, demosaic_t.cpu);
  row("  noise + ADC (the difference)", noise_adc_wall, noise_adc_cpu);
  if (!noise_adc_resolved)
    std::printf("  (noise + ADC not resolved: the sense measured no slower than the demosaic alone in %d rounds; "
                "the machine is loaded: more --repeats)\n", o.repeats);
  row("Philox4x32-10 words, AVX2", p10.wall, p10.cpu);
  row("Philox4x32-7 words, AVX2 (no results)", p7.wall, p7.cpu);
  if (avx512) {
    row("Philox4x32-10 words, AVX-512", p10w.wall, p10w.cpu);
    row("Philox4x32-7 words, AVX-512 (no results)", p7w.wall, p7w.cpu);
  }
  row("lowbias32 counter hash, AVX2 (no results)", hash_t.wall, hash_t.cpu);
  if (avx512) row("lowbias32 counter hash, AVX-512 (no results)", hash_w.wall, hash_w.cpu);
  row("memory floor of noise + ADC (24 B/pixel)", floor_t.wall, floor_t.cpu);
  // The floors as bytes over the measured bandwidth. Noise + ADC: 24 B a pixel (above). expose:
  // the radiance read twice (the glare pyramid, then the photon rows: 24 B), the three
  // fixed-pattern maps (12 B), electrons, raw and RGB written (20 B), acc_1 (3 floats per 2x2
  // pixels) written and read back (6 B): 62 B a pixel.
  const double gbps = triad_gb_per_s(std::max(3, o.repeats), 32);
  const double px = static_cast<double>(w) * h;
  const double floor_noise_ms = 24 * px / (gbps * 1e6), floor_expose_ms = 62 * px / (gbps * 1e6);
  std::printf("streaming bandwidth (triad, 3 x 32 MB, %d threads, by CPU time): %.1f GB/s; floors by bytes / bandwidth: "
              "noise + ADC %.2f ms, expose %.2f ms\n",
              threads, gbps, floor_noise_ms, floor_expose_ms);
  const Timing& philox = avx512 ? p10w : p10;  // the path the sampler runs
  const Timing& philox7 = avx512 ? p7w : p7;
  const Timing& hash = avx512 ? hash_w : hash_t;
  std::printf("\nCPU-time ratios (the sampler's Philox path, %s): Philox-7 / Philox-10 %.2f; counter hash / Philox-10 "
              "%.2f; Philox-10 share of noise + ADC %.0f%%, the hash's %.0f%%; noise + ADC / its measured floor %.1f; "
              "expose fused / its stages apart %.2f",
              avx512 ? "AVX-512" : "AVX2", philox7.cpu / philox.cpu, hash.cpu / philox.cpu,
              100.0 * philox.cpu / noise_adc_cpu, 100.0 * hash.cpu / noise_adc_cpu, noise_adc_cpu / floor_t.cpu,
              expose_t.cpu / apart_t.cpu);
  if (avx512) std::printf("; Philox-10 AVX-512 / AVX2 %.2f", p10w.cpu / p10.cpu);
  std::printf("\n(sum of the frames' word xors: %08x)\n", sink);
  std::string csv = "quantity,wall_ms,cpu_ms_all_threads\n";
  csv += fmt::format("expose_reused_outputs,{:.3f},{:.3f}\n", reused_t.wall, reused_t.cpu);
  csv += fmt::format("expose_fused,{:.3f},{:.3f}\nexpose_stages_apart,{:.3f},{:.3f}\nphoton_stage,{:.3f},{:.3f}\n",
                     expose_t.wall, expose_t.cpu, apart_t.wall, apart_t.cpu, photon_t.wall, photon_t.cpu);
  csv += fmt::format("sense,{:.3f},{:.3f}\nbilinear_demosaic,{:.3f},{:.3f}\nnoise_adc,{:.3f},{:.3f}\n"
                     "philox4x32_10_words_avx2,{:.3f},{:.3f}\nphilox4x32_7_words_avx2,{:.3f},{:.3f}\n",
                     sense_t.wall, sense_t.cpu, demosaic_t.wall, demosaic_t.cpu, noise_adc_wall, noise_adc_cpu,
                     p10.wall, p10.cpu, p7.wall, p7.cpu);
  if (avx512)
    csv += fmt::format("philox4x32_10_words_avx512,{:.3f},{:.3f}\nphilox4x32_7_words_avx512,{:.3f},{:.3f}\n", p10w.wall,
                       p10w.cpu, p7w.wall, p7w.cpu);
  csv += fmt::format("lowbias32_counter_hash_words_avx2,{:.3f},{:.3f}\n", hash_t.wall, hash_t.cpu);
  if (avx512) csv += fmt::format("lowbias32_counter_hash_words_avx512,{:.3f},{:.3f}\n", hash_w.wall, hash_w.cpu);
  csv += fmt::format("memory_floor_noise_adc,{:.3f},{:.3f}\n", floor_t.wall, floor_t.cpu);
  csv += fmt::format("floor_noise_adc_bytes_over_bandwidth,{:.3f},\nfloor_expose_bytes_over_bandwidth,{:.3f},\n",
                     floor_noise_ms, floor_expose_ms);
  csv += fmt::format("# onsemi-ar0331, {}x{}, {} threads, best of {} alternating rounds of {} calls, {}\n", w, h,
                     threads, o.repeats, o.inner, machine_description());
  csv += fmt::format("# triad bandwidth {:.2f} GB/s; cpu-time ratios on the sampler's Philox path ({}): "
                     "philox7_over_philox10={:.3f} hash_over_philox10={:.3f} philox10_share_of_noise_adc={:.3f} "
                     "hash_share_of_noise_adc={:.3f} noise_adc_over_floor={:.2f}\n",
                     gbps, avx512 ? "avx512" : "avx2", philox7.cpu / philox.cpu, hash.cpu / philox.cpu,
                     philox.cpu / noise_adc_cpu, hash.cpu / noise_adc_cpu, noise_adc_cpu / floor_t.cpu);
  write_bench_csv(o.out_dir, "bench_sense.csv", csv);
}

}  // namespace

static BenchRegistrar reg("sense",
                          "sense stage: its time against its memory floor, and Philox4x32-10 against -7 and a counter hash (docs/bench_sense.csv)",
                          [](CLI::App* sub) {
                            auto o = std::make_shared<BenchSenseOptions>();
                            sub->add_option("--out-dir", o->out_dir, "where the CSV goes (default docs/)");
                            sub->add_option("--repeats", o->repeats, "alternating rounds (best of each), at least 3")->capture_default_str();
                            sub->add_option("--inner", o->inner, "calls per timing")->capture_default_str();
                            sub->add_option("--width", o->width, "width of the timed frame in pixels, a multiple of 8")->capture_default_str();
                            sub->add_option("--height", o->height, "height of the timed frame in pixels")->capture_default_str();
                            sub->callback([o] { run_bench(*o); });
                          });

}  // namespace photosite::bench
