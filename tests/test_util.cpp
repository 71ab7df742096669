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

void expect_preview_flag_refused(const TempDir& tmp, const std::vector<std::pair<std::string, std::string>>& cases) {
  for (const auto& [cmd, what] : cases) {
    std::string args = cmd;
    for (const auto& [key, file] : {std::pair<std::string, std::string>{"{o}", "o.exr"}, {"{p}", "o.png"}, {"{r}", "none.exr"}})
      if (const size_t at = args.find(key); at != std::string::npos) args.replace(at, key.size(), tmp.file(file));
    const auto r = run_cli(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(what), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(tmp.file("o.exr"))) << args;
    EXPECT_FALSE(std::filesystem::exists(tmp.file("o.png"))) << args;
  }
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
