// The bench targets' registry and the helpers they share (bench.h).
#include "bench.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>
#include <vector>

#include "core/isa_detail.h"
#include "photosite/environment.h"
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

namespace {
// An integer option's lower bound, checked while the command line is parsed (exit 2 naming the
// option, before any work). A value that is not an integer is left to the option's own
// conversion, which refuses it with its usual message.
CLI::Validator at_least(long lo) {
  return CLI::Validator(
      [lo](std::string& s) -> std::string {
        size_t end = 0;
        long v = 0;
        try {
          v = std::stol(s, &end);
        } catch (const std::exception&) {
          return {};
        }
        if (end != s.size() || v >= lo) return {};
        return fmt::format("{} is not allowed: must be at least {}", s, lo);
      },
      fmt::format("at least {}", lo));
}

// The checks every target shares, added to whichever of these options the target has:
//  * the counts (--repeats, --frames, --inner, --cycles, --threads) at least 1: none of zero
//    timings gives a time (a sentinel or a crash), and OpenMP takes no 0 or negative thread
//    count (it would run the default and the CSV would record the flag's value); a target may
//    narrow the range further (batch's --repeats in [1, 20]);
//  * the frame size (--width, --height) at least 2 pixels: the radiance and mean ramps of bench
//    noise and sense divide by width - 1 (a NaN frame at 1), and the mosaic needs one whole
//    2x2 Bayer tile (bench sense also wants the width a multiple of 8, its own check);
//  * the output folder (--out-dir, or docs/ when it is not given) must exist and be writable,
//    checked when the command line is parsed, so a wrong path fails before minutes of work.
//    No target creates it (docs/cli.md, "photosite bench").
constexpr int kMinSide = 2;
void add_shared_checks(CLI::App* sub) {
  for (const char* name : {"--repeats", "--frames", "--inner", "--cycles", "--threads"})
    if (CLI::Option* opt = sub->get_option_no_throw(name)) opt->check(at_least(1));
  // --threads at most what a parallel region runs on (libgomp's stack: include/photosite/environment.h).
  if (CLI::Option* opt = sub->get_option_no_throw("--threads"))
    opt->check(CLI::Range(1, kMaxOpenmpThreads, fmt::format("at most {}", kMaxOpenmpThreads)));
  // --max-frames: 0 is all; a negative count was taken as all too (bench depth).
  if (CLI::Option* opt = sub->get_option_no_throw("--max-frames")) opt->check(at_least(0));
  for (const char* name : {"--width", "--height"})
    if (CLI::Option* opt = sub->get_option_no_throw(name)) opt->check(at_least(kMinSide));
  if (CLI::Option* opt = sub->get_option_no_throw("--out-dir"))
    sub->parse_complete_callback([opt] {
      const std::string given = opt->count() ? opt->as<std::string>() : opt->get_default_str();
      const std::filesystem::path dir = output_folder(given);
      std::error_code ec;
      if (std::filesystem::exists(dir, ec) && !std::filesystem::is_directory(dir, ec))
        fail_at(dir.string(), "--out-dir: is a file, not a folder");
      if (!std::filesystem::is_directory(dir, ec))
        fail_at(dir.string(), "--out-dir: output folder does not exist (the bench does not create it)");
      if (access(dir.c_str(), W_OK) != 0) fail_at(dir.string(), "--out-dir: output folder is not writable");
    });
}
}  // namespace

void add_bench_targets(CLI::App* bench) {
  for (auto& t : targets()) {
    CLI::App* sub = bench->add_subcommand(t.name, t.help);
    t.setup(sub);
    add_shared_checks(sub);
  }
}

