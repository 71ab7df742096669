// `photosite bench noise`: per-pixel Poisson sampling over a 2048x1024 frame with means from 0.5
// to 5000 e-, timed in one run against std::poisson_distribution, OpenCV's cv::randn Gaussian
// approximation and numpy (when /usr/bin/python3 has it); accuracy as the Kolmogorov-Smirnov
// distance to the exact Poisson CDF at low means. Also times the whole expose chain (no I/O).
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "bench.h"
#include "photosite/error.h"
#include "photosite/sensor/pipeline.h"
#include "photosite/sensor/poisson.h"

namespace photosite::cli {
namespace {


// Kolmogorov-Smirnov distance between n samples and Poisson(mu), on the integers.
double ks_distance(std::vector<float> s, double mu) {
  std::sort(s.begin(), s.end());
  double worst = 0, cdf = 0, pmf = std::exp(-mu);
  size_t idx = 0;
  const long kmax = static_cast<long>(mu + 12 * std::sqrt(mu) + 30);
  for (long k = 0; k <= kmax; ++k) {
    if (k > 0) pmf *= mu / k;
    cdf += pmf;
    while (idx < s.size() && s[idx] <= k) ++idx;
    worst = std::max(worst, std::fabs(static_cast<double>(idx) / s.size() - cdf));
  }
  return worst;
}

struct Sampler {
  std::string name;
  int threads;
  // fills out[i] for means[i], frame f
  std::function<void(const std::vector<float>& means, std::vector<float>& out, uint32_t frame)> run;
};

struct BenchNoiseOptions {
  std::string out_dir = std::string(PHOTOSITE_SOURCE_DIR) + "/docs";
  int repeats = 5;
  int width = 2048, height = 1024;
};

void run_bench(const BenchNoiseOptions& o) {
  namespace fs = std::filesystem;
  if (!fs::is_directory(o.out_dir)) fail_at(o.out_dir, "output folder does not exist");
  const int threads = omp_get_max_threads();
  const size_t n = static_cast<size_t>(o.width) * o.height;
  // Means log-uniform from 0.5 to 5000 along each row (a smooth image-like ramp).
  std::vector<float> means(n), out(n);
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x)
      means[static_cast<size_t>(y) * o.width + x] =
          static_cast<float>(0.5 * std::pow(1e4, (x + 0.5 * (y % 2)) / (o.width - 1.0)));

  std::vector<Sampler> samplers;
  samplers.push_back({"photosite exact (Philox, inversion + corrected normal)", threads,
                      [](const std::vector<float>& m, std::vector<float>& r, uint32_t f) {
                        poisson_fill(m.data(), r.data(), m.size(), 0, 1234, f, 1, PoissonMethod::Exact);
                      }});
  samplers.push_back({"photosite normal approx (Philox, rounded N(mu,mu))", threads,
                      [](const std::vector<float>& m, std::vector<float>& r, uint32_t f) {
                        poisson_fill(m.data(), r.data(), m.size(), 0, 1234, f, 1, PoissonMethod::Normal);
                      }});
  for (int t : {1, threads}) {
    samplers.push_back({fmt::format("std::poisson_distribution (mt19937_64, {} thread{})", t, t > 1 ? "s" : ""), t,
                        [t](const std::vector<float>& m, std::vector<float>& r, uint32_t f) {
                          const int64_t n = static_cast<int64_t>(m.size());
#pragma omp parallel num_threads(t)
                          {
                            std::mt19937_64 rng(1234 + 7919 * f + omp_get_thread_num());
#pragma omp for schedule(static)
                            for (int64_t i = 0; i < n; ++i)
                              r[i] = static_cast<float>(std::poisson_distribution<int>(m[i])(rng));
                          }
                        }});
    if (t == threads) break;
  }
  samplers.push_back({"cv::randn + round(mu + sqrt(mu) z) (OpenCV Gaussian approx)", cv::getNumThreads(),
                      [](const std::vector<float>& m, std::vector<float>& r, uint32_t f) {
                        cv::Mat z(1, static_cast<int>(m.size()), CV_32F, r.data());
                        cv::RNG rng(1234 + f);
                        rng.fill(z, cv::RNG::NORMAL, 0.0, 1.0);
                        const int64_t n = static_cast<int64_t>(m.size());
#pragma omp parallel for schedule(static)
                        for (int64_t i = 0; i < n; ++i)
                          r[i] = std::max(0.f, std::nearbyint(m[i] + std::sqrt(m[i]) * r[i]));
                      }});
  samplers.push_back({"cv::randn alone (N(0,1), no Poisson)", 1,
                      [](const std::vector<float>& m, std::vector<float>& r, uint32_t f) {
                        cv::Mat z(1, static_cast<int>(m.size()), CV_32F, r.data());
                        cv::theRNG().state = 1234 + f;
                        cv::randn(z, 0.0, 1.0);
                      }});

