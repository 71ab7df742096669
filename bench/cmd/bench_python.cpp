// `photosite bench python`: the Python module's benchmark (bench/python_bench.py, run by Debian's
// /usr/bin/python3 with this build's module on PYTHONPATH): `night` from Python against the C++
// chain in the same process, and DataLoader images/s with 1 and 2 workers against CLI + files.
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "bench.h"
#include "photosite/error.h"

namespace photosite::bench {
namespace {
struct PythonBench {
  std::string out_dir;
  int frames = 4, repeats = 3;
};

void run(const PythonBench& b) {
  namespace fs = std::filesystem;
  const fs::path build = fs::read_symlink("/proc/self/exe").parent_path();
  const fs::path module_dir = build / "python";
  if (!fs::is_directory(module_dir / "photosite"))
    fail_at(module_dir.string(), "no Python module here: build with -DPHOTOSITE_PYTHON=ON (scripts/setup.sh)");
  const std::string script = std::string(PHOTOSITE_SOURCE_DIR) + "/bench/python_bench.py";
  const std::string exe = build / "photosite";
  setenv("PYTHONPATH", module_dir.c_str(), 1);
  const std::string frames = std::to_string(b.frames), repeats = std::to_string(b.repeats);
  std::vector<const char*> argv = {"/usr/bin/python3", script.c_str(), "--photosite", exe.c_str(),
                                   "--frames", frames.c_str(), "--repeats", repeats.c_str()};
  if (!b.out_dir.empty()) {
    argv.push_back("--out-dir");
    argv.push_back(b.out_dir.c_str());
  }
  argv.push_back(nullptr);
  std::fflush(stdout);
  execv(argv[0], const_cast<char* const*>(argv.data()));
  fail("bench python: cannot run /usr/bin/python3 (install python3, scripts/setup.sh)");
}
}  // namespace

static BenchRegistrar reg("python", "Python module: night overhead vs the C++ chain, DataLoader images/s vs CLI + files",
                          [](CLI::App* sub) {
                            auto b = std::make_shared<PythonBench>();
                            sub->add_option("--out-dir", b->out_dir, "folder for the CSV and chart (default docs/)");
                            sub->add_option("--frames", b->frames, "frames through each loader")->capture_default_str();
                            sub->add_option("--repeats", b->repeats, "night calls timed for the overhead (median)")
                                ->capture_default_str();
                            sub->callback([b] { run(*b); });
                          });
}  // namespace photosite::bench
