// Fixed-pattern maps and the device store.
//
// Model (docs/sensor.md, "Fixed-pattern noise"): for pixel i,
//   PRNU gain        g_i = 1 + σ_PRNU z₁,                 z ~ N(0,1)
//   offset DSNU      o_i = σ_DSNU z₂            [e⁻]     (exposure independent)
//   dark-rate factor r_i = LogNormal(mean 1, CV = dark_current_nonuniformity) — or, for the
//                    hot pixels (a Bernoulli fraction), hot_rate / mean_rate.
// The dark part of the signal is then t·D·r_i: its spatial σ grows linearly with exposure t,
// while its temporal (shot) variance t·D·r_i grows linearly too — the thesis's Eq. 8,
// N_dsnu = N(0, T·σ²), keeps only the latter form; see docs/sensor.md for the comparison.
#include "photosite/sensor/fpn.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <fmt/format.h>

#include "photosite/checksum.h"
#include "photosite/environment.h"
#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/rng.h"
#include "core/rng_detail.h"  // Philox inline in the per-pixel loop
#include "sensor/fpn_detail.h"

namespace photosite {
namespace fs = std::filesystem;

namespace {
constexpr uint32_t kFpnFrame = 0xFFFFFFFFu;  // reserved frame number for device maps

std::string fpn_params_text(const CameraPreset& p) {
  return fmt::format("prnu_percent={};dsnu_e={};dark_current_nonuniformity_percent={};"
                     "hot_pixel_fraction={};hot_pixel_dark_current_e_per_s={};dark_current_e_per_s={}",
                     p.prnu_percent, p.dsnu_e, p.dark_current_nonuniformity_percent,
                     p.hot_pixel_fraction, p.hot_pixel_dark_current_e_per_s, p.dark_current_e_per_s);
}

// The id names the map's file, "<id>_<W>x<H>.exr", written first as ".<that>.tmp-<scope>-<pid>-<n>.exr"
// (about 60 bytes more than the id at the largest frame): at most 128 characters keeps both under
// a file name's 255 bytes (NAME_MAX), where a longer id failed at the write with "File name too
// long". A leading '.' would make the maps hidden files.
constexpr size_t kMaxDeviceIdChars = 128;
void check_device_id(const std::string& id) {
  if (id.empty()) fail("device id is empty");
  for (char c : id)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.'))
      fail("device id '" + id + "' may contain only letters, digits, '-', '_' and '.'");
  if (id.size() > kMaxDeviceIdChars)
    fail(fmt::format("device id of {} characters is longer than {} (it names the maps' file)", id.size(),
                     kMaxDeviceIdChars));
  if (id[0] == '.') fail("device id '" + id + "' starts with '.' (its maps' file would be hidden)");
}
}  // namespace

FixedPatternMaps generate_fixed_pattern(const CameraPreset& p, int width, int height,
                                        const std::string& device_id) {
  check_device_id(device_id);
  FixedPatternMaps m;
  m.device_id = device_id;
  m.preset_name = p.name;
  m.device_seed = seed_from_device_id(device_id.c_str());
  m.width = width;
  m.height = height;
  const size_t n = static_cast<size_t>(width) * height;
  const bool prnu = p.prnu_percent > 0, dsnu = p.dsnu_e > 0;
  const bool dark = p.dark_current_nonuniformity_percent > 0 || p.hot_pixel_fraction > 0;
  if (prnu) m.prnu_gain = ImageF(width, height, 1, 1.f, unit::dimensionless);
  if (dsnu) m.dsnu_offset_e = ImageF(width, height, 1, 0.f, unit::electrons);
  if (dark) m.dark_rate_factor = ImageF(width, height, 1, 1.f, unit::dimensionless);
  const double cv = p.dark_current_nonuniformity_percent / 100.0;
  const double s_ln = std::sqrt(std::log1p(cv * cv)), m_ln = -0.5 * s_ln * s_ln;
  const double hot_factor =
      p.dark_current_e_per_s > 0 ? p.hot_pixel_dark_current_e_per_s / p.dark_current_e_per_s : 0.0;
  const uint64_t seed = m.device_seed;
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < static_cast<int64_t>(n); ++i) {
    if (prnu) {
      auto w = detail::random_words_inline(seed, kFpnFrame, i, static_cast<uint32_t>(Stream::FpnPrnu));
      m.prnu_gain[i] = static_cast<float>(1.0 + p.prnu_percent / 100.0 * normal_from_words(w[0], w[1]));
    }
    if (dsnu) {
      auto w = detail::random_words_inline(seed, kFpnFrame, i, static_cast<uint32_t>(Stream::FpnDsnu));
      m.dsnu_offset_e[i] = static_cast<float>(p.dsnu_e * normal_from_words(w[0], w[1]));
    }
    if (dark) {
      auto w = detail::random_words_inline(seed, kFpnFrame, i, static_cast<uint32_t>(Stream::FpnDarkRate));
      double f = cv > 0 ? std::exp(m_ln + s_ln * normal_from_words(w[0], w[1])) : 1.0;
      if (p.hot_pixel_fraction > 0 && uniform_open(w[2]) < p.hot_pixel_fraction)
        f = hot_factor * std::exp(m_ln + s_ln * normal_from_words(w[3], w[1] ^ 0x9e3779b9u));
      m.dark_rate_factor[i] = static_cast<float>(f);
    }
  }
  m.checksum = fixed_pattern_checksum(m, ChecksumAlgorithm::Fnv1a_64);
  m.checksum_xxh3 = fixed_pattern_checksum(m, ChecksumAlgorithm::Xxh3_64);
  return m;
}

