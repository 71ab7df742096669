// Processes sharing one device store: several `photosite flat` runs started at the same moment
// need the same device's fixed-pattern maps, which none of them finds. Exactly one may create
// the map; the others must wait for it (flock on the store folder) or, having lost a race, load
// it (no-replace publish), so every output is made with the one map in the store.
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <fmt/format.h>

#include "photosite/io.h"
#include "test_util.h"

using namespace photosite;
namespace fs = std::filesystem;

namespace {
size_t count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}
std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), {}};
}
}  // namespace

TEST(DeviceStoreConcurrency, FourProcessesStartedTogetherUseOneMap) {
  constexpr int kProcs = 4;
  test::TempDir dir;
  const std::string store = dir.file("store"), gun = dir.file("start"), ready = dir.file("ready");
  ASSERT_EQ(mkfifo(gun.c_str(), 0600), 0);
  fs::create_directories(ready);
  // A barrier with no timing assumption. The parent holds the FIFO open read-write (fd 3), so a
  // child's open for reading returns at once; each child closes its inherited fd 3, opens the FIFO
  // (fd 4), says it is ready and blocks reading. When all are ready the parent closes the last
  // writer and every child's read returns end-of-file at the same moment; only then does each
  // exec photosite. A 1024x768 map takes long enough to generate and write that they overlap.
  std::string cmd = fmt::format("bash -c 'exec 3<>\"{}\"; ", gun);
  for (int i = 0; i < kProcs; ++i)
    cmd += fmt::format("(exec 3>&-; exec 4<\"{}\"; touch \"{}/{}\"; cat <&4 > /dev/null; exec 4<&-; "
                       "exec \"{}\" flat --photons 100 --wavelength-nm 525 "
                       "--preset sony-imx490 --width 1024 --height 768 --device-id race "
                       "--device-store \"{}\" --out \"{}\" 2> \"{}\") & ",
                       gun, ready, i, PHOTOSITE_BIN, store, dir.file(fmt::format("o{}.exr", i)),
                       dir.file(fmt::format("e{}.txt", i)));
  // Wait (up to 120 s on a loaded machine) until all are blocked on the FIFO, then release them.
  cmd += fmt::format("for t in $(seq 12000); do [ $(ls \"{}\" | wc -l) -ge {} ] && break; sleep 0.01; done; "
                     "exec 3>&-; fail=0; for j in $(jobs -p); do wait $j || fail=1; done; exit $fail'",
                     ready, kProcs);
  ASSERT_EQ(std::system(cmd.c_str()), 0);

  std::string all_stderr;
  for (int i = 0; i < kProcs; ++i) all_stderr += slurp(dir.file(fmt::format("e{}.txt", i)));
  EXPECT_EQ(count(all_stderr, "created the fixed-pattern map"), 1u) << all_stderr;

  EXPECT_EQ(std::distance(fs::directory_iterator(ready), fs::directory_iterator()), kProcs);
  std::vector<fs::path> files;
  for (const auto& e : fs::recursive_directory_iterator(store))
    if (!e.is_directory()) files.push_back(e.path());
  ASSERT_EQ(files.size(), 1u) << "expected one map and no lock or temporary files";
  const auto map = read_exr(files[0].string());
  const std::string checksum = map.attributes.at("photosite/checksum");
  for (int i = 0; i < kProcs; ++i) {
    const auto out = read_exr(dir.file(fmt::format("o{}.exr", i)));
    EXPECT_EQ(out.attributes.at("photosite/fpn_checksum"), checksum) << i;
  }
}

// The no-replace publish on its own (the path taken where flock is unavailable): the second
// writer finds the first one's file, keeps it untouched and leaves no temporary.
TEST(DeviceStoreConcurrency, CreateOnlyNeverReplacesAndCleansUp) {
  test::TempDir dir;
  const std::string path = dir.file("m.exr");
  EXPECT_TRUE(atomic_create(path, [](const std::string& tmp) { std::ofstream(tmp) << "first"; }));
  EXPECT_FALSE(atomic_create(path, [](const std::string& tmp) { std::ofstream(tmp) << "second"; }));
  EXPECT_EQ(slurp(path), "first");
  size_t n = 0;
  for (const auto& e : fs::directory_iterator(dir.path())) n += e.exists();
  EXPECT_EQ(n, 1u);
  ImageF img(4, 4, 1, 1.f);
  ExrWriteOptions wo;
  wo.create_only = true;
  EXPECT_FALSE(write_exr(path, {{{"Y"}, &img, ""}}, {}, wo));
  EXPECT_EQ(slurp(path), "first");
}
