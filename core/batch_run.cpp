// batch::run: a whole data set (or one shard of it) to night frames (batch.h).
//
// Pipeline: a reader thread decodes images and labels, the calling thread computes (the scene
// and the sensor, OpenMP inside), writer threads encode and write; bounded queues between them
// keep memory flat whatever the number of images. Every file is written under a temporary name
// and renamed; a small per-shard manifest (out/.photosite-batch/) records each finished item with
// its files' checksums and the run's parameters, so a re-run skips finished items and refuses to
// mix results of other parameters.
#include <fcntl.h>
#include <signal.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include <omp.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "photosite/batch.h"
#include "photosite/checksum.h"
#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/night_chain.h"
#include "photosite/scene/ego_motion.h"
#include "photosite/scene/luminaires.h"
#include "photosite/scene/rig.h"
#include "photosite/sensor/isp.h"
#include "scene/texture_detail.h"

namespace photosite::batch {
namespace fs = std::filesystem;

namespace {
double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
// CPU time of the calling thread, in ms.
double thread_cpu_ms() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

// A FIFO of at most cap items; push and pop add the time they were blocked to *waited_ms.
template <class T>
class BoundedQueue {
 public:
  explicit BoundedQueue(size_t cap) : cap_(cap) {}
  void push(T v, double* waited_ms) {
    std::unique_lock l(m_);
    if (q_.size() >= cap_) {
      const auto t0 = std::chrono::steady_clock::now();
      not_full_.wait(l, [&] { return q_.size() < cap_; });
      *waited_ms += ms_since(t0);
    }
    q_.push_back(std::move(v));
    not_empty_.notify_one();
  }
  std::optional<T> pop(double* waited_ms) {
    std::unique_lock l(m_);
    if (q_.empty() && !closed_) {
      const auto t0 = std::chrono::steady_clock::now();
      not_empty_.wait(l, [&] { return !q_.empty() || closed_; });
      *waited_ms += ms_since(t0);
    }
    if (q_.empty()) return std::nullopt;
    T v = std::move(q_.front());
    q_.pop_front();
    not_full_.notify_one();
    return v;
  }
  void close() {
    std::lock_guard l(m_);
    closed_ = true;
    not_empty_.notify_all();
  }

