// The one place photosite reads its environment (include/photosite/environment.h), and the data
// folder's lookup, which is relative to the library's own file so that an installed tree can move.
#include "photosite/environment.h"

#include <dlfcn.h>
#include <fmt/format.h>
#include <omp.h>

#include <cstdlib>
#include <filesystem>
#include <system_error>

#include "photosite/error.h"

namespace photosite::env {

const char* name(Var v) {
  switch (v) {
    case Var::DataDir: return "PHOTOSITE_DATA_DIR";
    case Var::PresetDir: return "PHOTOSITE_PRESET_DIR";
    case Var::DeviceStore: return "PHOTOSITE_DEVICE_STORE";
    case Var::XdgDataHome: return "XDG_DATA_HOME";
    case Var::Home: return "HOME";
    case Var::MaxPixels: return "PHOTOSITE_MAX_PIXELS";
    case Var::ExrThreads: return "PHOTOSITE_EXR_THREADS";
    case Var::VkValidation: return "PHOTOSITE_VK_VALIDATION";
    case Var::VkSyncValidation: return "PHOTOSITE_VK_SYNC_VALIDATION";
    case Var::VkStaging: return "PHOTOSITE_VK_STAGING";
    case Var::VkHostImport: return "PHOTOSITE_VK_HOST_IMPORT";
    case Var::SampleDir: return "PHOTOSITE_SAMPLE_DIR";
    case Var::ScalarLights: return "PHOTOSITE_SCALAR_LIGHTS";
    case Var::MaxIsa: return "PHOTOSITE_MAX_ISA";
    case Var::VkDriverFiles: return "VK_DRIVER_FILES";
    case Var::VkIcdFilenames: return "VK_ICD_FILENAMES";
  }
  return "";
}

std::optional<std::string> get(Var v) {
  const char* e = std::getenv(name(v));
  if (!e || !*e) return std::nullopt;
  return std::string(e);
}

}  // namespace photosite::env

namespace photosite {
namespace fs = std::filesystem;

namespace {

// <file's folder>/../share/photosite, then one level further up (lib/<multiarch>/ layouts).
std::optional<std::string> data_dir_near(const fs::path& file) {
  if (file.empty()) return std::nullopt;
  std::error_code ec;
  fs::path dir = fs::weakly_canonical(file, ec).parent_path();
  if (ec) dir = file.parent_path();
  for (int up = 0; up < 2 && !dir.empty(); ++up) {
    dir = dir.parent_path();
    const fs::path candidate = dir / "share" / "photosite";
    if (fs::is_directory(candidate / "presets", ec)) return candidate.string();
  }
  return std::nullopt;
}

// The file this code was loaded from: libphotosite.so, or the program it is linked into. For a
// program glibc reports argv[0], which may be relative to a folder the program has since left;
// only an absolute path is used (/proc/self/exe covers the rest).
fs::path this_library() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&data_dir), &info) && info.dli_fname && *info.dli_fname) {
    fs::path p(info.dli_fname);
    if (p.is_absolute()) return p;
  }
  return {};
}

}  // namespace

std::string data_dir() {
  if (auto e = env::get(env::Var::DataDir)) return *e;
  if (auto d = data_dir_near(this_library())) return *d;
  std::error_code ec;
  if (auto d = data_dir_near(fs::read_symlink("/proc/self/exe", ec))) return *d;
  return PHOTOSITE_SOURCE_DIR;
}

void check_openmp_threads() {
  const int n = omp_get_max_threads();
  if (n > kMaxOpenmpThreads)
    fail(fmt::format("OMP_NUM_THREADS: {} threads is more than photosite runs a parallel region on (at most {}; "
                     "more only share the same cores; 100000 overflowed libgomp's stack)",
                     n, kMaxOpenmpThreads));
}

}  // namespace photosite
