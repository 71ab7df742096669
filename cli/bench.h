// `photosite bench <target>`: benchmarks that write CSV and charts to docs/. Each target
// registers itself with a BenchRegistrar from its own cli/bench_*.cpp.
#pragma once
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <functional>
#include <string>

namespace photosite::cli {
// setup(sub) adds the target's options to `sub` and sets its callback.
void register_bench(const std::string& name, const std::string& help,
                    const std::function<void(CLI::App* sub)>& setup);
struct BenchRegistrar {
  BenchRegistrar(const std::string& name, const std::string& help,
                 const std::function<void(CLI::App* sub)>& setup) {
    register_bench(name, help, setup);
  }
};
// Where results go (docs/ in the source tree unless --out-dir is given), and the machine name
// (CPU model and core count) to print beside absolute times.
std::string machine_description();
// Writes `csv` atomically to <out_dir or docs/>/<name> and prints the path.
std::string write_bench_csv(const std::string& out_dir, const std::string& name, const std::string& csv);
// The best (smallest) wall time of `repeats` calls of f, in ms: the least-disturbed run.
template <class F>
double best_ms(int repeats, F&& f) {
  double best = 1e300;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    best = std::min(best, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  return best;
}
}  // namespace photosite::cli