std::string fixed_pattern_checksum(const FixedPatternMaps& m, ChecksumAlgorithm a) {
  // Each map's sample count, then its float32 samples as stored in memory (little-endian).
  Checksum c(a);
  for (const ImageF* img : {&m.prnu_gain, &m.dsnu_offset_e, &m.dark_rate_factor}) {
    const uint64_t n = img->size();
    c.update(&n, sizeof n);
    if (n) c.update(img->data(), n * sizeof(float));
  }
  return c.hex();
}

namespace detail {
std::atomic<FlockFn> device_store_flock{&::flock};
}  // namespace detail

namespace {
// The store's folder as an absolute, lexically normal path without a trailing separator. A relative
// folder (--device-store maps, PHOTOSITE_DEVICE_STORE=maps) is taken against the working folder
// once, here: every map of the store is then read and made in that one folder, whatever the
// working folder is at the time (a Python program that changes it with os.chdir between frames
// would otherwise draw the device's maps again in a second store, and its frames would stop
// sharing one fixed pattern).
std::string absolute_store(const std::string& dir) {
  std::error_code ec;
  fs::path p = fs::absolute(dir, ec);
  if (ec) fail_at(dir, "cannot make the device store's path absolute (" + ec.message() + "; the working folder is gone?)");
  p = p.lexically_normal();
  if (!p.has_filename() && p.has_relative_path()) p = p.parent_path();  // "maps/" -> "maps"
  return p.string();
}
}  // namespace

DeviceStore::DeviceStore(std::string dir) : dir_(absolute_store(dir.empty() ? default_dir() : dir)) {}

namespace {
// What identifies a file's contents for DeviceStore::Kept: a map is only ever published whole and
// never rewritten in place, so the same device, inode, size and modification time are the same
// bytes.
struct FileId {
  dev_t dev = 0;
  ino_t ino = 0;
  off_t size = 0;
  int64_t mtime_ns = 0;
  bool operator==(const FileId&) const = default;
};
std::optional<FileId> file_id(const std::string& path) {
  struct stat st;
  if (::stat(path.c_str(), &st) != 0) return std::nullopt;
  return FileId{st.st_dev, st.st_ino, st.st_size,
                static_cast<int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec};
}
}  // namespace

// The maps kept by keep_loaded, by file path (which names the preset, the device id and the
// size), with the file's identity and the preset's FPN parameters they were read for.
struct DeviceStore::Kept {
  struct Entry {
    FileId file;
    std::string fpn_params;
    FixedPatternMaps maps;
    uint64_t last_use = 0;
  };
  // At most this many maps (about 24 MB each at 2048x1024): a Camera fed frames of a few sizes
  // (KITTI's sequences differ by a few pixels) keeps one per size; beyond it, the least recently
  // used goes.
  static constexpr size_t kMaxEntries = 4;
  std::mutex mutex;
  std::map<std::string, Entry> entries;
  uint64_t uses = 0;

  // The kept maps of `path` if they were read from this very file for these parameters.
  std::optional<FixedPatternMaps> find(const std::string& path, const FileId& file, const std::string& fpn_params) {
    std::lock_guard<std::mutex> lock(mutex);
    auto it = entries.find(path);
    if (it == entries.end() || !(it->second.file == file) || it->second.fpn_params != fpn_params) return std::nullopt;
    it->second.last_use = ++uses;
    return it->second.maps;
  }
  void put(const std::string& path, const FileId& file, std::string fpn_params, const FixedPatternMaps& maps) {
    std::lock_guard<std::mutex> lock(mutex);
    entries[path] = Entry{file, std::move(fpn_params), maps, ++uses};
    while (entries.size() > kMaxEntries) {
      auto oldest = entries.begin();
      for (auto it = entries.begin(); it != entries.end(); ++it)
        if (it->second.last_use < oldest->second.last_use) oldest = it;
      entries.erase(oldest);
    }
  }
};

