// Cityscapes label decoding (ids, trainIds, palette) and instance ids.
#include "photosite/scene/labels.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <vector>

#include <fmt/format.h>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "core/isa_detail.h"
#include "photosite/error.h"
#include "photosite/io.h"

namespace photosite::scene {
namespace {
struct LabelInfo {
  const char* name;
  int train_id;
  uint8_t r, g, b;
};
// cityscapesScripts helpers/labels.py (name, trainId, colour) for labelIds 0..33.
constexpr LabelInfo kLabels[kLabelCount] = {
    {"unlabeled", 255, 0, 0, 0},          {"ego vehicle", 255, 0, 0, 0},
    {"rectification border", 255, 0, 0, 0}, {"out of roi", 255, 0, 0, 0},
    {"static", 255, 0, 0, 0},             {"dynamic", 255, 111, 74, 0},
    {"ground", 255, 81, 0, 81},           {"road", 0, 128, 64, 128},
    {"sidewalk", 1, 244, 35, 232},        {"parking", 255, 250, 170, 160},
    {"rail track", 255, 230, 150, 140},   {"building", 2, 70, 70, 70},
    {"wall", 3, 102, 102, 156},           {"fence", 4, 190, 153, 153},
    {"guard rail", 255, 180, 165, 180},   {"bridge", 255, 150, 100, 100},
    {"tunnel", 255, 150, 120, 90},        {"pole", 5, 153, 153, 153},
    {"polegroup", 255, 153, 153, 153},    {"traffic light", 6, 250, 170, 30},
    {"traffic sign", 7, 220, 220, 0},     {"vegetation", 8, 107, 142, 35},
    {"terrain", 9, 152, 251, 152},        {"sky", 10, 70, 130, 180},
    {"person", 11, 220, 20, 60},          {"rider", 12, 255, 0, 0},
    {"car", 13, 0, 0, 142},               {"truck", 14, 0, 0, 70},
    {"bus", 15, 0, 60, 100},              {"caravan", 255, 0, 0, 90},
    {"trailer", 255, 0, 0, 110},          {"train", 16, 0, 80, 100},
    {"motorcycle", 17, 0, 0, 230},        {"bicycle", 18, 119, 11, 32},
};

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Palette colour → labelId. Shared colours resolve to the first id (black → unlabeled,
// pole/polegroup → pole); the license-plate colour equals car's.
int palette_lookup(uint16_t r, uint16_t g, uint16_t b) {
  for (int id = 0; id < kLabelCount; ++id)
    if (kLabels[id].r == r && kLabels[id].g == g && kLabels[id].b == b) return id;
  return -1;
}
}  // namespace

LabelFormat parse_label_format(const std::string& text) {
  const std::string t = lower(text);
  if (t == "auto") return LabelFormat::Auto;
  if (t == "labelids" || t == "label-ids" || t == "ids") return LabelFormat::LabelIds;
  if (t == "trainids" || t == "train-ids") return LabelFormat::TrainIds;
  if (t == "color" || t == "colour" || t == "palette") return LabelFormat::Palette;
  fail_parameter("label_format", "", ": unknown format '" + text + "' (auto, labelIds, trainIds, color)");
}

const char* label_format_name(LabelFormat f) {
  switch (f) {
    case LabelFormat::Auto: return "auto";
    case LabelFormat::LabelIds: return "labelIds";
    case LabelFormat::TrainIds: return "trainIds";
    case LabelFormat::Palette: return "color";
  }
  return "?";
}

const char* label_name(int id) { return id >= 0 && id < kLabelCount ? kLabels[id].name : "?"; }
std::array<uint8_t, 3> label_color(int id) {
  if (id < 0 || id >= kLabelCount) return {0, 0, 0};
  return {kLabels[id].r, kLabels[id].g, kLabels[id].b};
}
int train_id_to_label_id(int train_id) {
  if (train_id == 255) return static_cast<int>(Label::Unlabeled);
  for (int id = 0; id < kLabelCount; ++id)
    if (kLabels[id].train_id == train_id) return id;
  return -1;
}
bool is_vehicle(int id) { return id >= 26 && id <= 33; }
bool is_ground(int id) {
  return id == 6 || id == 7 || id == 8 || id == 9 || id == 10 || id == 22;
}
const std::array<bool, kLabelCount>& ground_classes() {
  static const std::array<bool, kLabelCount> table = [] {
    std::array<bool, kLabelCount> t{};
    for (int id = 0; id < kLabelCount; ++id) t[id] = is_ground(id);
    return t;
  }();
  return table;
}

LabelMap decode_labels(const ImageU16& raw, LabelFormat format, const std::string& file) {
  LabelMap m;
  const int w = raw.width(), h = raw.height();
  m.ids = ImageU16(w, h, 1, uninitialized, unit::label_id);  // every pixel is written below, or it throws
  auto where_px = [&](size_t i) {
    return " at pixel (" + std::to_string(i % w) + ", " + std::to_string(i / w) + ")";
  };
  if (raw.channels() >= 3) {
    if (format != LabelFormat::Auto && format != LabelFormat::Palette)
      fail_parameter("label_format", file + ": labels have " + std::to_string(raw.channels()) + " channels but ",
                     std::string(" is ") + label_format_name(format));
    m.format = LabelFormat::Palette;
    const int c = raw.channels();
    for (size_t i = 0; i < raw.pixel_count(); ++i) {
      const int id = palette_lookup(raw[i * c], raw[i * c + 1], raw[i * c + 2]);
      if (id < 0)
        fail_at(file, "colour (" + std::to_string(raw[i * c]) + ", " + std::to_string(raw[i * c + 1]) +
                          ", " + std::to_string(raw[i * c + 2]) + ")" + where_px(i) +
                          " is not in the Cityscapes palette");
      m.ids[i] = static_cast<uint16_t>(id);
    }
    return m;
  }
  if (raw.channels() != 1) fail_at(file, "labels must have 1 (ids) or 3 (palette) channels");
  if (format == LabelFormat::Palette) fail_parameter("label_format", file + ": ", " color needs an RGB label image");
  uint16_t maxv = 0;
  bool has255 = false, has_mid = false;  // mid: 19..33, only labelIds have these
  for (size_t i = 0; i < raw.pixel_count(); ++i) {
    const uint16_t v = raw[i];
    if (v == 255) has255 = true;
    else {
      maxv = std::max(maxv, v);
      if (v >= 19 && v <= 33) has_mid = true;
    }
  }
  if (format == LabelFormat::Auto) {
    if (has255 && !has_mid) format = LabelFormat::TrainIds;
    else format = LabelFormat::LabelIds;  // values 0..18 only are ambiguous: labelIds (the common file)
    if (!has255 && !has_mid)
      m.note = file + ": only values 0.." + std::to_string(maxv) +
               ", which labelIds and trainIds both use: read as labelIds; pass --label-format trainIds if they are "
               "trainIds";
  }
  m.format = format;
  if (format == LabelFormat::LabelIds && !has255 && maxv < kLabelCount) {
    // Every value is a labelId already (the first pass saw them all): the ids are the codes.
    std::copy_n(raw.data(), raw.size(), m.ids.data());
    return m;
  }
  for (size_t i = 0; i < raw.pixel_count(); ++i) {
    const int v = raw[i];
    int id = -1;
    if (format == LabelFormat::LabelIds) id = v < kLabelCount ? v : -1;
    else id = (v <= 18 || v == 255) ? train_id_to_label_id(v) : -1;
    if (id < 0)
      fail_at(file, "value " + std::to_string(v) + where_px(i) + " is not a Cityscapes " +
                        label_format_name(format) + " value" +
                        (format == LabelFormat::LabelIds ? " (0..33)" : " (0..18, 255)"));
    m.ids[i] = static_cast<uint16_t>(id);
  }
  return m;
}

namespace {
#if defined(__x86_64__)
// dst[x] = src[2x + 1] for x in [0, n), sixteen at a time from x = 0: the odd 16-bit values of
// sixteen 32-bit pairs shifted down and packed (unsigned saturation leaves values below 2^16
// unchanged; the 128-bit lanes' halves put back in order); returns where it stopped.
__attribute__((target("avx2"))) int odd_values_avx2(const uint16_t* src, int n, uint16_t* dst) {
  int x = 0;
  for (; x + 16 <= n; x += 16) {
    const __m256i a = _mm256_srli_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(src + 2 * x)), 16);
    const __m256i b = _mm256_srli_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(src + 2 * x + 16)), 16);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(dst + x), _mm256_permute4x64_epi64(_mm256_packus_epi32(a, b), 0xd8));
  }
  return x;
}
const bool kAvx2 = photosite::detail::have_avx2();
#endif
}  // namespace

