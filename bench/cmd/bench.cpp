// The bench targets' registry and the helpers they share (bench.h).
#include "bench.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>
#include <vector>

#include "photosite/error.h"
#include "photosite/io.h"

namespace photosite::bench {
namespace {
struct Target { std::string name, help; std::function<void(CLI::App*)> setup; };
std::vector<Target>& targets() { static std::vector<Target> t; return t; }
}  // namespace

void register_bench(const std::string& name, const std::string& help,
                    const std::function<void(CLI::App* sub)>& setup) {
  targets().push_back({name, help, setup});
}

void add_bench_targets(CLI::App* bench) {
  for (auto& t : targets()) t.setup(bench->add_subcommand(t.name, t.help));
}

std::string machine_description() {
  std::ifstream f("/proc/cpuinfo");
  std::string line, model = "unknown CPU";
  while (std::getline(f, line))
    if (line.rfind("model name", 0) == 0) {
      model = line.substr(line.find(':') + 2);
      break;
    }
  return model + ", " + std::to_string(std::thread::hardware_concurrency()) + " hardware threads";
}

std::string write_bench_csv(const std::string& out_dir, const std::string& name, const std::string& csv) {
  namespace fs = std::filesystem;
  const fs::path dir = out_dir.empty() ? fs::path(PHOTOSITE_SOURCE_DIR) / "docs" : fs::path(out_dir);
  const std::string path = (dir / name).string();
  check_output_path(path, true);
  atomic_write(path, [&](const std::string& tmp) {
    std::ofstream f(tmp);
    f << csv;
    if (!f) fail_at(path, "cannot write");
  });
  std::printf("%s\n", path.c_str());
  return path;
}
ScratchDir::ScratchDir(const std::string& tag)
    : path_(std::filesystem::temp_directory_path() /
            ("photosite-bench-" + tag + "-" + std::to_string(static_cast<long>(::getpid())))) {
  std::filesystem::remove_all(path_);
  std::filesystem::create_directories(path_);
}
ScratchDir::~ScratchDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

}  // namespace photosite::bench