void DeviceStore::keep_loaded(bool on) { kept_ = on ? std::make_shared<Kept>() : nullptr; }

void DeviceStore::keep(const std::string& path, const CameraPreset& preset, const FixedPatternMaps& m) const {
  if (!kept_) return;
  if (const std::optional<FileId> file = file_id(path)) kept_->put(path, *file, fpn_params_text(preset), m);
}

FixedPatternMaps DeviceStore::load_or_keep(const std::string& path, const CameraPreset& preset,
                                           const std::string& device_id, int width, int height) const {
  if (!kept_) return load(path, preset, device_id, width, height);
  // The identity taken before the read: a file replaced during it is then read again next time.
  const std::optional<FileId> file = file_id(path);
  const std::string params = fpn_params_text(preset);
  if (file)
    if (std::optional<FixedPatternMaps> m = kept_->find(path, *file, params)) return std::move(*m);
  FixedPatternMaps m = load(path, preset, device_id, width, height);
  if (file) kept_->put(path, *file, params, m);
  return m;
}

std::string DeviceStore::default_dir() {
  if (auto e = env::get(env::Var::DeviceStore)) return *e;
  // XDG Base Directory: a relative XDG_DATA_HOME is invalid and is ignored.
  if (auto x = env::get(env::Var::XdgDataHome); x && fs::path(*x).is_absolute())
    return (fs::path(*x) / "photosite" / "devices").string();
  if (auto h = env::get(env::Var::Home); h && fs::path(*h).is_absolute())
    return (fs::path(*h) / ".local" / "share" / "photosite" / "devices").string();
  // No home (some service, cron and container setups): no folder relative to wherever the
  // process happens to run; the user names one.
  fail_parameter("device_store", "no device store folder: neither PHOTOSITE_DEVICE_STORE nor an absolute HOME or "
                 "XDG_DATA_HOME is set; give ", " (or set PHOTOSITE_DEVICE_STORE)");
}

std::string DeviceStore::path_for(const CameraPreset& preset, const std::string& device_id,
                                  int width, int height) const {
  check_device_id(device_id);
  return (fs::path(dir_) / preset.name / fmt::format("{}_{}x{}.exr", device_id, width, height))
      .string();
}

namespace {
// DeviceStore::load without its remedy.
FixedPatternMaps load_map(const std::string& path, const CameraPreset& preset, const std::string& device_id,
                          int width, int height) {
  // The header first: a map of another size (or a damaged header declaring a huge one) is
  // refused before its pixels are allocated and decoded.
  const ImageFileInfo info = probe_image(path);
  if (info.format != "openexr") fail_at(path, "not a photosite device map (a " + info.format + " file, not OpenEXR)");
  if (info.width != width || info.height != height)
    fail_at(path, fmt::format("fixed-pattern map is {}x{}, the frame is {}x{}", info.width, info.height,
                              width, height));
  if (info.channels > 3) fail_at(path, fmt::format("not a photosite device map ({} channels)", info.channels));
  ExrContents c = read_exr(path);
  auto attr = [&](const std::string& k) {
    auto it = c.attributes.find(k);
    if (it == c.attributes.end()) fail_at(path, "not a photosite device map (no " + k + ")");
    return it->second;
  };
  if (attr("photosite/preset") != preset.name)
    fail_at(path, "fixed-pattern map belongs to preset '" + attr("photosite/preset") + "', not '" +
                      preset.name + "'");
  if (attr("photosite/device_id") != device_id)
    fail_at(path, "fixed-pattern map belongs to device '" + attr("photosite/device_id") + "'");
  if (c.width != width || c.height != height)
    fail_at(path, fmt::format("fixed-pattern map is {}x{}, the frame is {}x{}", c.width, c.height,
                              width, height));
  if (attr("photosite/fpn_params") != fpn_params_text(preset))
    fail_parameter("device_id", path + ": fixed-pattern map was made with other preset parameters (" +
                                    attr("photosite/fpn_params") + "); the preset now says " +
                                    fpn_params_text(preset) + ". Use another ",
                   " or remove the map.");
  FixedPatternMaps m;
  m.device_id = device_id;
  m.preset_name = preset.name;
  m.device_seed = seed_from_device_id(device_id.c_str());
  m.width = width;
  m.height = height;
  auto take = [&](const char* name, ImageF& dst) {
    auto it = c.channels.find(name);
    if (it != c.channels.end()) dst = std::move(it->second);
  };
  take("prnu.Y", m.prnu_gain);
  take("dsnu.Y", m.dsnu_offset_e);
  take("dark_rate.Y", m.dark_rate_factor);
  // The data is verified by XXH3-64 where the file records it; a map written before it was
  // recorded, by its FNV-1a 64 (one multiply per byte: about 80 ms for 24 MB here). The FNV-1a
  // value stays the map's identity in the outputs' headers either way; it was computed from the
  // same bytes when the map was made.
  const auto xxh3 = c.attributes.find("photosite/checksum_xxh3_64");
  if (xxh3 != c.attributes.end()) {
    m.checksum_xxh3 = fixed_pattern_checksum(m, ChecksumAlgorithm::Xxh3_64);
    if (m.checksum_xxh3 != xxh3->second)
      fail_at(path, "fixed-pattern map is corrupt (XXH3-64 checksum " + m.checksum_xxh3 + " != recorded " +
                        xxh3->second + ")");
    m.checksum = attr("photosite/checksum");
  } else {
    m.checksum = fixed_pattern_checksum(m, ChecksumAlgorithm::Fnv1a_64);
    if (m.checksum != attr("photosite/checksum"))
      fail_at(path, "fixed-pattern map is corrupt (FNV-1a 64 checksum " + m.checksum + " != recorded " +
                        attr("photosite/checksum") + ")");
  }
  return m;
}
}  // namespace