  const std::vector<double> ks_means = {0.5, 2.0, 8.0, 30.0, 200.0};
  std::string csv = "sampler,threads,ms_per_frame,mpx_per_s";
  for (double mu : ks_means) csv += fmt::format(",ks_mean_{}", mu);
  csv += ",ks_max\n";
  std::printf("Poisson sampling, %dx%d frame, means 0.5..5000 e- log-uniform; %s\n", o.width, o.height,
              machine_description().c_str());
  std::printf("%-62s %7s %10s %10s\n", "sampler", "threads", "ms/frame", "KS max");
  std::vector<double> times;
  for (auto& s : samplers) {
    uint32_t frame = 0;
    const double ms = best_ms(o.repeats, [&] { s.run(means, out, frame++); });
    times.push_back(ms);
    // Accuracy: 400k draws at each low mean (the pure randn row has no Poisson output).
    std::vector<double> ks;
    double ks_max = 0;
    const bool is_poisson = s.name.find("alone") == std::string::npos;
    for (double mu : ks_means) {
      if (!is_poisson) {
        ks.push_back(NAN);
        continue;
      }
      std::vector<float> m(400000, static_cast<float>(mu)), r(m.size());
      s.run(m, r, 1000);
      ks.push_back(ks_distance(r, mu));
      ks_max = std::max(ks_max, ks.back());
    }
    csv += fmt::format("\"{}\",{},{:.3f},{:.1f}", s.name, s.threads, ms, n / ms / 1e3);
    for (double k : ks) csv += std::isnan(k) ? "," : fmt::format(",{:.5f}", k);
    csv += is_poisson ? fmt::format(",{:.5f}\n", ks_max) : ",\n";
    std::printf("%-62s %7d %10.2f %10s\n", s.name.c_str(), s.threads, ms,
                is_poisson ? fmt::format("{:.4f}", ks_max).c_str() : "-");
  }
  // numpy, when the system Python has it: the same frame of means, timed in the same run.
  {
    const std::string means_path = o.out_dir + "/.bench_noise_means.bin";
    {
      std::ofstream f(means_path, std::ios::binary);
      f.write(reinterpret_cast<const char*>(means.data()), means.size() * sizeof(float));
    }
    const std::string script = std::string(PHOTOSITE_SOURCE_DIR) + "/bench/numpy_poisson.py";
    std::string cmd = "/usr/bin/python3 '" + script + "' '" + means_path + "' " + std::to_string(o.repeats) + " 2>/dev/null";
    FILE* p = popen(cmd.c_str(), "r");
    char buf[512] = {0};
    std::string line;
    if (p) {
      while (fgets(buf, sizeof buf, p)) line += buf;
      pclose(p);
    }
    fs::remove(means_path);
    if (!line.empty() && line.find(',') != std::string::npos) {
      csv += line;
      std::printf("numpy: %s", line.c_str());
    } else {
      std::printf("numpy: not available to /usr/bin/python3, skipped\n");
    }
  }
  const double exact = times[0], std_t = times[2 + (threads > 1 ? 1 : 0)], std1 = times[2];
  const double randn_approx = times[times.size() - 2], randn_alone = times.back();
  std::printf("\nphotosite exact vs std::poisson_distribution (same threads): %.1fx faster (single-thread std: %.1fx)\n",
              std_t / exact, std1 / exact);
  std::printf("photosite exact vs cv::randn Gaussian approximation: %.2fx the time; vs cv::randn alone: %.2fx\n",
              exact / randn_approx, exact / randn_alone);
  csv += fmt::format("# machine: {}\n# speedup_vs_std_same_threads={:.2f} time_ratio_vs_cv_randn_approx={:.3f} time_ratio_vs_cv_randn_alone={:.3f}\n",
                     machine_description(), std_t / exact, exact / randn_approx, exact / randn_alone);

