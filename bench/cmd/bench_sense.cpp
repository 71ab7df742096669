// `photosite bench sense`: where the sense stage's time goes (issue 16 §3). On the expose chain's
// bench frame (onsemi-ar0331, a radiance ramp over three decades, 2048x1024, all threads), in
// alternating rounds (best of each):
//  * sense() whole (noise, ADC and the bilinear demosaic), and the demosaic alone;
//  * the Philox words alone: the AVX2 block generator over every pixel, with 10 rounds
//    (Philox4x32-10, the generator of every result) and with 7 (Philox4x32-7, used for nothing
//    but this comparison): what the counter-based generator costs, and what 3 rounds less would
//    save;
//  * the memory floor of the noise + ADC part: one streaming pass with its traffic, reading the
//    mean signal and the three fixed-pattern maps and writing electrons and DN (6 floats,
//    24 bytes per pixel), with the sense's mean-electron arithmetic and nothing else.
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

// Philox words for every pixel of a w x h frame in blocks of 256 (as the sense loop draws them),
// rows split over the threads; returns an xor of the words so nothing is optimised away.
uint32_t frame_words(int rounds, int w, int h) {
  uint32_t sum = 0;
#pragma omp parallel reduction(^ : sum)
  {
    alignas(64) uint32_t w0[256], w1[256], w2[256], w3[256];
#pragma omp for schedule(static)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; x += 256) {
        const int n = std::min(256, w - x);
        detail::philox_words_rounds(rounds, 1234, 7, static_cast<uint64_t>(y) * w + x, 1, n, w0, w1, w2, w3);
        for (int j = 0; j < n; ++j) sum ^= w0[j] ^ w1[j] ^ w2[j] ^ w3[j];
      }
  }
  return sum;
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

  Timing sense_t{o.inner}, demosaic_t{o.inner}, p10{o.inner}, p7{o.inner}, floor_t{o.inner};
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
    p10.add([&] { sink ^= frame_words(10, w, h); });
    p7.add([&] { sink ^= frame_words(7, w, h); });
    floor_t.add(floor_pass);
  }
  const double noise_adc_wall = sense_t.wall - demosaic_t.wall, noise_adc_cpu = sense_t.cpu - demosaic_t.cpu;
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
  row("Philox4x32-10 words, every pixel", p10.wall, p10.cpu);
  row("Philox4x32-7 words (not used for results)", p7.wall, p7.cpu);
  row("memory floor of noise + ADC (24 B/pixel)", floor_t.wall, floor_t.cpu);
  std::printf("\nCPU-time ratios: Philox-7 / Philox-10 %.2f; Philox-10 share of noise + ADC %.0f%%; "
              "noise + ADC / its memory floor %.1f; expose fused / its stages apart %.2f\n",
              p7.cpu / p10.cpu, 100.0 * p10.cpu / noise_adc_cpu, noise_adc_cpu / floor_t.cpu, expose_t.cpu / apart_t.cpu);
  std::printf("(xor of the words: %08x)\n", sink);
  std::string csv = "quantity,wall_ms,cpu_ms_all_threads\n";
  csv += fmt::format("expose_reused_outputs,{:.3f},{:.3f}\n", reused_t.wall, reused_t.cpu);
  csv += fmt::format("expose_fused,{:.3f},{:.3f}\nexpose_stages_apart,{:.3f},{:.3f}\nphoton_stage,{:.3f},{:.3f}\n",
                     expose_t.wall, expose_t.cpu, apart_t.wall, apart_t.cpu, photon_t.wall, photon_t.cpu);
  csv += fmt::format("sense,{:.3f},{:.3f}\nbilinear_demosaic,{:.3f},{:.3f}\nnoise_adc,{:.3f},{:.3f}\n"
                     "philox4x32_10_words,{:.3f},{:.3f}\nphilox4x32_7_words,{:.3f},{:.3f}\n"
                     "memory_floor_noise_adc,{:.3f},{:.3f}\n",
                     sense_t.wall, sense_t.cpu, demosaic_t.wall, demosaic_t.cpu, noise_adc_wall, noise_adc_cpu,
                     p10.wall, p10.cpu, p7.wall, p7.cpu, floor_t.wall, floor_t.cpu);
  csv += fmt::format("# onsemi-ar0331, {}x{}, {} threads, best of {} alternating rounds of {} calls, {}\n", w, h,
                     threads, o.repeats, o.inner, machine_description());
  csv += fmt::format("# cpu-time ratios: philox7_over_philox10={:.3f} philox10_share_of_noise_adc={:.3f} "
                     "noise_adc_over_floor={:.2f}\n",
                     p7.cpu / p10.cpu, p10.cpu / noise_adc_cpu, noise_adc_cpu / floor_t.cpu);
  write_bench_csv(o.out_dir, "bench_sense.csv", csv);
}

}  // namespace

static BenchRegistrar reg("sense",
                          "sense stage: its time against its memory floor, and Philox4x32-10 against -7 (docs/bench_sense.csv)",
                          [](CLI::App* sub) {
                            auto o = std::make_shared<BenchSenseOptions>();
                            sub->add_option("--out-dir", o->out_dir, "where the CSV goes (default docs/)");
                            sub->add_option("--repeats", o->repeats, "alternating rounds (best of each)")->capture_default_str();
                            sub->add_option("--inner", o->inner, "calls per timing")->capture_default_str();
                            sub->add_option("--width", o->width)->capture_default_str();
                            sub->add_option("--height", o->height)->capture_default_str();
                            sub->callback([o] { run_bench(*o); });
                          });

}  // namespace photosite::bench