FixedPatternMaps DeviceStore::load(const std::string& path, const CameraPreset& preset,
                                   const std::string& device_id, int width, int height) const {
  // A map that cannot be used (damaged, cut short, another preset's, size's or device's) says so
  // with what to do: the maps follow from the preset and the device id alone (generate_fixed_pattern),
  // so removing the file makes the next run draw the device's maps again. Never done silently:
  // the outputs made with the map on file record its checksum. (A ParameterError, other preset
  // parameters, names its own remedy.)
  try {
    return load_map(path, preset, device_id, width, height);
  } catch (const ParameterError&) {
    throw;
  } catch (const MissingFileError&) {
    throw;
  } catch (const Error& e) {
    if (e.kind() != Error::Kind::BadInput) throw;
    throw Error(std::string(e.what()) + "; remove the file, and the next run draws device " + device_id +
                "'s maps again (they follow from the preset and the device id alone)");
  }
}

namespace {
// Creation is serialised by an exclusive flock on the preset's folder itself (no lock files to
// leave behind): the second process waits, then finds the first one's map. Where the file system
// has no file locks (flock fails with another error than EWOULDBLOCK: ENOLCK from an NFS mount
// without a lock daemon, EOPNOTSUPP or ENOSYS from some FUSE and network file systems), the map is
// made without the lock, and a note says so: the publish is a no-replace link or rename (atomic
// without any lock; write_then_publish in core/io.cpp), so the first map to be published wins, and
// a process that loses the race discards its own and loads the winner's. Every process then uses
// one map; the cost is the losers' wasted draws. (Two maps of one device are the same bits anyway:
// they follow from the preset and the device id alone.) `doing` names what is done without the
// lock in that note.
class FolderLock {
 public:
  FolderLock(const std::string& dir, const char* doing) : fd_(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC)) {
    auto no_lock = [&](const char* call, int e) {
      std::fprintf(stderr, "photosite: note: %s: no lock on the device store's folder (%s: %s); %s\n", dir.c_str(), call,
                   std::strerror(e), doing);
    };
    if (fd_ < 0) {
      no_lock("open", errno);
    } else if (lock_(fd_, LOCK_EX | LOCK_NB) == 0) {
      locked_ = true;
    } else if (errno == EWOULDBLOCK) {
      // Another process is creating a map of this preset (any device or size): say so, then wait.
      std::fprintf(stderr, "photosite: waiting for another process creating a fixed-pattern map in %s (its lock on the folder)\n",
                   dir.c_str());
      int r;
      while ((r = lock_(fd_, LOCK_EX)) != 0 && errno == EINTR) {
      }
      if (r == 0) locked_ = true;
      else no_lock("flock", errno);
    } else {
      no_lock("flock", errno);
    }
  }
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;
  ~FolderLock() {
    if (fd_ >= 0) {
      if (locked_) lock_(fd_, LOCK_UN);
      ::close(fd_);
    }
  }