  // The whole expose chain (no file I/O) at the same size, per stage.
  {
    CameraPreset cam = load_camera_preset("onsemi-ar0331");
    LensPreset lens = load_lens_preset(cam.default_lens);
    ImageF radiance(o.width, o.height, 3);
    for (int y = 0; y < o.height; ++y)
      for (int x = 0; x < o.width; ++x)
        for (int c = 0; c < 3; ++c)
          radiance.at(x, y, c) = static_cast<float>(1e-4 * std::pow(1e3, x / (o.width - 1.0)) * (1 + 0.3 * c));
    auto fpn = generate_fixed_pattern(cam, o.width, o.height, "bench");
    ExposureSettings s;
    const auto ex = resolve(cam, lens, s);
    ImageF mean_e;
    SensorOutput so;
    const double t_photon = best_ms(o.repeats, [&] { mean_e = mean_signal_electrons(radiance, cam, lens, ex); });
    const double t_sense = best_ms(o.repeats, [&] { so = sense(mean_e, cam, ex, s, fpn); });
    const double t_demosaic = best_ms(o.repeats, [&] { auto rgb = demosaic(so.raw_dn, cam.cfa, DemosaicMethod::Bilinear); });
    const double t_total = best_ms(o.repeats, [&] { so = expose(radiance, cam, lens, s, fpn); });
    std::printf("\nexpose chain, %dx%d, onsemi-ar0331 (no file I/O), ms:\n", o.width, o.height);
    std::printf("  optics + photon integral        %8.2f\n", t_photon);
    std::printf("  noise + ADC + demosaic (sense)  %8.2f\n", t_sense);
    std::printf("    of which bilinear demosaic    %8.2f\n", t_demosaic);
    std::printf("  whole chain                     %8.2f\n", t_total);
    std::ofstream f(o.out_dir + "/bench_expose.csv");
    f << "stage,ms_per_frame\n"
      << fmt::format("optics_photon_integral,{:.3f}\nnoise_adc_demosaic,{:.3f}\nbilinear_demosaic,{:.3f}\nwhole_chain,{:.3f}\n",
                     t_photon, t_sense, t_demosaic, t_total)
      << "# " << o.width << "x" << o.height << ", onsemi-ar0331, " << machine_description() << "\n";
  }

  const std::string csv_path = o.out_dir + "/bench_noise.csv";
  std::ofstream(csv_path) << csv;
  std::printf("\nwrote %s and %s/bench_expose.csv\n", csv_path.c_str(), o.out_dir.c_str());
  const std::string chart = std::string(PHOTOSITE_SOURCE_DIR) + "/bench/chart_noise.py";
  const std::string cmd = "/usr/bin/python3 '" + chart + "' '" + csv_path + "' '" + o.out_dir + "/bench_noise.png'";
  if (std::system(cmd.c_str()) != 0) std::printf("chart: /usr/bin/python3 with matplotlib failed; CSV written\n");
  else std::printf("wrote %s/bench_noise.png\n", o.out_dir.c_str());
}
}  // namespace

static BenchRegistrar reg("noise", "Poisson sampler speed and accuracy vs std::, OpenCV, numpy; expose chain timing",
                          [](CLI::App* sub) {
                            auto o = std::make_shared<BenchNoiseOptions>();
                            sub->add_option("--out-dir", o->out_dir, "where CSV and chart go")->capture_default_str();
                            sub->add_option("--repeats", o->repeats, "best of N runs")->capture_default_str();
                            sub->add_option("--width", o->width)->capture_default_str();
                            sub->add_option("--height", o->height)->capture_default_str();
                            sub->callback([o] { run_bench(*o); });
                          });
}  // namespace photosite::cli