ImageU16 resize_nearest(const ImageU16& in, int width, int height) {
  ImageU16 out(width, height, in.channels(), uninitialized, in.unit());
  const int c = in.channels();
  // The source column of every output column once (the same expression per pixel as per column).
  std::vector<int> sxs(width);
  for (int x = 0; x < width; ++x) sxs[x] = std::min(in.width() - 1, static_cast<int>((x + 0.5) * in.width() / width));
  // Where every column reads source column 2x + 1 (the exact halving: the working labels of a
  // 2048-wide frame), a one-channel row is the source row's odd values, taken sixteen at a time.
  bool odd = c == 1;
  for (int x = 0; x < width && odd; ++x) odd = sxs[x] == 2 * x + 1;
#pragma omp parallel for schedule(static)
  for (int y = 0; y < height; ++y) {
    const int sy = std::min(in.height() - 1, static_cast<int>((y + 0.5) * in.height() / height));
    const uint16_t* src = in.row(sy);
    uint16_t* dst = out.row(y);
    int x0 = 0;
#if defined(__x86_64__)
    if (odd && kAvx2) x0 = odd_values_avx2(src, width, dst);
#endif
    if (c == 1)
      for (int x = x0; x < width; ++x) dst[x] = src[sxs[x]];
    else
      for (int x = 0; x < width; ++x)
        for (int k = 0; k < c; ++k) dst[x * c + k] = src[sxs[x] * c + k];
  }
  return out;
}

