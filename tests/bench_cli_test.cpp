// `photosite bench`: the checks every target shares (bench/cmd/bench.cpp), run on every target the
// binary lists, and the bench results that were wrong (bench sense's one-round difference, bench
// python's temporary device store).
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "test_util.h"

namespace fs = std::filesystem;
using photosite::test::run_cli;

namespace {
// The words of the indented lines after `heading` in a --help text (CLI11's lists of subcommands
// and options), each line's first word.
std::vector<std::string> help_list(const std::string& help, const std::string& heading) {
  std::vector<std::string> words;
  const size_t at = help.find(heading);
  if (at == std::string::npos) return words;
  std::istringstream in(help.substr(at + heading.size()));
  for (std::string line; std::getline(in, line);) {
    if (line.empty()) continue;
    if (line.rfind("  ", 0) != 0) break;
    std::istringstream w(line);
    std::string first;
    w >> first;
    words.push_back(first.substr(0, first.find(',')));
  }
  return words;
}
std::vector<std::string> targets() {
  const auto h = run_cli("bench --help");
  EXPECT_EQ(h.exit_code, 0) << h.output;
  return help_list(h.output, "Subcommands:");
}
std::vector<std::string> options_of(const std::string& target) {
  const auto h = run_cli("bench " + target + " --help");
  EXPECT_EQ(h.exit_code, 0) << h.output;
  // "-h,--help" lists first; the options' names follow the same indentation.
  std::vector<std::string> names;
  for (const auto& w : help_list(h.output, "Options:")) names.push_back(w.rfind("-h", 0) == 0 ? "--help" : w);
  return names;
}
std::vector<std::string> csv_cells(const std::string& path) {
  std::ifstream f(path);
  std::vector<std::string> cells;
  for (std::string line; std::getline(f, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
  }
  return cells;
}
}  // namespace

// Every target has the options the docs name, and the shared checks are on each of them: a count
// of 0 or -1 and a frame side of 1 exit 2 naming the option, before any work (nothing written).
TEST(Bench, EveryTargetRefusesZeroCountsAndTooSmallFrames) {
  const auto t = targets();
  ASSERT_GE(t.size(), 10u);
  photosite::test::TempDir out;
  size_t checked = 0;
  for (const auto& target : t) {
    for (const auto& opt : options_of(target)) {
      std::vector<std::string> bad;
      if (opt == "--repeats" || opt == "--frames" || opt == "--inner" || opt == "--cycles" || opt == "--threads")
        bad = {"0", "-1"};
      else if (opt == "--width" || opt == "--height")
        bad = {"0", "1"};
      for (const auto& v : bad) {
        const std::string args = "bench " + target + " " + opt + " " + v + " --out-dir '" + out.path().string() + "'";
        const auto r = run_cli(args);
        EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
        EXPECT_NE(r.output.find(opt + ": " + v + " is not allowed: must be at least"), std::string::npos)
            << args << "\n" << r.output;
        ++checked;
      }
    }
  }
  // --repeats on 9 targets (depth has none), --frames on python, --inner on sense, --cycles on
  // batch, --threads on night, pipeline and realism, --width and --height on demosaic, noise and
  // sense: 21 options, two values each.
  EXPECT_EQ(checked, 42u);
  EXPECT_TRUE(fs::is_empty(out.path()));
}

// A missing --out-dir: every target exits 2 naming the folder, at once, and does not create it.
TEST(Bench, EveryTargetRefusesAMissingOutDirBeforeWork) {
  photosite::test::TempDir out;
  const fs::path nope = out.path() / "nope";
  for (const auto& target : targets()) {
    // depth needs --kitti to get as far as its work; the check comes before it reads that.
    const std::string args = "bench " + target + (target == "depth" ? " --kitti /nonexistent" : "") +
                             " --out-dir '" + nope.string() + "'";
    const auto r = run_cli(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(nope.string() + ": --out-dir: output folder does not exist"), std::string::npos)
        << args << "\n" << r.output;
    EXPECT_FALSE(fs::exists(nope)) << args;
  }
}

TEST(Bench, AWordThatIsNoTargetIsNamed) {
  const auto r = run_cli("bench nosuch");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("unknown target 'nosuch'; the targets are: batch, demosaic"), std::string::npos) << r.output;
  const auto none = run_cli("bench");
  EXPECT_EQ(none.exit_code, 2) << none.output;
  EXPECT_NE(none.output.find("bench: name a target: batch, demosaic"), std::string::npos) << none.output;
  // An unknown option of a real target stays CLI11's usage error.
  const auto bogus = run_cli("bench night --bogus");
  EXPECT_EQ(bogus.exit_code, 2) << bogus.output;
  EXPECT_NE(bogus.output.find("--bogus"), std::string::npos) << bogus.output;
}

// "noise + ADC" is sense minus the demosaic alone, each the best of --repeats rounds. With one
// round each was one sample, and a loaded machine's preemption made the difference negative in
// the CSV. Fewer than 3 rounds are refused; a run's durations are all positive, or NaN where
// every round was disturbed (never a negative time).
TEST(Bench, SenseRefusesTooFewRoundsAndWritesNoNegativeDuration) {
  photosite::test::TempDir out;
  for (const char* n : {"1", "2"}) {
    const auto r = run_cli(std::string("bench sense --repeats ") + n + " --inner 1 --width 256 --height 128 --out-dir '" +
                           out.path().string() + "'");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find(std::string("--repeats: ") + n + " is not allowed"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("at least 3 rounds"), std::string::npos) << r.output;
  }
  EXPECT_TRUE(fs::is_empty(out.path()));
  const auto r = run_cli("bench sense --repeats 3 --inner 1 --width 256 --height 128 --out-dir '" +
                         out.path().string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto cells = csv_cells(out.file("bench_sense.csv"));
  ASSERT_GE(cells.size(), 3u * 12) << r.output;
  size_t times = 0;
  for (size_t i = 3; i < cells.size(); ++i) {  // after the header's three names
    if (cells[i].empty() || std::isalpha(static_cast<unsigned char>(cells[i][0]))) continue;  // names, nan
    EXPECT_GT(std::stod(cells[i]), 0) << "cell " << i << " of\n" << r.output;
    ++times;
  }
  EXPECT_GE(times, 18u);
}

// bench python's fixed-pattern maps went to a mkdtemp store under /tmp that no run removed
// (25 MB each). With TMPDIR pointed at a fresh folder, the run leaves nothing there.
TEST(Bench, PythonLeavesNoTemporaryDeviceStore) {
  const fs::path module = fs::path(PHOTOSITE_BIN).parent_path() / "python" / "photosite";
  if (!fs::is_directory(module)) {
    std::fprintf(stderr, "\n*** SKIPPING: no Python module at %s (build _photosite) ***\n\n", module.c_str());
    GTEST_SKIP() << "no Python module";
  }
  photosite::test::TempDir tmp, out;
  const char* old = std::getenv("TMPDIR");
  const std::string saved = old ? old : "";
  setenv("TMPDIR", tmp.path().c_str(), 1);
  const auto r = run_cli("bench python --frames 1 --repeats 1 --out-dir '" + out.path().string() + "'");
  if (old) setenv("TMPDIR", saved.c_str(), 1);
  else unsetenv("TMPDIR");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(out.file("bench_python.csv"))) << r.output;
  for (const auto& e : fs::directory_iterator(tmp.path())) ADD_FAILURE() << "left in TMPDIR: " << e.path();
}