std::vector<SharedFrame> shared_frames(const std::filesystem::path& data, int max_frames, const std::string& who) {
  namespace fs = std::filesystem;
  std::vector<SharedFrame> out;
  const fs::path cs = data / "cityscapes", kt = data / "kitti";
  if (!fs::is_directory(cs / "leftImg8bit") || !fs::is_directory(kt / "image_2"))
    fail_at(data.string(), who + ": needs cityscapes/leftImg8bit and kitti/image_2 here (the shared data; "
                           "give --shared DIR)");
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(cs / "leftImg8bit")) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  for (const auto& p : files) {
    const std::string stem = p.filename().string();
    const auto cut = stem.find("_leftImg8bit.png");
    if (cut == std::string::npos) continue;
    const std::string base = stem.substr(0, cut);
    SharedFrame f{"cityscapes", base, p.string(), (cs / "gtFine" / (base + "_gtFine_labelIds.png")).string(),
            (cs / "gtFine" / (base + "_gtFine_instanceIds.png")).string(), "onsemi-ar0331"};
    if (!fs::exists(f.labels)) fail_at(f.labels, who + ": labels of " + f.image + " missing");
    if (!fs::exists(f.instances)) f.instances.clear();
    if (max_frames > 0 && static_cast<int>(out.size()) >= max_frames) break;
    out.push_back(f);
  }
  const size_t n_cityscapes = out.size();
  files.clear();
  for (const auto& e : fs::directory_iterator(kt / "image_2")) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  for (const auto& p : files) {
    if (p.extension() != ".png") continue;
    SharedFrame f{"kitti", "kitti_" + p.stem().string(), p.string(), (kt / "semantic" / p.filename()).string(), "",
            "sony-icx267-flea2"};
    if (!fs::exists(f.labels)) fail_at(f.labels, who + ": labels of " + f.image + " missing");
    if (max_frames > 0 && static_cast<int>(out.size() - n_cityscapes) >= max_frames) break;
    out.push_back(f);
  }
  if (out.empty()) fail_at(data.string(), who + ": no frames found");
  return out;
}

bool draw_chart(const std::string& script, const std::string& csv_path, const std::string& png_path) {
  const std::string cmd = "/usr/bin/python3 '" + std::string(PHOTOSITE_SOURCE_DIR) + "/" + script + "' '" + csv_path +
                          "' '" + png_path + "'";
  if (std::system(cmd.c_str()) == 0) return true;
  std::error_code ec;
  std::printf("chart: /usr/bin/python3 with matplotlib failed; CSV written%s\n",
              std::filesystem::exists(png_path, ec) ? (" (" + png_path + " is an earlier run's chart)").c_str() : "");
  return false;
}

std::filesystem::path output_folder(const std::string& out_dir) {
  return out_dir.empty() ? std::filesystem::path(PHOTOSITE_SOURCE_DIR) / "docs" : std::filesystem::path(out_dir);
}

// The CPU's model name, with its family and model numbers where the name alone does not tell the
// generation (a virtual machine's "AMD EPYC" was a Zen 3 and a Zen 4 in turn) and the vector
// level the code paths take (core/isa_detail.h: AVX-512, AVX2 or scalar), and the thread count.
std::string machine_description() {
  std::ifstream f("/proc/cpuinfo");
  std::string line, model = "unknown CPU", family, number;
  auto value = [&] { return line.substr(line.find(':') + 2); };
  while (std::getline(f, line) && (model == "unknown CPU" || family.empty() || number.empty())) {
    if (line.rfind("model name", 0) == 0) model = value();
    else if (line.rfind("cpu family", 0) == 0) family = value();
    else if (line.rfind("model", 0) == 0 && line.find(':') != std::string::npos && line.rfind("model name", 0) != 0)
      number = value();
  }
  const char* isa = photosite::detail::have_avx512() ? "AVX-512" : photosite::detail::have_avx2() ? "AVX2" : "scalar";
  std::string what = family.empty() ? std::string(isa) : "family " + family + " model " + number + ", " + isa;
  return model + " (" + what + "), " + std::to_string(std::thread::hardware_concurrency()) + " hardware threads";
}

std::string write_bench_csv(const std::string& out_dir, const std::string& name, const std::string& csv) {
  const std::string path = (output_folder(out_dir) / name).string();
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