namespace {
// Ids are names, not intensities: a label file must give back exactly the codes it was saved
// with. JPEG's lossy coding (the 8x8 DCT's quantised coefficients, and chroma subsampling in a
// colour file) blends the codes of neighbouring classes along every border, and a blend is a
// value of another class (between road 7 and building 11 lie sidewalk 8 and parking 9) or of
// none: a JPEG label file is refused by its signature, whatever its values, before they are read
// as classes. (Cityscapes labelIds saved as a quality-95 JPEG hold the value 35, which no class
// has, at a border: docs/cli.md "Edge cases (thirty-fifth session)".)
void refuse_lossy_ids(const ImageFileInfo& info, const char* what) {
  if (info.format == "jpeg")
    fail_at(info.path, fmt::format("{} in a JPEG file: JPEG's lossy compression changes them along every class "
                                   "border, and {} must be exact; give them as a PNG (lossless)",
                                   what, what));
}
}  // namespace

LabelMap read_labels(const std::string& labels_path, const std::string& instances_path, int width,
                     int height, LabelFormat format, ResizeLabels resize) {
  if (!std::filesystem::exists(labels_path)) fail_missing(labels_path, "labels file not found");
  ImageFileInfo info;
  ImageU16 raw = read_image_u16(labels_path, &info);
  refuse_lossy_ids(info, "label ids");
  ImageU16 inst;
  if (!instances_path.empty()) {
    if (!std::filesystem::exists(instances_path)) fail_missing(instances_path, "instances file not found");
    inst = read_image_u16(instances_path, &info);
    refuse_lossy_ids(info, "instance ids");
  }
  return labels_from_codes(std::move(raw), instances_path.empty() ? nullptr : &inst, width, height, format,
                           resize, labels_path, instances_path);
}