 private:
  size_t cap_;
  std::deque<T> q_;
  bool closed_ = false;
  std::mutex m_;
  std::condition_variable not_full_, not_empty_;
};

struct Loaded {
  Item item;
  ImageF day;  // linear sRGB
  scene::LabelMap labels;
  // The texture's class sums made with the linearisation (linearize_with_texture_sums), which
  // the texture then does not make again (its pass 1); taken only for this day and these labels.
  scene::TextureSums sums;
  std::optional<scene::CameraRig> rig;  // the item's own camera file, when used
  std::optional<std::string> camera_sum;  // and that file's XXH3-64, for the item's record
  std::string image_note;  // the day image's negative samples (day_image_note), for the header
  std::string image_file_note;  // what its reader noted of its file (ImageFileInfo::note), for the header
  std::optional<scene::OdometrySample> odometry;  // batch --sequence with ego-motion: the item's
  std::string mount_source;  // where its camera_* (the camera's place on the vehicle) come from
  std::string error;
};
// A worker's sequence (batch --sequence): the group being computed, its scene state, and the
// odometry of its last frame computed with ego-motion (scene/ego_motion.h).
struct GroupState {
  std::string group;
  scene::SequenceState seq;
  // The last frame computed with ego-motion: its odometry and pose, which the next frame's advances
  // (a frame that fails leaves them: the next one advances over both intervals).
  std::optional<scene::OdometrySample> odometry;
  scene::CameraPose pose;
  bool ego = false;  // the group's first frame had odometry
};
// A sequence's day white balance as its reader sees it: the rule of reflectance_texture's
// ClassMeans (the group's first frame whose own balance is "road" fixes the gains for the group),
// which the compute stage applies to the same frames in the same order. The reader makes a later
// frame's class sums with those gains, so its texture takes them instead of summing again.
struct ReaderBalance {
  std::string group;
  std::optional<scene::DayBalance> fixed;
};
struct Computed {
  Item item;
  std::optional<std::string> camera_sum;  // Loaded's
  std::string error;
  std::vector<std::pair<std::string, std::function<void(const std::string&)>>> writes;  // rel path, writer
};

std::string read_text(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// The resume manifest of this shard, appended to one record (one line) at a time. Every write is
// checked: a record that cannot be written (disk full, quota, a file-size limit, a network file
// system's error) fails its item, naming the file, instead of a run that reports success while
// its results are unrecorded (a re-run then refused them as someone else's). After one failure
// every later record fails too: a line cut short must not be followed by the next.
class Journal {
 public:
  explicit Journal(std::string path) : path_(std::move(path)) {
    fd_ = ::open(path_.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0666);
    if (fd_ < 0) fail_at(path_, std::string("cannot write the batch manifest: ") + std::strerror(errno));
  }
  ~Journal() {
    if (fd_ >= 0) ::close(fd_);
  }
  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;
  // Appends text (whole lines); Error naming the file when it cannot.
  void append(const std::string& text) {
    if (failed_) fail_at(path_, "cannot write the batch manifest (an earlier record failed: " + failure_ + ")");
    for (size_t done = 0; done < text.size();) {
      const ssize_t n = ::write(fd_, text.data() + done, text.size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        failed_ = true;
        failure_ = n < 0 ? std::strerror(errno) : "nothing written";
        fail_at(path_, "cannot write the batch manifest: " + failure_);
      }
      done += static_cast<size_t>(n);
    }
  }

 private:
  std::string path_;
  int fd_ = -1;
  bool failed_ = false;
  std::string failure_;
};

// "seed: 0 in the folder, 1 now": the first parameter (in name order) that differs between a
// manifest's record and this run's, so a refused user knows what to change back.
std::string first_difference(const nlohmann::json& was, const nlohmann::json& now) {
  std::set<std::string> names;
  for (const auto* j : {&was, &now})
    if (j->is_object())
      for (const auto& [k, v] : j->items()) names.insert(k);
  auto value = [](const nlohmann::json& j, const std::string& k) {
    return j.is_object() && j.contains(k) ? j[k].dump() : std::string("not set");
  };
  for (const auto& k : names)
    if (value(was, k) != value(now, k)) return k + ": " + value(was, k) + " in the folder, " + value(now, k) + " now";
  return "";
}

// A finished record as this engine writes it: {"key": "...", "files": [{"path": "...", ...}]}.
// Anything else (a line of another tool, a damaged one that still parses) is not trusted.
bool is_finished_record(const nlohmann::json& j) {
  if (!j.is_object() || !j.contains("key") || !j["key"].is_string() || !j.contains("files") || !j["files"].is_array())
    return false;
  return std::all_of(j["files"].begin(), j["files"].end(),
                     [](const nlohmann::json& f) { return f.is_object() && f.contains("path") && f["path"].is_string(); });
}

// Every output path of the run comes from one input. Two different inputs written to one path
// (a manifest's "x/lab.png" and "../x/lab.png" both mirror to labels/x/lab.png; a preview and a
// label copy of one name) left one item beside another's file, and a re-run that never
// finished. Checked among all items, not only the shard's, so every shard refuses alike. The
// same input copied to one path twice (two images sharing one label file) is one file.
void check_outputs_unique(const std::vector<Item>& all, const std::string& format) {
  struct Source {
    std::string what, input;
    const Item* item;
  };
  auto describe = [](const Source& s) {
    return s.what + " " + s.input + (s.item->origin.empty() ? std::string() : " (" + s.item->origin + ")");
  };
  std::map<std::string, Source> by_path;
  for (const Item& it : all) {
    const std::vector<std::string> paths = output_paths(it, format);
    for (size_t k = 0; k < paths.size(); ++k) {
      // output_paths' order: the night images first, then the label copies.
      const bool labels_copy = paths[k] == it.labels_rel || paths[k] == it.instances_rel;
      Source src = labels_copy ? Source{paths[k] == it.labels_rel ? "labels" : "instances",
                                        paths[k] == it.labels_rel ? it.labels : it.instances, &it}
                               : Source{"the night frame of", it.image, &it};
      const auto [at, fresh] = by_path.emplace(paths[k], src);
      if (fresh || at->second.item == &it) continue;
      std::error_code ec;
      const Source& first = at->second;
      const bool same_input = labels_copy && first.what != "the night frame of" &&
                              (first.input == src.input || fs::equivalent(first.input, src.input, ec));
      if (!same_input)
        fail(describe(src) + " and " + describe(first) + " would both be written to " + paths[k] +
             " under --out; photosite never writes two files to one name");
    }
  }
}

// OpenMP's team size for the compute stage, restored when the run ends.
struct OmpThreads {
  int saved = omp_get_max_threads();
  explicit OmpThreads(int n) {
    if (n > 0) omp_set_num_threads(n);
  }
  ~OmpThreads() { omp_set_num_threads(saved); }
};
}  // namespace

std::vector<std::string> output_paths(const Item& it, const std::string& format) {
  std::vector<std::string> v;
  if (format != "png") v.push_back(it.key + ".exr");
  if (format != "exr") v.push_back(it.key + ".png");
  if (!it.labels_rel.empty()) v.push_back(it.labels_rel);
  if (!it.instances_rel.empty()) v.push_back(it.instances_rel);
  return v;
}

Result run(const std::vector<Item>& all, const Options& o, SensorRunner& runner, const ProgressFn& progress) {
  // ---- options and parameters -------------------------------------------------------------
  if (o.format != "exr" && o.format != "png" && o.format != "both") fail("--format must be exr, png or both");
  if (o.layers == 0 || (o.layers & ~kNightLayers) != 0) fail("batch: no layer or an unknown layer in the set");
  check_exr_compression(o.compression, "--compression");
  if (o.jobs < 1 || o.jobs > 64) fail("--jobs must be in [1, 64]");
  if (o.queue_depth < 1 || o.queue_depth > 64) fail("--queue-depth must be in [1, 64]");
  if (o.compute_threads < 0 || o.compute_threads > 256) fail("--compute-threads must be in [0, 256]");
  if (o.shard_count < 1 || o.shard_index < 0 || o.shard_index >= o.shard_count)
    fail(fmt::format("--shard {}/{} must be I/N with 0 <= I < N", o.shard_index, o.shard_count));
  if (o.out.empty()) fail("batch: no output folder given");
  check_outputs_unique(all, o.format);
  std::error_code ec;
  if (!o.root.empty() && fs::exists(o.out, ec) && fs::equivalent(o.out, o.root, ec))
    fail_at(o.out, "the output folder is the data set's own root; choose another --out");
  if (fs::exists(o.out, ec) && !fs::is_directory(o.out, ec)) fail_at(o.out, "is a file, not an output folder");
  fs::create_directories(o.out, ec);
  if (!fs::is_directory(o.out, ec))
    fail_at(o.out, "cannot create the output folder" + (ec ? " (" + ec.message() + ")" : std::string()));
  const std::vector<Item> items = shard(all, o.shard_index, o.shard_count);
  const SensorSetup& r = o.sensor;
  const ResolvedExposure base_ex = resolve(r.camera, r.lens, r.settings);  // checks the settings
  (void)base_ex;
  const DeviceStore store(o.device_store);
  const scene::ScenePreset& sp = o.scene;
  // On a GPU the run's large copies go by the device's copy engine straight from (to) the host's
  // pages, not through the staging buffer by the host's memcpy: the host's cores are busy reading
  // and encoding beside them (gpu::Buffer::set_host_import has the measurements). The runner's
  // own setting comes back when the run ends.
  struct HostImport {
    SensorRunner& r;
    bool before;
    ~HostImport() { r.set_host_import(before); }
  } host_import{runner, runner.host_import()};
  runner.set_host_import(true);
  const bool item_cameras =
      o.item_cameras && std::any_of(items.begin(), items.end(), [](const Item& it) { return !it.camera.empty(); });

  // Parameters that decide the results (not the shard: results do not depend on the split).
  // "Use the preset's value" is recorded as null (manifests of earlier runs: -1 / -999, read as
  // null by upgrade_params).
  nlohmann::json params = {
      {"photosite_version", PHOTOSITE_VERSION}, {"source", o.source},
      {"camera", r.camera.name}, {"camera_file_fnv", fmt::format("{:016x}", fnv1a_text(read_text(r.camera.file)))},
      {"lens", r.lens.name}, {"lens_file_fnv", fmt::format("{:016x}", fnv1a_text(read_text(r.lens.file)))},
      {"scene_preset", sp.name}, {"scene_file_fnv", fmt::format("{:016x}", fnv1a_text(read_text(sp.file)))},
      {"camera_rig", (item_cameras ? std::string("per-image camera files, else ") : std::string()) +
                         (sp.rig.file.empty() ? std::string("auto") : sp.rig.name)},
      {"rig_file_fnv", sp.rig.file.empty() ? std::string() : fmt::format("{:016x}", fnv1a_text(read_text(sp.rig.file)))},
      {"exposure_s", r.settings.exposure_s}, {"f_number", r.settings.f_number ? nlohmann::json(*r.settings.f_number) : nlohmann::json()},
      {"gain_db", r.settings.gain_db}, {"temperature_c", r.settings.temperature_c ? nlohmann::json(*r.settings.temperature_c) : nlohmann::json()},
      {"seed", r.settings.seed}, {"device_id", r.device_id}, {"demosaic", to_string(r.settings.demosaic)},
      {"poisson", to_string(r.settings.poisson)},
      {"format", o.format}, {"half", o.half}, {"compression", o.compression}, {"layers", layers_text(o.layers)}};
  if (o.sequences) params["sequences"] = true;  // only when set: earlier manifests stay valid
  // Ego-motion only where it is read (a sequence run over odometry): earlier manifests of runs
  // without odometry stay valid; one of a run over odometry, which took every frame at pose 0, is
  // refused by a run that reads it (and accepted with --ego-motion none).
  if (o.sequences && o.ego_motion &&
      std::any_of(items.begin(), items.end(), [](const Item& it) { return !it.odometry.empty(); }))
    params["ego_motion"] = "odometry";
  // The camera's place on the vehicle from a KITTI drive's calibration files (calib/<sub>/), only
  // when read: earlier manifests stay valid, and a run that took the OXTS unit's place is not
  // resumed by one that reads the calibration, nor the reverse.
  if (params.contains("ego_motion") &&
      std::any_of(items.begin(), items.end(), [](const Item& it) { return !it.odometry_calib.empty(); }))
    params["camera_mount"] = "kitti_calibration";
  // The lamp type (night --streetlamp-type, or the preset's key) only when not the LED: earlier
  // manifests, all LED, stay valid, and a run resumed with the other type is refused.
  if (sp.streetlamp_type != scene::StreetlampType::Led)
    params["streetlamp_type"] = scene::streetlamp_type_name(sp.streetlamp_type);
  // The PNG route writes the preview and the label copies whatever the set (as upgrade_params
  // reads the records of earlier runs): `--format png` with or without `--layers sensor,labels`
  // is one run.
  if (o.format == "png")
    params["layers"] = layers_text(kPngRouteLayers);
  const std::string params_text = params.dump();

  // ---- the resume manifest ------------------------------------------------------------------
  const fs::path out(o.out);
  const fs::path mdir = out / ".photosite-batch";
  fs::create_directories(mdir, ec);
  remove_stale_temporaries(o.out);  // a shared --out: other machines' temporaries and user files untouched
  const std::string mname = fmt::format("shard-{}-of-{}.jsonl", o.shard_index, o.shard_count);
  const std::string mfile = (mdir / mname).string();
  std::map<std::string, nlohmann::json> done;  // key → record
  std::map<std::string, fs::path> done_in;     // key → the manifest file its record is in
  std::set<std::string> publishing;            // paths of "writing" records: being published at a kill
  // This shard's manifest as found: whether it holds its parameter record yet (a kill or a full
  // disk between creating it and writing the record leaves it empty, or holding a cut line), and
  // whether it ends in a whole line (a record cut short by a power loss or a full disk).
  bool own_has_params = false, own_ends_whole = true;
  for (const auto& e : fs::directory_iterator(mdir, ec)) {
    if (e.path().extension() != ".jsonl") continue;
    const std::string text = read_text(e.path().string());
    if (e.path().filename() == mname) own_ends_whole = text.empty() || text.back() == '\n';
    std::istringstream f(text);
    std::string line;
    bool first = true;
    while (std::getline(f, line)) {
      nlohmann::json j = nlohmann::json::parse(line, nullptr, false);
      if (j.is_discarded()) continue;  // a line cut short by a kill
      if (first) {
        first = false;
        if (!j.is_object() || !j.contains("params") || !j["params"].is_object())
          fail_at(e.path().string(), "is a damaged batch manifest: its first readable line is not the run's "
                                     "parameters, so which run wrote this folder is unknown; use a new --out");
        if (const std::string was = batch::upgrade_params(j["params"].dump()); was != params_text)
          fail_at(o.out, "was written by a batch run with other parameters (" + e.path().filename().string() + ": " +
                             first_difference(nlohmann::json::parse(was), params) +
                             "); photosite does not mix results: use a new --out");
        if (e.path().filename() == mname) own_has_params = true;
        continue;
      }
      if (is_finished_record(j)) {
        done[j["key"].get<std::string>()] = j;
        done_in[j["key"].get<std::string>()] = e.path().filename();
      } else if (j.is_object() && j.contains("failed") && j["failed"].is_string()) {
        // A sequence's frame that failed after an earlier run had finished it: that record no
        // longer stands, as the frames after it were computed without it (with its input restored,
        // its sequence is redone instead of keeping them). Its files stay ours, to be replaced.
        // Only a record of the same file is cancelled (the same shard split): the files are read
        // in no set order.
        const std::string k = j["failed"].get<std::string>();
        if (const auto d = done.find(k); d != done.end() && done_in[k] == e.path().filename()) {
          for (const auto& f : d->second["files"]) publishing.insert(f["path"].get<std::string>());
          done.erase(d);
        }
      }
      // An item whose files were being published when the run was killed: they are ours.
      else if (j.is_object() && j.contains("writing") && j.contains("paths") && j["paths"].is_array())
        for (const auto& p : j["paths"])
          if (p.is_string()) publishing.insert(p.get<std::string>());
    }
  }
  // An item's own camera file (Cityscapes camera/...json) is a parameter of that item alone: its
  // record keeps the file's checksum, and an item whose file changed since is redone.
  auto camera_checksum = [&](const Item& it) -> std::optional<std::string> {
    if (!item_cameras || it.camera.empty()) return std::nullopt;
    return file_checksum_hex(it.camera, ChecksumAlgorithm::Xxh3_64);
  };
  // Likewise a manifest line's own odometry fields (read_manifest) where the run uses them: its
  // record keeps them as text, and an item whose fields changed since is redone (with its
  // sequence: a sequence with an unfinished frame is redone whole).
  auto odometry_text = [&](const Item& it) -> std::optional<std::string> {
    if (!(o.sequences && o.ego_motion && it.odometry_given)) return std::nullopt;
    const scene::OdometrySample& g = *it.odometry_given;
    return fmt::format("time_ns {} speed_m_s {:.17g} yaw_rate_rad_s {:.17g} camera_forward_m {:.17g} camera_left_m {:.17g} "
                       "camera_yaw_rad {:.17g}", g.time_ns, g.speed_m_s, g.yaw_rate_rad_s, g.camera_forward_m,
                       g.camera_left_m, g.camera_yaw_rad);
  };
  // A KITTI drive's timestamps file, read once per run for all its frames: here, for the records'
  // lines, and by the readers' threads, which share it (the frame's pose is computed from the very
  // lines its record keeps). A file that cannot be read is not kept, so each frame that needs it
  // fails naming it.
  std::mutex stamps_m;
  std::map<std::string, std::shared_ptr<const std::vector<std::string>>> stamps_read;
  auto kitti_stamps = [&](const std::string& path) {
    {
      std::lock_guard l(stamps_m);
      if (const auto f = stamps_read.find(path); f != stamps_read.end()) return f->second;
    }
    auto lines = std::make_shared<const std::vector<std::string>>(scene::read_kitti_timestamps(path));
    std::lock_guard l(stamps_m);
    return stamps_read.try_emplace(path, std::move(lines)).first->second;
  };
  // Like those fields, what a frame's pose is computed from where the run reads a data set's odometry files
  // (the load stage below): KITTI raw's OXTS data file (its checksum), the frame's line of the
  // drive's timestamps (its text, as read_kitti_oxts takes it: the only part of the file the frame
  // reads, so an edit of another frame's line, or frames appended to the drive, leave it alone)
  // and the drive's three calibration files where read (their checksums, in kKittiCalibFiles'
  // order); Cityscapes' vehicle JSON, timestamp file and, where the item has one, camera file (the
  // camera's place on the vehicle, read whatever --rig says). The record keeps them as
  // "odometry_sources"; a frame whose sources differ now is not finished, and its sequence is
  // redone whole (frame k's pose integrates the odometry of frames 0..k). A record without them
  // (written before they were kept) is not trusted where the frame reads odometry files now: its
  // pose cannot be checked, so it is redone once, as a record without camera_file_xxh3_64 is where
  // a camera file exists. Taken here, before any item is read: a file edited while the run reads
  // it leaves a record of its earlier content, which the next run finds changed (never the reverse).
  std::map<std::string, nlohmann::json> odometry_sources;  // item key → its sources, where it has any
  {
    auto sum = [](const std::string& p) {
      const auto s = file_checksum_hex(p, ChecksumAlgorithm::Xxh3_64);
      return s ? nlohmann::json(*s) : nlohmann::json();  // null: unreadable now (its item then fails)
    };
    std::map<std::string, nlohmann::json> calib_sums;                             // per calibration folder
    for (const Item& it : items) {
      if (!(o.sequences && o.ego_motion) || it.odometry.empty() || it.odometry_given) continue;
      nlohmann::json& s = odometry_sources[it.key];
      if (it.odometry_line >= 0) {  // KITTI raw
        s["oxts_xxh3_64"] = sum(it.odometry);
        std::shared_ptr<const std::vector<std::string>> l;  // null: unreadable now (its item then fails)
        try {
          l = kitti_stamps(it.odometry_time);
        } catch (const Error&) {
        }
        s["timestamps_line"] = l && static_cast<size_t>(it.odometry_line) < l->size()
                                   ? nlohmann::json((*l)[static_cast<size_t>(it.odometry_line)])
                                   : nlohmann::json();
        if (!it.odometry_calib.empty()) {
          auto [calib, first] = calib_sums.try_emplace(it.odometry_calib, nlohmann::json::array());
          if (first)
            for (const char* name : scene::kKittiCalibFiles)
              calib->second.push_back(sum((fs::path(it.odometry_calib) / name).string()));
          s["calibration_xxh3_64"] = calib->second;
        }
      } else {  // Cityscapes
        s["vehicle_xxh3_64"] = sum(it.odometry);
        s["timestamp_xxh3_64"] = sum(it.odometry_time);
        if (!it.camera.empty()) s["camera_xxh3_64"] = sum(it.camera);
      }
    }
  }
  // A sequence's frames as this run lists them (with --sequence, in a group of more than one
  // frame): frame k's pose integrates the odometry of frames 0..k, and its street lamps, façades
  // and parked vehicles carry over from them (scene::SequenceState), so a frame removed from the
  // data set (or one inserted) changes every frame after it, whose own sources did not change.
  // The record keeps "sequence_frames_xxh3_64": the XXH3-64 of the keys of frames 0..k, each
  // followed by a newline, in frame order; a frame whose value differs now is not finished, and
  // its sequence is redone whole. Frames appended after it leave it alone. A record without it in
  // such a group (written before it was kept) is redone once: its frames cannot be checked.
  std::map<std::string, std::string> sequence_frames;  // item key → its value, where it has one
  if (o.sequences) {
    std::map<std::string, size_t> group_size;
    for (const Item& it : items) ++group_size[it.group];
    std::vector<const Item*> by_frame;
    for (const Item& it : items) by_frame.push_back(&it);
    std::stable_sort(by_frame.begin(), by_frame.end(), [](const Item* a, const Item* b) {
      return a->group != b->group ? a->group < b->group : a->frame < b->frame;
    });
    std::map<std::string, std::unique_ptr<Checksum>> running;  // per group, over its frames so far
    for (const Item* p : by_frame) {
      const Item& it = *p;
      if (group_size[it.group] < 2) continue;
      auto& c = running[it.group];
      if (!c) c = std::make_unique<Checksum>(ChecksumAlgorithm::Xxh3_64);
      c->update(it.key.data(), it.key.size());
      c->update("\n", 1);
      sequence_frames[it.key] = c->hex();
    }
  }
  auto finished = [&](const Item& it) {
    auto d = done.find(it.key);
    if (d == done.end()) return false;
    if (const auto sf = sequence_frames.find(it.key);
        sf != sequence_frames.end() && (!d->second.contains("sequence_frames_xxh3_64") || d->second["sequence_frames_xxh3_64"] != sf->second))
      return false;
    if (const auto odo = odometry_text(it); d->second.contains("odometry") ? d->second["odometry"] != odo.value_or("") : odo.has_value())
      return false;
    if (const auto src = odometry_sources.find(it.key);
        d->second.contains("odometry_sources") ? src == odometry_sources.end() || d->second["odometry_sources"] != src->second
                                               : src != odometry_sources.end())
      return false;
    const auto now = camera_checksum(it);
    if (d->second.contains("camera_file_xxh3_64")) {
      if (!now || d->second["camera_file_xxh3_64"] != *now) return false;
    } else if (now) {
      return false;  // finished without a camera file, and one exists now: made with another rig
    }
    for (const auto& f : d->second["files"]) {
      const fs::path p = out / f["path"].get<std::string>();
      // Records name their checksum by its algorithm: "xxh3_64" now, "fnv" (FNV-1a 64) in
      // manifests written before XXH3 was adopted. A record with neither is not trusted.
      const bool xxh3 = f.contains("xxh3_64");
      if (!xxh3 && !f.contains("fnv")) return false;
      const auto sum = file_checksum_hex(p.string(), xxh3 ? ChecksumAlgorithm::Xxh3_64 : ChecksumAlgorithm::Fnv1a_64);
      if (!sum || f[xxh3 ? "xxh3_64" : "fnv"] != *sum) return false;
    }
    return true;
  };
  std::vector<Item> todo;
  std::set<std::string> redo;  // with sequences: groups with an unfinished frame, redone whole
  for (const auto& it : items)
    if (o.sequences && !finished(it)) redo.insert(it.group);
  for (const auto& it : items)
    if (redo.count(it.group) || !finished(it)) todo.push_back(it);
  // Every output we are about to write must be new, or one of ours from an unfinished item.
  std::set<std::string> ours = publishing;
  for (const auto& [k, rec] : done)
    for (const auto& f : rec["files"]) ours.insert(f["path"].get<std::string>());
  for (const auto& it : todo)
    for (const auto& rel : output_paths(it, o.format)) {
      const fs::path p = out / rel;
      if (fs::exists(p, ec) && !ours.count(rel))
        fail_at(p.string(), "exists and was not written by this batch; photosite never overwrites other files");
      if (!o.root.empty() && fs::exists(p, ec)) {
        for (const std::string& in : {it.image, it.labels, it.instances})
          if (!in.empty() && fs::equivalent(p, in, ec)) fail_at(p.string(), "output would overwrite an input");
      }
    }
  Journal journal(mfile);
  // The next record starts on a line of its own (else it is glued to a cut one and lost with it),
  // and a manifest without its parameter record gets one (else the first item's record is read
  // as the parameters and the folder refused by every later run).
  journal.append(std::string(own_ends_whole ? "" : "\n") +
                 (own_has_params ? std::string() : nlohmann::json({{"params", params}}).dump() + "\n"));

  Result result;
  Progress& pr = result.progress;
  pr.items = items.size();
  pr.to_do = todo.size();
  pr.already_done = items.size() - todo.size();
  std::mutex state_m;  // result, progress calls and the manifest
  const auto t0 = std::chrono::steady_clock::now();
  auto report = [&] {  // with state_m held
    pr.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (progress) progress(pr);
  };
  report();
  auto stopped = [&] { return o.stop && o.stop->load(); };

  // ---- one item's stages ------------------------------------------------------------------
  // Read: decode the image and labels, linearize.
  // `rb`: the group's balance so far (batch --sequence), else null.
  auto load = [&](const Item& it, ReaderBalance* rb) {
    Loaded l;
    l.item = it;
    try {
      ImageFileInfo info;
      // A plain 8-bit RGB PNG's codes are linearised directly (6 MB read for a 2048x1024 frame
      // instead of their 24 MB of floats; the same bits), as `night` reads its image, and with
      // the texture's class sums, as `night` makes them (prepare_night): on this reader thread
      // while each block is in cache, instead of in a pass of the compute stage's own.
      const DayImage day = read_day_image(it.image, &info);
      if (!day.codes) l.image_note = day_image_note(day.floats, info);
      l.image_file_note = info.note;
      l.labels = scene::read_labels(it.labels, it.instances, day.width(), day.height(),
                                    scene::parse_label_format(it.label_format), scene::ResizeLabels::None);
      const bool ego = o.sequences && o.ego_motion && !it.odometry.empty();
      // The camera file, read once: its intrinsics for the item's rig (unless --rig replaces them)
      // and its extrinsics for the camera's place on the vehicle (with odometry, whatever --rig).
      std::optional<scene::CameraRig> camera_file;
      if ((item_cameras || ego) && !it.camera.empty()) camera_file = scene::load_cityscapes_camera(it.camera);
      if (item_cameras && camera_file) {
        l.camera_sum = file_checksum_hex(it.camera, ChecksumAlgorithm::Xxh3_64);
        l.rig = camera_file;
      }
      if (ego && it.odometry_given) {  // a manifest line's own fields
        l.odometry = it.odometry_given;
        const scene::OdometrySample& g = *it.odometry_given;
        l.mount_source = g.camera_forward_m != 0 || g.camera_left_m != 0 || g.camera_yaw_rad != 0
                             ? "manifest " + it.odometry
                             : "none: the odometry's reference point (manifest " + it.odometry + ")";
      } else if (ego && it.odometry_line >= 0) {
        const scene::CameraMount mount =
            it.odometry_calib.empty() ? scene::CameraMount{} : scene::read_kitti_camera_mount(it.odometry_calib);
        l.odometry = scene::read_kitti_oxts(it.odometry, it.odometry_time, *kitti_stamps(it.odometry_time), it.odometry_line, mount);
        l.mount_source = it.odometry_calib.empty() ? "none: the OXTS unit's place" : "KITTI calibration " + it.odometry_calib;
      } else if (ego) {
        const scene::CameraMount mount = camera_file ? scene::cityscapes_camera_mount(*camera_file) : scene::CameraMount{};
        l.odometry = scene::read_cityscapes_odometry(it.odometry, it.odometry_time, mount);
        l.mount_source = camera_file ? "Cityscapes camera file " + it.camera : "none: the rear axle's centre";
      }
      // (And the sun/shade split's block sums, from the same pass: the preset says whether it is on.)
      if (rb && rb->group != it.group) *rb = ReaderBalance{it.group, std::nullopt};
      const scene::DayBalance* carried = rb && rb->fixed ? &*rb->fixed : nullptr;
      // The sky seen through tree crowns taken for sky before the sums read the labels, as `night`
      // takes it (prepare_night); the compute stage gives the file's ids back.
      l.day = scene::linearize_taking_sky_gaps(day.floats, day.codes ? &*day.codes : nullptr, info, l.labels, &l.sums,
                                               sp, carried);
      if (rb && !rb->fixed && l.sums.balance.use == scene::DayBalance::Use::Road) rb->fixed = l.sums.balance;
    } catch (const ParameterError& e) {
      // batch takes labels of the image's size (it has no --resize-labels): say what to do.
      l.error = e.parameter() == "resize_labels"
                    ? e.message_for("--resize-labels") + " (batch has no such option: resample the labels to the "
                                                         "image's size, or run `night --resize-labels nearest`)"
                    : e.what();
    } catch (const Error& e) {
      l.error = e.what();
    } catch (const std::exception& e) {  // no exception may leave a worker's thread (terminate)
      l.error = it.image + ": " + e.what();
    }
    return l;
  };
  // Compute: the scene and the sensor; the files' writers (encoding included) for the write
  // stage. One fixed-pattern map per frame size, loaded once.
  std::map<std::pair<int, int>, FixedPatternMaps> fpn_cache;
  std::mutex fpn_m;
  const auto wb = white_balance_gains(r.camera);
  // g: o.sequences, the current group's state (a group's items in frame order).
  auto compute = [&](Loaded& l, GroupState& g) {
    Computed c;
    c.item = l.item;
    c.camera_sum = l.camera_sum;
    if (!l.error.empty()) {
      c.error = l.error;
      return c;
    }
    try {
      const Item& it = l.item;
      const uint64_t seed = group_seed(r.settings.seed, it.group);
      const scene::ScenePreset* spi = &sp;
      scene::ScenePreset with_camera;
      if (l.rig) {
        with_camera = sp;
        with_camera.rig = *l.rig;
        spi = &with_camera;
      }
      if (o.sequences && it.group != g.group) {
        g = GroupState();
        g.group = it.group;
      }
      // The camera's pose: from the last computed frame's by the odometry of both (a group whose
      // first frame has odometry), else 0.
      if (o.sequences && g.seq.frames == 0) g.ego = l.odometry.has_value();
      if (g.ego) {
        if (!l.odometry)
          throw Error(it.image + ": no odometry for this frame (" +
                      (it.odometry.empty() ? std::string("no vehicle or OXTS file") : it.odometry) +
                      ") while its sequence's first frame had some: its camera pose is unknown (--ego-motion none "
                      "takes every frame at pose 0)");
        if (g.odometry) g.seq.pose = scene::advance_pose(g.pose, *g.odometry, *l.odometry, it.odometry_time);
      } else if (o.sequences && l.odometry) {
        throw Error(it.image + ": has odometry (" + it.odometry + ") while its sequence's first frame had none");
      }
      auto ns = std::make_shared<scene::NightScene>(
          night_scene_for(runner, l.day, l.labels, *spi, seed, false, r, o.sequences ? &g.seq : nullptr, &l.sums));
      scene::restore_sky_gaps(l.labels);  // the outputs' labels.Y: the file's
      if (g.ego) {
        g.odometry = l.odometry;
        g.pose = g.seq.pose;
      }
      auto rr = std::make_shared<SensorSetup>(r);
      rr->settings.seed = seed;
      rr->settings.frame = static_cast<uint32_t>(it.frame);
      const ResolvedExposure ex = resolve(rr->camera, rr->lens, rr->settings);
      const int w = ns->radiance.width(), h = ns->radiance.height();
      const FixedPatternMaps* fpn_p;
      {
        std::lock_guard g(fpn_m);  // std::map: references stay valid as entries are added
        const auto key = std::make_pair(w, h);
        if (!fpn_cache.count(key)) fpn_cache[key] = store.load_or_create(r.camera, r.device_id, w, h);
        fpn_p = &fpn_cache[key];
      }
      const FixedPatternMaps& fpn = *fpn_p;
      auto so = std::make_shared<SensorOutput>(
          runner.expose(ns->radiance, rr->camera, lens_for_frame(rr->lens, rr->camera, ns->geometry), rr->settings, fpn,
                        ns->resident_radiance,
                        ns->glare_level1.get()));
      ns->glare_level1.reset();  // read by the glare above only (peak memory)
      auto labels = std::make_shared<scene::LabelMap>(std::move(l.labels));
      // The inputs as recorded in the header: lexically normal, so `--root ./cs` and `--root cs`
      // write the same bytes (the manifest's source is normal too).
      auto normal = [](const std::string& p) { return fs::path(p).lexically_normal().string(); };
      const NightInputs in{normal(it.image), normal(it.labels), normal(it.instances), l.image_note, l.image_file_note};
      // The EXR header's attributes (the fixed pattern's checksum among them, a pass over its
      // three maps): only when an EXR is written.
      auto attrs = std::make_shared<std::map<std::string, ExrAttribute>>();
      if (o.format != "png") {
        *attrs = night_attributes(*rr, ex, fpn, *spi, *ns, *labels, in);
        (*attrs)["photosite/batch/group"] = it.group;
        if (g.ego) {  // the frame's camera pose from the odometry, in the road coordinates of its sequence's first frame
          (*attrs)["photosite/batch/pose_X_m"] = g.seq.pose.X_m;
          (*attrs)["photosite/batch/pose_D_m"] = g.seq.pose.D_m;
          (*attrs)["photosite/batch/pose_yaw_rad"] = g.seq.pose.yaw_rad;
          // The camera's place on the vehicle the pose was computed with (ISO 8855, m and rad).
          (*attrs)["photosite/batch/camera_forward_m"] = l.odometry->camera_forward_m;
          (*attrs)["photosite/batch/camera_left_m"] = l.odometry->camera_left_m;
          (*attrs)["photosite/batch/camera_yaw_rad"] = l.odometry->camera_yaw_rad;
          (*attrs)["photosite/batch/camera_mount"] = l.mount_source;
        }
      }
      ExrWriteOptions wo;
      wo.half = o.half;
      wo.compression = o.compression;
      wo.reproducible = true;
      const LayerSet layers = o.layers;
      if (o.format != "png")
        c.writes.emplace_back(it.key + ".exr", [=](const std::string& p) {
          write_exr(p, night_channels(*so, *ns, *labels, layers), *attrs, wo);
        });
      if (o.format != "exr") {
        const double min_white = preview_min_white(rr->camera, ex, wb);
        c.writes.emplace_back(it.key + ".png", [=](const std::string& p) {
          write_png8(p, preview_srgb8(so->rgb, wb, 0.99, 1.0, min_white));
        });
      }
      // Labels carried over unchanged: byte copies, written atomically too.
      for (const auto& [src, dst] : {std::pair{it.labels, it.labels_rel}, std::pair{it.instances, it.instances_rel}})
        if (!dst.empty())
          c.writes.emplace_back(dst, [src = src](const std::string& p) {
            atomic_write(p, [&](const std::string& tmp) {
              std::error_code e2;
              fs::copy_file(src, tmp, fs::copy_options::overwrite_existing, e2);
              if (e2) fail_at(p, "cannot copy labels: " + e2.message());
            });
          });
    } catch (const std::exception& e) {  // Error, or anything else: no exception may leave a thread
      c.error = l.item.image + ": " + e.what();
    }
    return c;
  };
  // Write: every file under a temporary name, renamed when complete; then the manifest record.
  auto write = [&](Computed& cmp) {
    std::string error = cmp.error;
    nlohmann::json files = nlohmann::json::array();
    if (error.empty()) try {
        // First the item's output paths, as a "writing" record: a kill between publishing its
        // first file and recording it finished leaves files that a re-run knows as its own
        // (and redoes), instead of refusing them as someone else's.
        nlohmann::json paths = nlohmann::json::array();
        for (const auto& w : cmp.writes) paths.push_back(w.first);
        {
          std::lock_guard l(state_m);
          journal.append(nlohmann::json({{"writing", cmp.item.key}, {"paths", paths}}).dump() + "\n");
        }
        for (auto& [relp, write_file] : cmp.writes) {
          const fs::path p = out / relp;
          // Not the throwing overload: its exception left the worker's thread (terminate).
          std::error_code dec;
          fs::create_directories(p.parent_path(), dec);
          if (dec) fail_at(p.parent_path().string(), "cannot create the folder: " + dec.message());
          write_file(p.string());
          const auto sum = file_checksum_hex(p.string(), ChecksumAlgorithm::Xxh3_64);
          if (!sum) fail_at(p.string(), "cannot read back the file just written (for its checksum)");
          files.push_back({{"path", relp}, {"xxh3_64", *sum}});
        }
      } catch (const Error& e) {
        error = e.what();
      } catch (const std::exception& e) {  // no exception may leave a writer's thread (terminate)
        error = cmp.item.image + ": " + e.what();
      }
    std::lock_guard l(state_m);
    if (error.empty()) try {
        nlohmann::json rec = {{"key", cmp.item.key}, {"files", files}};
        if (cmp.camera_sum) rec["camera_file_xxh3_64"] = *cmp.camera_sum;
        if (const auto odo = odometry_text(cmp.item)) rec["odometry"] = *odo;
        if (const auto src = odometry_sources.find(cmp.item.key); src != odometry_sources.end())
          rec["odometry_sources"] = src->second;
        if (const auto sf = sequence_frames.find(cmp.item.key); sf != sequence_frames.end())
          rec["sequence_frames_xxh3_64"] = sf->second;
        journal.append(rec.dump() + "\n");
      } catch (const Error& e) {
        error = e.what();  // published, unrecorded: its "writing" record has them redone
      }
    if (!error.empty()) {
      result.errors.push_back(error);
      ++pr.failed;
      // With sequences: the frames after it are computed without it, so an earlier finished record
      // of it must not make its sequence look finished on the next run (the manifest's reader).
      // Best effort: a manifest that cannot be written has failed the item already.
      if (o.sequences) try {
          journal.append(nlohmann::json({{"failed", cmp.item.key}}).dump() + "\n");
        } catch (const Error&) {
        }
    } else {
      ++pr.written;
    }
    report();
  };

  StageTimes& st = result.stages;
  const int cores = std::max(1, omp_get_num_procs());
  // On the CPU, when EXR files are written: workers. Measured on 2 cores (docs/benchmarks.md
  // "Batch throughput", 2026-11-28 second session): with a reader, a compute team spanning the
  // cores and a writer whose OpenEXR pool spans them too, the team's barriers wait while the
  // others hold a core; independent workers, one image each with an OpenMP team of cores /
  // (workers busy) threads, used 10% less CPU per image on the EXR route. On the PNG-only route
  // (a light writer) they did not: more CPU in most alternating pairs, so it keeps the stages.
  if (runner.backend() == Backend::Cpu && o.format != "png") {
    // ---- workers that each take an item through all three stages -------------------------------
    // The stages of different items overlap as the OS shares the cores; no barrier spans two
    // items. Images in flight: the workers, at most queue_depth. With sequences a worker takes
    // a whole group, in frame order, with the group's own state.
    std::vector<std::pair<size_t, size_t>> units;  // [begin, end) of todo
    for (size_t i = 0; i < todo.size();) {
      size_t e = i + 1;
      if (o.sequences)
        while (e < todo.size() && todo[e].group == todo[i].group) ++e;
      units.emplace_back(i, e);
      i = e;
    }
    const int n_workers = static_cast<int>(std::min<size_t>({static_cast<size_t>(o.queue_depth),
                                                              static_cast<size_t>(cores), std::max<size_t>(1, units.size())}));
    std::atomic<size_t> next_unit{0};
    std::atomic<int> busy{n_workers};
    std::atomic<bool> interrupted{false};
    std::vector<StageTimes> times(n_workers);
    auto team = [&] {  // the OpenMP team of a worker's next stage
      omp_set_num_threads(o.compute_threads > 0 ? o.compute_threads : std::max(1, cores / std::max(1, busy.load())));
    };
    auto worker = [&](int j) {
      StageTimes& t = times[j];
      GroupState g;
      ReaderBalance rb;
      for (;;) {
        if (stopped()) {
          interrupted = true;
          break;
        }
        const size_t u = next_unit++;
        if (u >= units.size()) break;
        for (size_t i = units[u].first; i < units[u].second; ++i) {
          double c0 = thread_cpu_ms();
          team();
          Loaded l = load(todo[i], o.sequences ? &rb : nullptr);
          const double c1 = thread_cpu_ms();
          t.reader_cpu_ms += c1 - c0;
          team();
          Computed c = compute(l, g);
          l = Loaded();  // the day image and the labels' copy are no longer needed
          const double c2 = thread_cpu_ms();
          t.compute_cpu_ms += c2 - c1;
          team();
          write(c);
          t.writer_cpu_ms += thread_cpu_ms() - c2;
        }
      }
      --busy;  // the others' next stages get this worker's cores
    };
    std::vector<std::thread> workers;
    for (int j = 1; j < n_workers; ++j) workers.emplace_back(worker, j);
    const OmpThreads restore(0);  // the calling thread's team size, restored when the run ends
    worker(0);
    for (auto& t : workers) t.join();
    if (interrupted) result.interrupted = true;
    for (const auto& t : times) {
      st.reader_cpu_ms += t.reader_cpu_ms;
      st.compute_cpu_ms += t.compute_cpu_ms;
      st.writer_cpu_ms += t.writer_cpu_ms;
    }
  } else {
    // ---- a reader thread, compute on this thread, writer threads, bounded queues ------------------
    BoundedQueue<Loaded> loaded(static_cast<size_t>(o.queue_depth));
    BoundedQueue<Computed> computed(static_cast<size_t>(o.queue_depth));
    // The writer (EXR encoding) gets OpenEXR's own thread pool and the compute stage a full
    // OpenMP team, and the OS shares the cores between them. compute_threads caps the compute
    // stage's team (e.g. beside other jobs on a shared node).
    const OmpThreads omp_team(o.compute_threads);
    std::thread reader([&] {
      const double cpu0 = thread_cpu_ms();
      ReaderBalance rb;
      for (const auto& it : todo) {
        if (stopped()) {
          result.interrupted = true;  // read by the calling thread only after join()
          break;
        }
        loaded.push(load(it, o.sequences ? &rb : nullptr), &st.reader_wait_ms);
      }
      st.reader_cpu_ms = thread_cpu_ms() - cpu0;  // read by the calling thread only after join()
      loaded.close();
    });
    std::vector<std::thread> writers;
    std::vector<double> writer_cpu_ms(o.jobs, 0.0), writer_wait_ms(o.jobs, 0.0);
    for (int j = 0; j < o.jobs; ++j)
      writers.emplace_back([&, j] {
        const double cpu0 = thread_cpu_ms();
        while (auto cmp = computed.pop(&writer_wait_ms[j])) write(*cmp);
        writer_cpu_ms[j] = thread_cpu_ms() - cpu0;
      });
    GroupState g;
    const double compute_cpu0 = thread_cpu_ms();
    while (auto l = loaded.pop(&st.compute_wait_in_ms)) computed.push(compute(*l, g), &st.compute_wait_out_ms);
    st.compute_cpu_ms = thread_cpu_ms() - compute_cpu0;
    reader.join();
    computed.close();
    for (auto& t : writers) t.join();
    for (int j = 0; j < o.jobs; ++j) {
      st.writer_cpu_ms += writer_cpu_ms[j];
      st.writer_wait_ms += writer_wait_ms[j];
    }
  }
  std::lock_guard l(state_m);
  pr.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace photosite::batch
