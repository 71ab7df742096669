// Helpers shared by the test files: running the photosite binary, temporary folders, and the
// location of ../shared test data (tests that need it skip loudly when it is absent).
#pragma once
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "photosite/image.h"
#include "photosite/io.h"
#include "photosite/scene/labels.h"

namespace photosite::test {

struct CliResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

// The message of the photosite::Error that fn throws, or "" when it throws none.
std::string error_of(const std::function<void()>& fn);

// Runs `photosite <args>` through the shell; args are passed verbatim (quote paths yourself).
CliResult run_cli(const std::string& args);

// A fresh, empty folder under the build tree's temp area, removed when the object dies.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::filesystem::path& path() const { return path_; }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// Runs each (command, message) case of a preview flag's bad input: its {o}, {p} and {r} become
// tmp's o.exr, o.png and none.exr; each must exit 2 with the message and leave neither o.exr nor
// o.png behind (bad input is refused before any output).
void expect_preview_flag_refused(const TempDir& tmp, const std::vector<std::pair<std::string, std::string>>& cases);

// ../shared beside the checkout, or empty when absent.
std::filesystem::path shared_dir();

// A shared KITTI label image in its day image's frame (width x height): PROVENANCE.txt describes an
// older copy whose labels were 1242x375 for 1224x370 images, offset (18, 4): such labels are
// cropped, same-size ones taken as they are.
photosite::ImageU16 kitti_labels_in_frame(const photosite::ImageU16& raw, int width, int height);

// The bundled KITTI sample (samples/kitti/000000_10, the README's main job): its day image as read
// (read_image), the file's info, and its labels (labelIds, the image's size).
struct KittiSample {
  photosite::ImageF day;
  photosite::ImageFileInfo info;
  photosite::scene::LabelMap labels;
};
KittiSample bundled_kitti_sample();

}  // namespace photosite::test

// Skips the current test with a loud message when ../shared/<sub> is absent.
#define PHOTOSITE_REQUIRE_SHARED(sub)                                                        \
  do {                                                                                       \
    auto _d = ::photosite::test::shared_dir();                                               \
    if (_d.empty() || !std::filesystem::exists(_d / (sub))) {                                \
      std::fprintf(stderr,                                                                   \
                   "\n*** SKIPPING: ../shared/%s is absent; this test needs the shared test " \
                   "data beside the checkout ***\n\n",                                       \
                   std::string(sub).c_str());                                                \
      GTEST_SKIP() << "../shared/" << (sub) << " absent";                                    \
    }                                                                                        \
  } while (0)
