#include "photosite/batch.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string_view>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/scene/rig.h"
#include "scene/data_file_detail.h"

namespace photosite::batch {
namespace fs = std::filesystem;

Dataset parse_dataset(const std::string& name) {
  if (name == "cityscapes") return Dataset::Cityscapes;
  if (name == "kitti") return Dataset::Kitti;
  if (name == "bdd100k") return Dataset::Bdd100k;
  fail_parameter("dataset", "unknown ", " '" + name + "' (expected cityscapes, kitti or bdd100k)");
}
DatasetCamera dataset_camera(Dataset d) {
  switch (d) {
    case Dataset::Cityscapes: return {"onsemi-ar0331", "cityscapes"};
    case Dataset::Kitti: return {"sony-icx267-flea2", "kitti"};
    case Dataset::Bdd100k: return {"onsemi-ar0331", "auto"};
  }
  return {"onsemi-ar0331", "auto"};
}

const char* to_string(Dataset d) {
  switch (d) {
    case Dataset::Cityscapes: return "cityscapes";
    case Dataset::Kitti: return "kitti";
    case Dataset::Bdd100k: return "bdd100k";
  }
  return "?";
}

uint64_t fnv1a_text(const std::string& text, uint64_t h) { return fnv1a_64(text.data(), text.size(), h); }

uint64_t group_seed(uint64_t base_seed, const std::string& group) {
  uint64_t z = fnv1a_text(group) ^ (base_seed * 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

namespace {
// p relative to root as the paths are written, links not followed: fs::relative resolves them,
// so a linked file's output was named after its target and could land outside --out.
fs::path lexical_relative(const fs::path& p, const fs::path& root) {
  return fs::absolute(p).lexically_normal().lexically_relative(fs::absolute(root).lexically_normal());
}
std::string rel(const fs::path& p, const fs::path& root) { return lexical_relative(p, root).generic_string(); }

bool all_digits(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); });
}

// Frames: within a group, sorted by (order key, item key), numbered 0, 1, 2, ...
void number_frames(std::vector<Item>& items, const std::map<std::string, long>& order) {
  std::sort(items.begin(), items.end(), [&](const Item& a, const Item& b) {
    if (a.group != b.group) return a.group < b.group;
    const long oa = order.at(a.key), ob = order.at(b.key);
    return oa != ob ? oa < ob : a.key < b.key;
  });
  std::string last;
  int f = 0;
  for (auto& it : items) {
    f = it.group == last ? f + 1 : 0;
    it.frame = f;
    last = it.group;
  }
}

// Files under dir with one of the extensions (any case), sorted. Folder links are followed: data
// sets on other volumes are usually linked in, and skipping them lost their images silently.
// A cycle is not: a folder is not entered when it is (canonically) one of the folders the walk
// is already inside. Nor is `exclude` (the canonical output folder, when it lies in the data
// set: its previews would be found as day images).
std::vector<fs::path> files_under(const fs::path& dir, const std::vector<std::string>& exts,
                                  const fs::path& exclude) {
  std::vector<fs::path> out;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return out;
  std::vector<fs::path> inside{fs::canonical(dir, ec)};  // [d]: the folder of the entries at depth d
  if (!exclude.empty() && inside[0] == exclude)
    fail_at(exclude.string(), "the output folder is the data set's own image folder; choose another --out");
  constexpr auto options = fs::directory_options::skip_permission_denied | fs::directory_options::follow_directory_symlink;
  for (auto it = fs::recursive_directory_iterator(dir, options, ec); it != fs::recursive_directory_iterator();
       it.increment(ec)) {
    if (ec) break;
    if (std::error_code dec; it->is_directory(dec)) {
      const fs::path c = fs::canonical(it->path(), dec);
      inside.resize(static_cast<size_t>(it.depth()) + 1);
      if (dec || c == exclude || std::find(inside.begin(), inside.end(), c) != inside.end())
        it.disable_recursion_pending();
      else
        inside.push_back(c);
      continue;
    }
    if (!it->is_regular_file()) continue;
    const std::string e = lower_extension(it->path().string());
    if (std::find(exts.begin(), exts.end(), e) != exts.end()) out.push_back(it->path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

void require_labels(const Item& it) {
  std::error_code ec;
  if (!fs::exists(it.labels, ec))
    fail_at(it.image, "no labels found for this image (looked for " + it.labels + ")");
}
}  // namespace

std::vector<Item> discover(Dataset d, const std::string& root_s, const std::string& out) {
  const fs::path root(root_s);
  std::error_code ec;
  if (!fs::is_directory(root, ec)) fail_at(root_s, "data set root is not a folder");
  // Canonical as files_under compares; weakly, as the output folder may not exist yet (another
  // shard may create it and write into it while this one walks).
  const fs::path exclude = out.empty() ? fs::path() : fs::weakly_canonical(fs::absolute(out), ec);
  std::vector<Item> items;
  std::map<std::string, long> order;
  if (d == Dataset::Cityscapes) {
    // <root>/leftImg8bit[_sequence]/<split>/<city>/<city>_<seq>_<frame>_leftImg8bit.png and
    // <root>/gtFine/<split>/<city>/<city>_<seq>_<frame>_gtFine_labelIds.png (+ _instanceIds).
    // ".png" in any case, as files_under matches it (a "_leftImg8bit.PNG" was skipped silently).
    static const std::regex name_re(R"((.*)_(\d{6})_(\d{6})_leftImg8bit\.[pP][nN][gG])");
    for (const char* top : {"leftImg8bit", "leftImg8bit_sequence"})
      for (const auto& p : files_under(root / top, {".png"}, exclude)) {
        std::smatch m;
        const std::string name = p.filename().string();
        if (!std::regex_match(name, m, name_re)) continue;
        const std::string stem = name.substr(0, name.size() - std::string("_leftImg8bit.png").size());
        const fs::path sub = lexical_relative(p.parent_path(), root / top);
        Item it;
        it.image = p.string();
        it.key = (fs::path(top) / sub / (stem + "_leftImg8bit")).generic_string();
        const fs::path lab = root / "gtFine" / sub / (stem + "_gtFine_labelIds.png");
        const fs::path ins = root / "gtFine" / sub / (stem + "_gtFine_instanceIds.png");
        it.labels = lab.string();
        it.labels_rel = rel(lab, root);
        if (fs::exists(ins, ec)) {
          it.instances = ins.string();
          it.instances_rel = rel(ins, root);
        }
        it.group = (fs::path(top) / sub / (m[1].str() + "_" + m[2].str())).generic_string();
        it.camera = scene::cityscapes_camera_file(it.image);
        // The odometry beside it: vehicle[_sequence]/ and timestamp[_sequence]/ as leftImg8bit[_sequence]/,
        // both (a vehicle package without the timestamps gives no times to integrate over).
        const std::string suffix = std::string(top) == "leftImg8bit" ? "" : "_sequence";
        const fs::path veh = root / ("vehicle" + suffix) / sub / (stem + "_vehicle.json"),
                       ts = root / ("timestamp" + suffix) / sub / (stem + "_timestamp.txt");
        if (fs::exists(veh, ec) && fs::exists(ts, ec)) {
          it.odometry = veh.string();
          it.odometry_time = ts.string();
        }
        require_labels(it);
        order[it.key] = std::stol(m[3].str());
        items.push_back(std::move(it));
      }
  } else if (d == Dataset::Kitti) {
    // <root>/image_2/<name>.png with <root>/semantic/<name>.png (+ instance/<name>.png). Purely
    // numbered files (0000000123.png) in a folder form one sequence.
    for (const auto& p : files_under(root / "image_2", {".png"}, exclude)) {
      const fs::path sub = lexical_relative(p, root / "image_2");
      Item it;
      it.image = p.string();
      it.key = (fs::path("image_2") / sub).replace_extension().generic_string();
      const fs::path lab = root / "semantic" / sub, ins = root / "instance" / sub;
      it.labels = lab.string();
      it.labels_rel = rel(lab, root);
      if (fs::exists(ins, ec)) {
        it.instances = ins.string();
        it.instances_rel = rel(ins, root);
      }
      const std::string stem = p.stem().string();
      it.group = all_digits(stem) ? (fs::path("image_2") / sub.parent_path() / "seq").generic_string() : it.key;
      // A numbered frame's OXTS record: the drive's oxts folder as KITTI raw ships it (data/<frame>.txt
      // and timestamps.txt), at oxts/<sub>/ as the frames are at image_2/<sub>/. Where the drive has
      // that folder every frame has its record: one missing is then read and refused by its name.
      if (const fs::path oxts = root / "oxts" / sub.parent_path(); all_digits(stem) &&
                                                                    fs::is_directory(oxts / "data", ec)) {
        it.odometry = (oxts / "data" / (stem + ".txt")).string();
        it.odometry_time = (oxts / "timestamps.txt").string();
        it.odometry_line = std::stol(stem);
        // The camera's place on the vehicle: the drive date's calibration files (KITTI raw ships
        // them beside its drives, <date>/calib_*.txt) at calib/<sub>/; where that folder exists
        // all three are read, a missing one refused by its name.
        if (const fs::path calib = root / "calib" / sub.parent_path(); fs::is_directory(calib, ec))
          it.odometry_calib = calib.string();
      }
      require_labels(it);
      order[it.key] = all_digits(stem) ? std::stol(stem) : 0;
      items.push_back(std::move(it));
    }
  } else {
    // BDD100K: <root>/images/10k/<split>/<name>.jpg with <root>/labels/sem_seg/masks/<split>/<name>.png
    // (trainIds).
    for (const auto& p : files_under(root / "images" / "10k", {".jpg", ".jpeg", ".png"}, exclude)) {
      const fs::path sub = lexical_relative(p, root / "images" / "10k");
      Item it;
      it.image = p.string();
      it.key = (fs::path("images/10k") / sub).replace_extension().generic_string();
      const fs::path lab = (root / "labels" / "sem_seg" / "masks" / sub).replace_extension(".png");
      it.labels = lab.string();
      it.labels_rel = rel(lab, root);
      it.label_format = "trainIds";
      it.group = it.key;
      require_labels(it);
      order[it.key] = 0;
      items.push_back(std::move(it));
    }
  }
  if (items.empty())
    fail_at(root_s, std::string("no ") + to_string(d) + " images found in the data set's layout (see docs/cli.md, batch)");
  number_frames(items, order);
  return items;
}

namespace {
// The fields of one manifest line; `bad` throws (an unclosed quote).
std::vector<std::string> manifest_fields(const std::string& line, const std::function<void(const std::string&)>& bad) {
  // Outside double quotes '#' starts a comment. A line with a comma or a tab outside quotes is
  // split at those alone, each field trimmed of spaces (CSV- or TSV-like: a path may hold
  // spaces); any other line at runs of spaces. A double-quoted part is taken as it is, spaces,
  // commas and '#' included ("" inside it is one quote); it must close on its line.
  bool by_separator = false, quoted = false;
  for (const char c : line) {
    if (c == '"') quoted = !quoted;
    else if (!quoted && c == '#') break;
    else if (!quoted && (c == ',' || c == '\t')) by_separator = true;
  }
  std::vector<std::string> fields;
  std::string cur;
  bool have = false;  // cur is a field even if empty (it had a quoted part)
  auto end_field = [&] {
    if (by_separator) {
      const size_t a = cur.find_first_not_of(" \r"), b = cur.find_last_not_of(" \r");
      cur = a == std::string::npos ? std::string() : cur.substr(a, b - a + 1);
    }
    if (have || !cur.empty()) fields.push_back(cur);
    cur.clear();
    have = false;
  };
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (c == '"') {
      size_t j = i + 1;
      for (;; ++j) {
        if (j >= line.size()) bad("a double quote opens a field that does not close on its line");
        if (line[j] != '"') cur += line[j];
        else if (j + 1 < line.size() && line[j + 1] == '"') cur += line[++j];  // "" is one quote
        else break;
      }
      have = true;
      i = j;
    } else if (c == '#') {
      break;
    } else if (by_separator ? (c == ',' || c == '\t') : (c == ' ' || c == '\r')) {
      end_field();
    } else {
      cur += c;
    }
  }
  end_field();
  return fields;
}
}  // namespace

namespace {
// A manifest line's fields: the paths, then key=value fields (read_manifest, batch.h).
struct ManifestLine {
  std::vector<std::string> paths;
  std::string sequence;
  std::optional<scene::OdometrySample> odometry;
};
// The group of a manifest line's sequence=NAME: kSequenceGroup + NAME (a line without is its own).
constexpr std::string_view kSequenceGroup = "sequence:";
constexpr const char* kManifestKeys[] = {"sequence", "time_s", "speed_m_s", "yaw_rate_rad_s",
                                         "camera_forward_m", "camera_left_m", "camera_yaw_rad"};
// The fields of the line at `at`; is_file(field): whether a field names an existing file (a path
// that looks like key=value is a path when it is one).
ManifestLine split_manifest_line(const std::vector<std::string>& fields, const std::string& at,
                                 const std::function<bool(const std::string&)>& is_file) {
  ManifestLine ml;
  std::map<std::string, std::string> kv;
  std::string known;
  for (const char* k : kManifestKeys) known += std::string(known.empty() ? "" : ", ") + k;
  for (const std::string& f : fields) {
    const size_t eq = f.find('=');
    const std::string key = eq == std::string::npos ? std::string() : f.substr(0, eq);
    const bool keyish = !key.empty() && std::all_of(key.begin(), key.end(), [](unsigned char c) {
      return std::islower(c) || c == '_';
    });
    if (keyish && std::find_if(std::begin(kManifestKeys), std::end(kManifestKeys),
                               [&](const char* k) { return key == k; }) != std::end(kManifestKeys)) {
      if (!kv.emplace(key, f.substr(eq + 1)).second) fail(at + ": " + key + " given twice");
      continue;
    }
    if (keyish && !is_file(f)) fail(at + ": unknown field key '" + key + "' (the keys after the paths: " + known + ")");
    if (!kv.empty()) fail(at + ": '" + f + "' after the key=value fields: the paths (image labels [instances]) come first");
    ml.paths.push_back(f);
  }
  auto number = [&](const char* key, double lo, double hi, const char* unit, const char* why) -> std::optional<double> {
    const auto i = kv.find(key);
    if (i == kv.end()) return std::nullopt;
    const std::string& t = i->second;
    double v = 0;
    const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    if (t.empty() || r.ec != std::errc() || r.ptr != t.data() + t.size()) fail(at + ": " + key + "=" + t + ": not a number");
    return scene::detail::number_in_range(v, lo, hi, key, unit, at, why);
  };
  if (const auto i = kv.find("sequence"); i != kv.end()) {
    if (i->second.empty()) fail(at + ": sequence= names no sequence");
    ml.sequence = i->second;
  }
  using scene::detail::kMaxSpeed_m_s, scene::detail::kMaxYawRate_rad_s, scene::detail::kNotOdometry;
  using scene::detail::kMaxCameraLever_m, scene::detail::kMaxCameraYaw_rad;
  // Seconds from any origin (a Unix time too): within 9·10⁹ s its whole ns fit in 64 bits.
  const auto t = number("time_s", -9e9, 9e9, "s", " (seconds; 9e9 s keeps whole ns within 64 bits)");
  const auto v = number("speed_m_s", -kMaxSpeed_m_s, kMaxSpeed_m_s, "m/s", kNotOdometry);
  const auto w = number("yaw_rate_rad_s", -kMaxYawRate_rad_s, kMaxYawRate_rad_s, "rad/s", kNotOdometry);
  const auto cf = number("camera_forward_m", -kMaxCameraLever_m, kMaxCameraLever_m, "m", " (the camera's place on its vehicle)");
  const auto cl = number("camera_left_m", -kMaxCameraLever_m, kMaxCameraLever_m, "m", " (the camera's place on its vehicle)");
  const auto cy = number("camera_yaw_rad", -kMaxCameraYaw_rad, kMaxCameraYaw_rad, "rad", " (a forward camera's heading on its vehicle)");
  if (t || v || w) {
    if (!(t && v && w))
      fail(at + ": " + (t ? "" : "time_s ") + (v ? "" : "speed_m_s ") + (w ? "" : "yaw_rate_rad_s ") +
           "missing: a frame's odometry is time_s, speed_m_s and yaw_rate_rad_s together");
    scene::OdometrySample o;
    o.time_ns = std::llround(*t * 1e9);
    o.speed_m_s = *v;
    o.yaw_rate_rad_s = *w;
    o.camera_forward_m = cf.value_or(0);
    o.camera_left_m = cl.value_or(0);
    o.camera_yaw_rad = cy.value_or(0);
    ml.odometry = o;
  } else if (cf || cl || cy) {
    fail(at + ": camera_forward_m, camera_left_m and camera_yaw_rad place the camera for the odometry: give time_s, "
              "speed_m_s and yaw_rate_rad_s too");
  }
  return ml;
}
}  // namespace

std::vector<Item> read_manifest(const std::string& manifest) {
  std::error_code dir_ec;
  if (fs::is_directory(manifest, dir_ec)) fail_at(manifest, "is a folder, not a manifest file");
  if (!fs::exists(manifest, dir_ec)) fail_missing(manifest, "manifest file not found");
  std::ifstream f(manifest);
  if (!f) fail_at(manifest, "cannot read the manifest");
  const fs::path base = fs::path(manifest).parent_path();
  std::vector<Item> items;
  std::map<std::string, long> order;
  std::map<std::string, std::pair<int, std::string>> keys;  // output key -> (line, image)
  std::string line;
  int lineno = 0;
  auto resolve = [&](const std::string& s) { return fs::path(s).is_absolute() ? fs::path(s) : base / s; };
  // The output path mirrors the input path: relative to the manifest's folder when inside it,
  // else the path with its root and any leading "../" removed.
  auto mirror = [&](const fs::path& p) {
    fs::path r = lexical_relative(p, base.empty() ? fs::path(".") : base);
    fs::path clean;
    for (const auto& part : r.lexically_normal())
      if (part != ".." && part != "." && !part.empty() && part != r.root_path()) clean /= part;
    return clean.generic_string();
  };
  while (std::getline(f, line)) {
    ++lineno;
    // A byte-order mark (editors on Windows save one) is not part of the first path.
    if (lineno == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);
    // An image file given as the manifest (its bytes are no text): said so, not "found 1 fields".
    if (lineno == 1 && (line.find('\0') != std::string::npos || line.rfind("\x89PNG", 0) == 0 ||
                        line.rfind("\xFF\xD8\xFF", 0) == 0))
      fail_at(manifest, "is an image or other binary file, not a manifest (a text file of 'image labels "
                        "[instances]' lines)");
    const std::vector<std::string> parts = manifest_fields(line, [&](const std::string& why) {
      fail(where(manifest, lineno) + ": " + why);
    });
    if (parts.empty()) continue;
    const std::string at = where(manifest, lineno);
    const ManifestLine ml = split_manifest_line(parts, at, [&](const std::string& f) {
      std::error_code ec;
      return fs::exists(resolve(f), ec);
    });
    const std::vector<std::string>& paths = ml.paths;
    if (paths.size() < 2 || paths.size() > 3)
      fail(at + ": expected 'image labels [instances]', found " + std::to_string(paths.size()) +
           " fields" +
           (line.find_first_of(" #") != std::string::npos && line.find_first_of(",\t\"") == std::string::npos
                ? " (a path with spaces or '#': put it in double quotes, or separate the fields with commas or tabs)"
                : ""));
    Item it;
    it.image = resolve(paths[0]).string();
    it.labels = resolve(paths[1]).string();
    if (paths.size() == 3) it.instances = resolve(paths[2]).string();
    std::error_code ec;
    if (!fs::exists(it.image, ec)) throw MissingFileError(where(manifest, lineno) + ": image " + it.image + " not found");
    if (!fs::exists(it.labels, ec)) throw MissingFileError(where(manifest, lineno) + ": labels " + it.labels + " not found");
    if (!it.instances.empty() && !fs::exists(it.instances, ec))
      throw MissingFileError(where(manifest, lineno) + ": instances " + it.instances + " not found");
    it.key = fs::path(mirror(it.image)).replace_extension().generic_string();
    it.labels_rel = "labels/" + mirror(it.labels);
    if (!it.instances.empty()) it.instances_rel = "labels/" + mirror(it.instances);
    if (const auto [k, fresh] = keys.emplace(it.key, std::make_pair(lineno, it.image)); !fresh)
      fail(where(manifest, lineno) + (k->second.second == it.image
                                          ? ": image listed twice (also on line " + std::to_string(k->second.first) + "): " + it.image
                                          : ": " + it.image + " and " + k->second.second + " (line " +
                                                std::to_string(k->second.first) + ") would both write " + it.key + ".*"));
    it.group = ml.sequence.empty() ? it.key : std::string(kSequenceGroup) + ml.sequence;
    it.origin = at;
    if (ml.odometry) {
      it.odometry_given = ml.odometry;
      it.odometry = it.odometry_time = at;  // (named in messages)
    }
    order[it.key] = lineno;
    items.push_back(std::move(it));
  }
  if (items.empty()) fail_at(manifest, "the manifest lists no items");
  // A sequence's frames, in line order: all with odometry or none (a frame without it would have
  // no pose), their times increasing (the pose integrates forward in time).
  std::map<std::string, const Item*> last_of;
  for (const Item& it : items) {
    if (it.group == it.key) continue;  // a line of its own
    const auto [prev, first] = last_of.emplace(it.group, &it);
    if (first) continue;
    const Item& p = *prev->second;
    const std::string seq = it.group.substr(kSequenceGroup.size());
    if (p.odometry_given.has_value() != it.odometry_given.has_value())
      fail(it.origin + ": sequence " + seq + (it.odometry_given ? " has odometry on this line but not on " : " has no odometry on this line but has on ") +
           p.origin + " (time_s, speed_m_s, yaw_rate_rad_s on every line of a sequence, or on none)");
    if (it.odometry_given && it.odometry_given->time_ns <= p.odometry_given->time_ns)
      fail(it.origin + ": sequence " + seq + ": time_s is not after the previous line's (" + p.origin +
           "): a sequence's lines are its frames in the order they were recorded");
    prev->second = &it;
  }
  number_frames(items, order);
  return items;
}

std::vector<Item> shard(const std::vector<Item>& items, int index, int count) {
  std::vector<std::string> groups;
  for (const auto& it : items) groups.push_back(it.group);
  std::sort(groups.begin(), groups.end());
  groups.erase(std::unique(groups.begin(), groups.end()), groups.end());
  std::map<std::string, int> gi;
  for (size_t i = 0; i < groups.size(); ++i) gi[groups[i]] = static_cast<int>(i);
  std::vector<Item> out;
  for (const auto& it : items)
    if (gi[it.group] % count == index) out.push_back(it);
  return out;
}

std::string upgrade_params(const std::string& params_json) {
  nlohmann::json j = nlohmann::json::parse(params_json, nullptr, false);
  if (!j.is_object()) return params_json;
  if (j.contains("f_number") && j["f_number"] == -1.0) j["f_number"] = nullptr;
  if (j.contains("temperature_c") && j["temperature_c"] == -999.0) j["temperature_c"] = nullptr;
  if (j.contains("source") && j["source"].is_string()) {
    std::string src = j["source"].get<std::string>();  // "<kind> <absolute path>"
    while (src.size() > 1 && src.back() == '/' && src[src.size() - 2] != ' ') src.pop_back();
    j["source"] = src;
  }
  if (j.contains("format") && j["format"] == "png")
    j["layers"] = layers_text(kPngRouteLayers);
  return j.dump();
}

std::pair<int, int> parse_shard(const std::string& text) {
  int i = -1, n = -1;
  char slash = 0;
  std::istringstream ss(text);
  if (!(ss >> i >> slash >> n) || slash != '/' || n < 1 || i < 0 || i >= n || !ss.eof())
    fail_parameter("shard", "", " '" + text + "' must be I/N with 0 <= I < N (e.g. 3/16)");
  return {i, n};
}

}  // namespace photosite::batch
