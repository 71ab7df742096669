#include <fstream>
#include <thread>
#include <vector>

#include "bench.h"
#include "registry.h"

namespace photosite::cli {
namespace {
struct Target { std::string name, help; std::function<void(CLI::App*)> setup; };
std::vector<Target>& targets() { static std::vector<Target> t; return t; }
}  // namespace

void register_bench(const std::string& name, const std::string& help,
                    const std::function<void(CLI::App* sub)>& setup) {
  targets().push_back({name, help, setup});
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

static Registrar reg("m-bench", [](CLI::App& app) {
  auto* bench = app.add_subcommand("bench", "run a benchmark; writes CSV and a chart to docs/");
  bench->require_subcommand(1);
  for (auto& t : targets()) t.setup(bench->add_subcommand(t.name, t.help));
});
}  // namespace photosite::cli
