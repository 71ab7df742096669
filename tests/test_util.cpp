#include "test_util.h"

#include <unistd.h>

#include <array>
#include <cstdlib>
#include <atomic>
#include <sys/wait.h>

namespace photosite::test {

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

std::filesystem::path shared_dir() {
  std::filesystem::path p = PHOTOSITE_SHARED_DIR;
  std::error_code ec;
  if (std::filesystem::is_directory(p, ec)) return std::filesystem::canonical(p);
  return {};
}

}  // namespace photosite::test
