// `photosite batch`: a whole data set to night, on one machine or as one shard of many.
//
// Pipeline: a reader thread decodes images and labels, the main thread computes (the scene and
// the sensor, OpenMP inside), writer threads encode and write; bounded queues between them keep
// memory flat whatever the number of images. Every file is written under a temporary name and
// renamed; a small per-shard manifest (out/.photosite-batch/) records each finished item with its
// files' checksums and the run's parameters, so a re-run skips finished items and refuses to mix
// results of other parameters.
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include <omp.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "photosite/batch.h"
#include "photosite/error.h"
#include "photosite/sensor/isp.h"
#include "photosite/outputs.h"
#include "sensor_options.h"
#include "backend.h"
#include "registry.h"

namespace photosite::cli {
namespace fs = std::filesystem;
using batch::Item;

namespace {
std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

template <class T>
class BoundedQueue {
 public:
  explicit BoundedQueue(size_t cap) : cap_(cap) {}
  void push(T v) {
    std::unique_lock l(m_);
    not_full_.wait(l, [&] { return q_.size() < cap_; });
    q_.push_back(std::move(v));
    not_empty_.notify_one();
  }
  std::optional<T> pop() {
    std::unique_lock l(m_);
    not_empty_.wait(l, [&] { return !q_.empty() || closed_; });
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

struct BatchCmd {
  std::string dataset, root, manifest, out, shard = "0/1", format = "exr", compression = "piz",
                                               scene_preset = "night-urban";
  std::string rig = "auto";  // auto: the data set's rig (kitti, cityscapes), else by aspect ratio
  bool half = false, quiet = false;
  int jobs = 1, queue_depth = 2;
  int compute_threads = 0;  // 0: OpenMP's default (every hardware thread)
  SensorOptions sensor;
  std::string backend = "auto";
  std::string layers;  // empty: kBatchLayers
};

struct Loaded {
  Item item;
  ImageF day;  // linear sRGB
  scene::LabelMap labels;
  std::string error;
};
struct Computed {
  Item item;
  std::string error;
  std::vector<std::pair<std::string, std::function<void(const std::string&)>>> writes;  // rel path, writer
};

std::string read_text(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// Removes temporaries left by a killed run (".<name>.tmp-<pid>-<n>.<ext>" whose pid is gone).
void remove_stale_temporaries(const fs::path& out) {
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(out, ec); it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (ec) break;
    const std::string n = it->path().filename().string();
    const auto t = n.find(".tmp-");
    if (n.empty() || n[0] != '.' || t == std::string::npos) continue;
    const int pid = std::atoi(n.c_str() + t + 5);
    if (pid > 0 && (kill(pid, 0) == 0 || errno != ESRCH)) continue;  // still running
    fs::remove(it->path(), ec);
  }
}

void run(BatchCmd& c) {
  // ---- inputs and parameters ------------------------------------------------------------
  if (c.dataset.empty() == c.manifest.empty()) fail("batch: give either --dataset with --root, or --manifest");
  if (!c.dataset.empty() && c.root.empty()) fail("batch: --dataset needs --root");
  if (c.format != "exr" && c.format != "png" && c.format != "both") fail("--format must be exr, png or both");
  const LayerSet layers = c.layers.empty() ? kBatchLayers : parse_layers(c.layers, kNightLayers, "--layers", "batch");
  if (c.jobs < 1 || c.jobs > 64) fail("--jobs must be in [1, 64]");
  if (c.queue_depth < 1 || c.queue_depth > 64) fail("--queue-depth must be in [1, 64]");
  if (c.compute_threads < 0 || c.compute_threads > 256) fail("--compute-threads must be in [0, 256]");
  const auto [shard_i, shard_n] = batch::parse_shard(c.shard);
  std::vector<Item> all;
  std::string source;
  if (!c.manifest.empty()) {
    all = batch::read_manifest(c.manifest);
    source = "manifest " + fs::absolute(c.manifest).lexically_normal().string();
  } else {
    const auto ds = batch::parse_dataset(c.dataset);
    all = batch::discover(ds, c.root);
    source = std::string(batch::to_string(ds)) + " " + fs::absolute(c.root).lexically_normal().string();
    if (c.sensor.preset.empty()) c.sensor.preset = ds == batch::Dataset::Kitti ? "sony-icx267-flea2" : "onsemi-ar0331";
    if (c.rig == "auto" && ds == batch::Dataset::Kitti) c.rig = "kitti";
    if (c.rig == "auto" && ds == batch::Dataset::Cityscapes) c.rig = "cityscapes";
  }
  if (c.sensor.preset.empty()) c.sensor.preset = "onsemi-ar0331";
  if (c.sensor.frames != 1) fail("batch: --frames does not apply (sequences come from the data set's own frames)");
  std::error_code ec;
  if (!c.root.empty() && fs::exists(c.out, ec) && fs::equivalent(c.out, c.root, ec))
    fail_at(c.out, "the output folder is the data set's own root; choose another --out");
  fs::create_directories(c.out, ec);
  if (!fs::is_directory(c.out, ec)) fail_at(c.out, "cannot create the output folder");
  const std::vector<Item> items = batch::shard(all, shard_i, shard_n);
  auto r = c.sensor.resolve();
  SensorRunner runner(resolve_backend(c.backend));
  scene::ScenePreset sp = scene::load_scene_preset(c.scene_preset);
  if (c.rig != "auto") sp.rig = scene::load_camera_rig(c.rig);  // auto: per image (rig_for_image)

  // Parameters that decide the results (not the shard: results do not depend on the split).
  nlohmann::json params = {
      {"photosite_version", PHOTOSITE_VERSION}, {"source", source},
      {"camera", r.camera.name}, {"camera_file_fnv", fmt::format("{:016x}", batch::fnv1a_text(read_text(r.camera.file)))},
      {"lens", r.lens.name}, {"lens_file_fnv", fmt::format("{:016x}", batch::fnv1a_text(read_text(r.lens.file)))},
      {"scene_preset", sp.name}, {"scene_file_fnv", fmt::format("{:016x}", batch::fnv1a_text(read_text(sp.file)))},
      {"camera_rig", c.rig}, {"rig_file_fnv", sp.rig.file.empty() ? std::string() : fmt::format("{:016x}", batch::fnv1a_text(read_text(sp.rig.file)))},
      {"exposure_s", r.settings.exposure_s}, {"f_number", std::isnan(r.settings.f_number) ? -1.0 : r.settings.f_number},
      {"gain_db", r.settings.gain_db}, {"temperature_c", std::isnan(r.settings.temperature_c) ? -999.0 : r.settings.temperature_c},
      {"seed", r.settings.seed}, {"device_id", r.device_id}, {"demosaic", to_string(r.settings.demosaic)},
      {"poisson", to_string(r.settings.poisson)},
      {"format", c.format}, {"half", c.half}, {"compression", c.compression}, {"layers", layers_text(layers)}};
  const std::string params_text = params.dump();

  // ---- the resume manifest ------------------------------------------------------------------
  const fs::path mdir = fs::path(c.out) / ".photosite-batch";
  fs::create_directories(mdir, ec);
  remove_stale_temporaries(c.out);
  std::map<std::string, nlohmann::json> done;  // key → record
  for (const auto& e : fs::directory_iterator(mdir, ec)) {
    if (e.path().extension() != ".jsonl") continue;
    std::ifstream f(e.path());
    std::string line;
    bool first = true;
    while (std::getline(f, line)) {
      nlohmann::json j = nlohmann::json::parse(line, nullptr, false);
      if (j.is_discarded()) continue;  // a line cut short by a kill
      if (first) {
        first = false;
        if (!j.contains("params") || j["params"].dump() != params_text)
          fail_at(c.out, "was written by a batch run with other parameters (" + e.path().filename().string() +
                             "); photosite does not mix results: use a new --out");
        continue;
      }
      if (j.contains("key")) done[j["key"]] = j;
    }
  }
  auto finished = [&](const Item& it) {
    auto d = done.find(it.key);
    if (d == done.end()) return false;
    for (const auto& f : d->second["files"]) {
      const fs::path p = fs::path(c.out) / f["path"].get<std::string>();
      if (!fs::exists(p) || fmt::format("{:016x}", batch::fnv1a_file(p.string())) != f["fnv"].get<std::string>())
        return false;
    }
    return true;
  };
  std::vector<Item> todo;
  for (const auto& it : items)
    if (!finished(it)) todo.push_back(it);
  // Every output we are about to write must be new, or one of ours from an unfinished item.
  std::set<std::string> ours;
  for (const auto& [k, rec] : done)
    for (const auto& f : rec["files"]) ours.insert(f["path"].get<std::string>());
  auto outputs_of = [&](const Item& it) {
    std::vector<std::string> o;
    if (c.format != "png") o.push_back(it.key + ".exr");
    if (c.format != "exr") o.push_back(it.key + ".png");
    if (!it.labels_rel.empty()) o.push_back(it.labels_rel);
    if (!it.instances_rel.empty()) o.push_back(it.instances_rel);
    return o;
  };
  for (const auto& it : todo)
    for (const auto& o : outputs_of(it)) {
      const fs::path p = fs::path(c.out) / o;
      if (fs::exists(p, ec) && !ours.count(o))
        fail_at(p.string(), "exists and was not written by this batch; photosite never overwrites other files");
      if (!c.root.empty() && fs::exists(p, ec)) {
        for (const std::string& in : {it.image, it.labels, it.instances})
          if (!in.empty() && fs::equivalent(p, in, ec)) fail_at(p.string(), "output would overwrite an input");
      }
    }
  const std::string mfile = (mdir / fmt::format("shard-{}-of-{}.jsonl", shard_i, shard_n)).string();
  const bool new_manifest = !fs::exists(mfile, ec);
  std::ofstream mout(mfile, std::ios::app);
  if (!mout) fail_at(mfile, "cannot write the batch manifest");
  if (new_manifest) mout << nlohmann::json({{"params", params}}).dump() << "\n" << std::flush;
  std::mutex mout_m;

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  const bool tty = !c.quiet && isatty(2);
  const size_t total = todo.size();
  if (!c.quiet)
    std::fprintf(stderr, "batch: %zu items in shard %d/%d, %zu already done, %zu to do\n", items.size(), shard_i,
                 shard_n, items.size() - total, total);

  // ---- the pipeline -----------------------------------------------------------------------
  BoundedQueue<Loaded> loaded(static_cast<size_t>(c.queue_depth));
  BoundedQueue<Computed> computed(static_cast<size_t>(c.queue_depth));
  // By default every part may use every core: the writer (EXR encoding, the slowest part) gets
  // OpenEXR's own thread pool and the compute stage a full OpenMP team, and the OS shares the
  // cores between them. Measured on 2 cores (docs/benchmarks.md, bench batch): pinning the writer
  // and the reader to one thread each and giving compute the rest made the run 1.6x slower, since
  // the writer then runs single-threaded while compute idles. --compute-threads N caps the
  // compute stage's team (e.g. beside other jobs on a shared node).
  if (c.compute_threads > 0) omp_set_num_threads(c.compute_threads);
  std::thread reader([&] {
    for (const auto& it : todo) {
      if (g_stop) break;
      Loaded l;
      l.item = it;
      try {
        ImageFileInfo info;
        ImageF day = read_image(it.image, &info);
        l.labels = scene::read_labels(it.labels, it.instances, day.width(), day.height(),
                                      scene::parse_label_format(it.label_format), scene::ResizeLabels::None);
        l.day = scene::linearize(day, info);
      } catch (const Error& e) {
        l.error = e.what();
      }
      loaded.push(std::move(l));
    }
    loaded.close();
  });
  std::atomic<size_t> written{0};
  std::vector<std::string> errors;
  std::mutex err_m;
  const auto t0 = std::chrono::steady_clock::now();
  auto progress = [&] {
    if (!tty) return;
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const size_t n = written;
    const double rate = el > 0 ? n / el : 0;
    const double left = rate > 0 ? (total - n) / rate : 0;
    const int bar = total ? static_cast<int>(30.0 * n / total) : 30;
    std::fprintf(stderr, "\r[%s%s] %zu/%zu  %.2f img/s  %02d:%02d left ", std::string(bar, '#').c_str(),
                 std::string(30 - bar, ' ').c_str(), n, total, rate, static_cast<int>(left) / 60, static_cast<int>(left) % 60);
  };
  std::vector<std::thread> writers;
  for (int j = 0; j < c.jobs; ++j)
    writers.emplace_back([&] {
      while (auto cmp = computed.pop()) {
        if (!cmp->error.empty()) {
          std::lock_guard l(err_m);
          errors.push_back(cmp->error);
          continue;
        }
        nlohmann::json files = nlohmann::json::array();
        try {
          for (auto& [relp, write] : cmp->writes) {
            const fs::path p = fs::path(c.out) / relp;
            fs::create_directories(p.parent_path());
            write(p.string());
            files.push_back({{"path", relp}, {"fnv", fmt::format("{:016x}", batch::fnv1a_file(p.string()))}});
          }
        } catch (const Error& e) {
          std::lock_guard l(err_m);
          errors.push_back(e.what());
          continue;
        }
        {
          std::lock_guard l(mout_m);
          mout << nlohmann::json({{"key", cmp->item.key}, {"files", files}}).dump() << "\n" << std::flush;
        }
        ++written;
        progress();
      }
    });

  std::map<std::pair<int, int>, FixedPatternMaps> fpn_cache;
  while (auto l = loaded.pop()) {
    Computed out;
    out.item = l->item;
    if (!l->error.empty()) {
      out.error = l->error;
      computed.push(std::move(out));
      continue;
    }
    try {
      const Item& it = l->item;
      const uint64_t seed = batch::group_seed(r.settings.seed, it.group);
      auto ns = std::make_shared<scene::NightScene>(scene::night_scene(l->day, l->labels, sp, seed, false, runner.pixel_stages()));
      auto rr = std::make_shared<SensorOptions::Resolved>(r);
      rr->settings.seed = seed;
      rr->settings.frame = static_cast<uint32_t>(it.frame);
      const ResolvedExposure ex = resolve(rr->camera, rr->lens, rr->settings);
      const int w = ns->radiance.width(), h = ns->radiance.height();
      auto key = std::make_pair(w, h);
      if (!fpn_cache.count(key)) fpn_cache[key] = r.store.load_or_create(r.camera, r.device_id, w, h);
      const FixedPatternMaps& fpn = fpn_cache[key];
      auto so = std::make_shared<SensorOutput>(runner.expose(ns->radiance, rr->camera, rr->lens, rr->settings, fpn,
                                                                    ns->resident_radiance));
      auto label_img = std::make_shared<ImageF>(label_image(l->labels));
      NightInputs in{it.image, it.labels, it.instances};
      auto attrs = std::make_shared<std::map<std::string, ExrAttribute>>(
          night_attributes(*rr, ex, fpn, sp, *ns, l->labels, in));
      (*attrs)["photosite/batch/group"] = it.group;
      ExrWriteOptions wo;
      wo.half = c.half;
      wo.compression = c.compression;
      wo.reproducible = true;
      if (c.format != "png")
        out.writes.emplace_back(it.key + ".exr", [=](const std::string& p) {
          write_exr(p, night_channels(*so, *ns, *label_img, layers), *attrs, wo);
        });
      if (c.format != "exr") {
        auto wb = white_balance_gains(rr->camera);
        out.writes.emplace_back(it.key + ".png", [=](const std::string& p) { write_png(p, preview_srgb(so->rgb, wb)); });
      }
      // Labels carried over unchanged: byte copies, written atomically too.
      for (const auto& [src, dst] : {std::pair{it.labels, it.labels_rel}, std::pair{it.instances, it.instances_rel}})
        if (!dst.empty())
          out.writes.emplace_back(dst, [src = src](const std::string& p) {
            atomic_write(p, [&](const std::string& tmp) {
              std::error_code e2;
              fs::copy_file(src, tmp, fs::copy_options::overwrite_existing, e2);
              if (e2) fail_at(p, "cannot copy labels: " + e2.message());
            });
          });
    } catch (const Error& e) {
      out.error = l->item.image + ": " + e.what();
    }
    computed.push(std::move(out));
  }
  reader.join();
  computed.close();
  for (auto& t : writers) t.join();
  if (tty) std::fprintf(stderr, "\n");
  const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!c.quiet)
    std::fprintf(stderr, "batch: wrote %zu items in %.1f s (%.2f s per item)%s\n", written.load(), el,
                 written ? el / written : 0.0, g_stop ? ", interrupted" : "");
  if (!errors.empty()) {
    for (const auto& e : errors) std::fprintf(stderr, "photosite: error: %s\n", e.c_str());
    fail(fmt::format("batch: {} of {} items failed (the others are written; re-run to retry)", errors.size(), total));
  }
  if (g_stop) throw Error("batch: interrupted; re-run the same command to finish", Error::Kind::BadInput);
}
}  // namespace

static Registrar reg("f-batch", [](CLI::App& app) {
  auto c = std::make_shared<BatchCmd>();
  auto* sub = app.add_subcommand("batch", "translate a whole data set to night (resumable, shardable)");
  sub->add_option("--dataset", c->dataset, "cityscapes, kitti or bdd100k (with --root)");
  sub->add_option("--root", c->root, "the data set's root folder");
  sub->add_option("--manifest", c->manifest, "file of 'image labels [instances]' lines instead of --dataset");
  sub->add_option("--out", c->out, "output folder (mirrors the data set's layout)")->required();
  sub->add_option("--shard", c->shard, "I/N: process the I-th of N deterministic shards")->capture_default_str();
  sub->add_option("--format", c->format, "exr, png (preview) or both")->capture_default_str();
  sub->add_option("--layers", c->layers, "comma list of layers to write: sensor,raw,electrons,radiance,lights,depth,labels (default: sensor,raw,electrons,depth,labels)");
  sub->add_flag("--half", c->half, "store EXR channels as half floats");
  sub->add_option("--compression", c->compression, "EXR compression (zip, piz, dwaa, none, ...)")->capture_default_str();
  sub->add_option("--jobs", c->jobs, "writer threads")->capture_default_str();
  sub->add_option("--compute-threads", c->compute_threads,
                  "OpenMP threads for the scene and sensor (0: all hardware threads)")
      ->capture_default_str();
  sub->add_option("--queue-depth", c->queue_depth, "images in flight between stages (bounds memory)")->capture_default_str();
  sub->add_option("--scene-preset", c->scene_preset, "scene preset")->capture_default_str();
  sub->add_option("--rig", c->rig, "camera rig (presets/rigs name or .toml path; auto: the data set's, else by aspect ratio)")
      ->capture_default_str();
  sub->add_flag("--quiet", c->quiet, "no progress output");
  c->sensor.add(sub, false);
  add_backend_option(sub, c->backend);
  sub->callback([c] { run(*c); });
});

}  // namespace photosite::cli
