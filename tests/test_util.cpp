#include "test_util.h"

#include "photosite/error.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <atomic>
#include <sys/wait.h>

namespace photosite::test {

std::string error_of(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

CliResult run_cli(const std::string& args) {
  // Never touch the user's own device store from the tests (ctest sets one; plain runs get a
  // private folder).
  static const bool store_set = [] {
    if (!std::getenv("PHOTOSITE_DEVICE_STORE"))
      setenv("PHOTOSITE_DEVICE_STORE",
             (std::filesystem::temp_directory_path() / ("photosite-test-store-" + std::to_string(getpid()))).c_str(), 1);
    return true;
  }();
  (void)store_set;
  CliResult r;
  std::string cmd = std::string("'") + PHOTOSITE_BIN + "' " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.output.append(buf.data(), n);
  int status = pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return r;
}

TempDir::TempDir() {
  static std::atomic<int> counter{0};
  path_ = std::filesystem::temp_directory_path() /
          ("photosite-test-" + std::to_string(getpid()) + "-" + std::to_string(counter++));
  std::filesystem::remove_all(path_);
  std::filesystem::create_directories(path_);
}
TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

// The bound on differing sensor samples, derived rather than fitted. A pixel's mean electron
// count μ is linear in its radiance (the photon integral weights R, G, B by the QE bands), so the
// two backends' means differ by δμ ≤ μ · r with r = max_c |L_a,c − L_b,c| / L_a,c. An inversion
// draw F⁻¹(u; μ) changes only when u falls in the slice that F(k; μ) sweeps as μ moves by δμ,
// which has probability Σ_k |∂F(k; μ)/∂μ| δμ = Σ_k p(k; μ) δμ = δμ; a normal-based draw
// k = ⌊μ + √μ z + …⌉ crosses a count with probability δμ (1 + |z|/(2√μ)) < 2 δμ for μ ≥ 10 and
// |z| < 5.9. Read noise, offsets and the ADC are the same function of the count on both
// backends, so a DN differs only where the count does. Hence E[#differing] ≤ Σ_i min(1, 2 μ_i r_i)
// (μ_i estimated by the first run's electron sample, unbiased), and the count, a sum of
// independent Bernoulli trials, stays below E + 5 √E + 1 (5 σ of a Poisson-binomial, variance ≤ E).
double differing_sensor_samples_bound(const std::map<std::string, photosite::ImageF>& a,
                                      const std::map<std::string, photosite::ImageF>& b) {
  const photosite::ImageF& e = a.at("electrons.Y");
  double expected = 0;
  for (size_t i = 0; i < e.size(); ++i) {
    double r = 0;
    for (const char* c : {"night_radiance.R", "night_radiance.G", "night_radiance.B"}) {
      const double x = a.at(c)[i], y = b.at(c)[i];
      if (x != y) r = std::max(r, x > 0 ? std::fabs(x - y) / x : 1.0);
    }
    expected += std::min(1.0, 2.0 * std::max<double>(e[i], 1.0) * r);
  }
  return expected + 5 * std::sqrt(expected) + 1;
}

ImageU16 kitti_labels_in_frame(const ImageU16& raw, int width, int height) {
  ImageU16 crop(width, height, 1);
  const int ox = raw.width() == width ? 0 : 18, oy = raw.height() == height ? 0 : 4;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      crop.at(x, y) = raw.at(std::min(raw.width() - 1, x + ox), std::min(raw.height() - 1, y + oy));
  return crop;
}

KittiSample bundled_kitti_sample() {
  const std::string dir = std::string(PHOTOSITE_SOURCE_DIR) + "/samples/kitti/";
  KittiSample k;
  k.day = read_image(dir + "image_2/000000_10.png", &k.info);
  k.labels = scene::read_labels(dir + "semantic/000000_10.png", "", k.day.width(), k.day.height(),
                                scene::LabelFormat::Auto, scene::ResizeLabels::None);
  return k;
}

std::filesystem::path shared_dir() {
  std::filesystem::path p = PHOTOSITE_SHARED_DIR;
  std::error_code ec;
  if (std::filesystem::is_directory(p, ec)) return std::filesystem::canonical(p);
  return {};
}

}  // namespace photosite::test