LabelMap labels_from_codes(ImageU16 raw, const ImageU16* instances, int width, int height, LabelFormat format,
                           ResizeLabels resize, const std::string& labels_path, const std::string& instances_path) {
  if (!raw.same_shape(width, height)) {
    if (resize == ResizeLabels::None)
      // A ParameterError: each face names its own spelling (--resize-labels, resize_labels).
      fail_parameter("resize_labels",
                     labels_path + ": labels are " + std::to_string(raw.width()) + "x" + std::to_string(raw.height()) +
                         " but the image is " + std::to_string(width) + "x" + std::to_string(height) + " (pass ",
                     "=nearest to resample them)");
    raw = resize_nearest(raw, width, height);
  }
  LabelMap m = decode_labels(raw, format, labels_path);
  if (instances) {
    if (instances->channels() != 1) fail_at(instances_path, "instance ids must be a one-channel image");
    ImageU16 resized;  // only when the instance ids must be resampled; otherwise read in place
    if (!instances->same_shape(width, height)) {
      if (resize == ResizeLabels::None)
        fail_parameter("resize_labels",
                       instances_path + ": instance ids are " + std::to_string(instances->width()) + "x" +
                           std::to_string(instances->height()) + " but the image is " + std::to_string(width) + "x" +
                           std::to_string(height) + " (pass ",
                       "=nearest to resample them)");
      resized = resize_nearest(*instances, width, height);
    }
    const ImageU16& inst = resized.empty() ? *instances : resized;
    m.instances = ImageU16(width, height, 1, 0, "instance id");
    // Cityscapes codes are class*1000 + n; KITTI's instance PNGs use class*256 + n. Decide by
    // which one agrees with the labels on every pixel carrying an instance.
    size_t city_ok = 0, kitti_ok = 0, with_inst = 0;
    for (size_t i = 0; i < inst.pixel_count(); ++i) {
      const int v = inst[i];
      if (v < kLabelCount) continue;
      ++with_inst;
      city_ok += v >= 1000 && v / 1000 == m.ids[i];
      kitti_ok += (v >> 8) == m.ids[i];
    }
    const bool kitti = with_inst > 0 && kitti_ok == with_inst && city_ok < with_inst;
    // A frame's own instance ids agree with its labels on every instance pixel (each code's class
    // is the label there, also after both are resampled alike). When most disagree, the file is
    // another frame's (a mixed-up manifest line): its vehicles would put lamps on road, façades
    // and cyclists. Refused rather than drawn; a minority of disagreeing pixels (another tool's
    // instance boundaries) is let through.
    if (!kitti && with_inst > 0 && 2 * city_ok < with_inst) {
      size_t first = 0;
      for (size_t i = 0; i < inst.pixel_count(); ++i)
        if (inst[i] >= kLabelCount && !(inst[i] >= 1000 && inst[i] / 1000 == m.ids[i])) {
          first = i;
          break;
        }
      fail_at(instances_path,
              fmt::format("the instance ids disagree with the labels on {:.1f}% of their pixels (first at ({}, {}): "
                          "instance {} of class {}, label {}): are they another frame's?",
                          100.0 * static_cast<double>(with_inst - city_ok) / static_cast<double>(with_inst),
                          first % width, first / width, inst[first], inst[first] / 1000, m.ids[first]));
    }
    for (size_t i = 0; i < inst.pixel_count(); ++i) {
      const int v = inst[i];
      if (kitti) {
        if (v >= 256) m.instances[i] = static_cast<uint16_t>((v >> 8) * 1000 + (v & 255));
        continue;
      }
      if (v >= 1000) {
        if (v / 1000 >= kLabelCount)
          fail_at(instances_path, "instance id " + std::to_string(v) + " has class " +
                                      std::to_string(v / 1000) + " beyond labelId 33");
        m.instances[i] = static_cast<uint16_t>(v);
      } else if (v >= kLabelCount) {
        fail_at(instances_path, "instance id " + std::to_string(v) + " at pixel (" +
                                    std::to_string(i % width) + ", " + std::to_string(i / width) +
                                    ") is neither a labelId (0..33), class*1000+n (Cityscapes) nor "
                                    "class*256+n (KITTI) matching the labels");
      }
    }
  }
  return m;
}

}  // namespace photosite::scene