 private:
  int fd_;
  bool locked_ = false;
  detail::FlockFn lock_ = detail::device_store_flock.load();
};
}  // namespace

FixedPatternMaps DeviceStore::load_or_create(const CameraPreset& preset,
                                             const std::string& device_id, int width,
                                             int height) const {
  check_frame_size("fixed-pattern map", width, height);
  const std::string path = path_for(preset, device_id, width, height);
  const std::string dir = fs::path(path).parent_path().string();
  std::error_code ec;
  // A map on file, read. One that is refused (cut short, checksum) may be one being filled in place
  // by its creator on a file system with neither hard links nor a no-replace rename (the last way
  // of write_then_publish, core/io.cpp): the creator holds the folder's lock while it writes, so
  // the map is read once more under that lock (unless this process holds it: `locked`), and a map
  // refused again is reported as it is.
  auto load_existing = [&](bool locked) {
    try {
      return load_or_keep(path, preset, device_id, width, height);
    } catch (const Error& e) {
      // Other preset parameters (a ParameterError) or a map gone is no map being filled.
      if (locked || e.kind() != Error::Kind::BadInput || dynamic_cast<const ParameterError*>(&e) ||
          dynamic_cast<const MissingFileError*>(&e))
        throw;
    }
    const FolderLock lock(dir, "reading the fixed-pattern map again without it");
    return load_or_keep(path, preset, device_id, width, height);
  };
  // Maps are published whole (a temporary linked or renamed in, never replacing), so one that
  // exists is complete (but for the last way above) and is read without a lock: a read-only store shared by many jobs works as long as it holds
  // every map they need.
  if (fs::exists(path, ec)) return load_existing(false);
  // A store given as a file (PHOTOSITE_DEVICE_STORE=a file) is named as such, not as a folder that
  // could not be made.
  if (std::error_code fe; fs::exists(dir_, fe) && !fs::is_directory(dir_, fe))
    fail_at(dir_, "the device store is a file, not a folder");
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    fail_at(dir, "cannot create the device store folder (" + (ec ? ec.message() : "not a folder") +
                     "; read-only store?) for the fixed-pattern map " + fs::path(path).filename().string());
  if (::access(dir.c_str(), W_OK) != 0)
    fail_at(dir, "the device store folder is read-only; cannot create the fixed-pattern map " +
                     fs::path(path).filename().string() + " (make it writable, or create the map elsewhere and copy it in)");
  const FolderLock lock(dir, "creating the fixed-pattern map without it: the first map published wins, and a process "
                             "that made another loads that one");
  if (fs::exists(path, ec)) return load_existing(true);
  // Under the lock (where there is one; without it, only temporaries of processes gone are
  // touched): the temporaries of map creations killed outright (SIGKILL: no handler ran)
  // in this pid space are removed.
  remove_stale_temporaries(dir);
  FixedPatternMaps m = generate_fixed_pattern(preset, width, height, device_id);
  std::vector<ExrChannelGroup> groups;
  if (!m.prnu_gain.empty()) groups.push_back({{"prnu.Y"}, &m.prnu_gain, unit::dimensionless});
  if (!m.dsnu_offset_e.empty()) groups.push_back({{"dsnu.Y"}, &m.dsnu_offset_e, unit::electrons});
  if (!m.dark_rate_factor.empty())
    groups.push_back({{"dark_rate.Y"}, &m.dark_rate_factor, unit::dimensionless});
  ImageF none(width, height, 1, 0.f);
  if (groups.empty()) groups.push_back({{"none.Y"}, &none, ""});  // a preset without FPN
  ExrWriteOptions wo;
  wo.create_only = true;
  // Uncompressed: the maps are per-pixel noise (PRNU, DSNU, dark-rate factors), which deflate
  // cannot shrink (ZIP gave 24.5 MB for 24 MB of float32 at 2048x1024), while inflating them
  // cost every run that loads the map (each `night`, each `batch` run) its decode time. Maps
  // written before with ZIP are read as they are.
  wo.compression = "none";
  const bool published = write_exr(path, groups,
                                   {{"photosite/version", std::string(PHOTOSITE_VERSION)},
                                    {"photosite/preset", preset.name},
                                    {"photosite/device_id", device_id},
                                    {"photosite/fpn_params", fpn_params_text(preset)},
                                    {"photosite/checksum", m.checksum},
                                    {"photosite/checksum_xxh3_64", m.checksum_xxh3}},
                                   wo);
  if (!published) return load_existing(true);
  std::fprintf(stderr, "photosite: created the fixed-pattern map %s\n", path.c_str());
  keep(path, preset, m);
  return m;
}

}  // namespace photosite
