// `photosite bench <target>`: benchmarks that write CSV and charts to docs/. They are built as
// their own static library (photosite_benchlib, from bench/cmd/*.cpp), linked whole into the
// `photosite` executable; each target registers itself with a BenchRegistrar from its own
// bench/cmd/bench_*.cpp, and cli/cmd_bench.cpp adds them under `photosite bench`.
#pragma once
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace photosite::bench {
// setup(sub) adds the target's options to `sub` and sets its callback.
void register_bench(const std::string& name, const std::string& help,
                    const std::function<void(CLI::App* sub)>& setup);
// Adds every registered target as a subcommand of `bench` (the command line's `photosite bench`),
// with the checks all targets share (bench.cpp: counts at least 1, the frame size, the output
// folder), run while the command line is parsed.
void add_bench_targets(CLI::App* bench);
struct BenchRegistrar {
  BenchRegistrar(const std::string& name, const std::string& help,
                 const std::function<void(CLI::App* sub)>& setup) {
    register_bench(name, help, setup);
  }
};
// Where results go (docs/ in the source tree unless --out-dir is given), and the machine name
// (CPU model and core count) to print beside absolute times.
std::string machine_description();
// The folder a target writes into: out_dir, or docs/ in the source tree when it is empty.
std::filesystem::path output_folder(const std::string& out_dir);
// The shared frames under `data` (../shared/data): every Cityscapes leftImg8bit with its gtFine
// labelIds (and instanceIds), every KITTI image_2 with its semantic labelIds, at most max_frames
// of each data set (0: all). Cameras as `photosite night` uses them (Cityscapes: onsemi AR0331;
// KITTI: Sony ICX267 on the Point Grey Flea2). Bad input naming `data` (and `who`, the command)
// when either data set is missing.
struct SharedFrame {
  std::string dataset, name, image, labels, instances, camera;
};
std::vector<SharedFrame> shared_frames(const std::filesystem::path& data, int max_frames, const std::string& who);
// Draws a bench's chart with Debian's matplotlib: /usr/bin/python3 <source tree>/script csv_path
// png_path. True when it ran; else prints that only the CSV was written (no chart is not an error:
// the figures are in the CSV).
bool draw_chart(const std::string& script, const std::string& csv_path, const std::string& png_path);
// Writes `csv` atomically to <out_dir or docs/>/<name> and prints the path.
std::string write_bench_csv(const std::string& out_dir, const std::string& name, const std::string& csv);
// The wall time of one call of f, in ms.
template <class F>
double time_ms(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
// The best (smallest) wall time of `repeats` calls of f, in ms: the least-disturbed run.
template <class F>
double best_ms(int repeats, F&& f) {
  double best = 1e300;
  for (int r = 0; r < repeats; ++r) best = std::min(best, time_ms(f));
  return best;
}
// The median of a set of timings (the upper middle for an even count), 0 when empty.
inline double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}
// A fresh scratch folder photosite-bench-<tag>-<pid> under the system's temporary folder,
// removed with everything in it when the object goes (also when the bench fails).
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& tag);
  ~ScratchDir();
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace photosite::bench
