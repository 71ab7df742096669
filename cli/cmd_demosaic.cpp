// `photosite demosaic`: one demosaicing method on a single-channel CFA mosaic from a file.
//   photosite demosaic --in MOSAIC --cfa RGGB --method NAME --out RGB.exr
//   photosite demosaic --list
// Integer mosaics (8/16-bit PNG, TIFF) are read as code / max code and give a result on that
// scale: a PNG out keeps the input's bit depth; float mosaics (EXR, float TIFF) keep their units
// (a PNG out from them is clipped to [0, 1], 16-bit). A UINT EXR channel holds counts and is read
// as they are (DN, e-). A photosite mosaic (`expose --layers raw`, `flat`) carries its CFA, bit
// depth and black level in its header: the CFA is taken from it (a different --cfa is refused),
// the black level is subtracted from a DN channel (the result is in DN above black level, as
// expose's R,G,B), and a PNG out is DN / (2^bit_depth - 1).
// --white-level V (RCCB and RCCC only): samples stored at V or above are clipped, and the pixels
// whose 3x3 window holds one come out neutral at (V - black level) / 3 on the output's scale
// (neutralize_clipped_highlights, sensor/demosaic.h, has the rule). Without the flag, a photosite
// raw mosaic's header says where it clipped (photosite/clipped_at_dn, clip_neutral_dn: what
// expose's own R,G,B used) and that is applied; other files do not say, and nothing is done.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <optional>
#include <variant>
#include <vector>

#include <fmt/format.h>

#include "photosite/error.h"
#include "photosite/io.h"
#include "backend.h"
#include "photosite/sensor/demosaic.h"
#include "registry.h"
#include "sensor_options.h"

namespace photosite::cli {
namespace {
struct DemosaicCmd {
  std::string in, out, cfa = "RGGB", method = "bilinear", backend = "auto";
  bool list = false, overwrite = false;
  std::optional<double> white_level;        // --white-level, in the input's stored values
  const CLI::Option* cfa_option = nullptr;  // count() > 0: --cfa given
};

// The mosaic of --in, how its samples are scaled, and the header attributes that say what was used.
struct Mosaic {
  ImageF image;
  CfaPattern cfa = CfaPattern::RGGB;
  int png_bits = 16;         // a PNG out: this many bits
  double png_scale = 1;      // a PNG out: sample · png_scale in [0, 1]
  bool png_possible = true;
  // A stored value v is the sample (v - stored_offset) * stored_scale; integer_codes: v is an
  // integer code (clipped: code >= V, i.e. above V - 1/2).
  double stored_offset = 0, stored_scale = 1;
  bool integer_codes = false;
  // A photosite raw's own clip level (header photosite/clipped_at_dn, clip_neutral_dn: raw DN, and
  // DN above black), the default where --white-level is not given.
  std::optional<std::pair<double, double>> header_clip;
  std::map<std::string, ExrAttribute> attributes;
};

std::string cfa_flag_source(const DemosaicCmd& c) { return c.cfa_option->count() ? "--cfa" : "--cfa default"; }

double header_number(const ExrContents& e, const std::string& in, const std::string& key) {
  const std::string& text = e.attributes.at(key);
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != 0 || !std::isfinite(v)) fail_at(in, fmt::format("{} '{}' is not a number", key, text));
  return v;
}

// A one-channel EXR as stored: UINT channels are counts (OpenEXR widens them to float exactly
// below 2^24, which every bit depth of a preset, <= 24, stays under), float channels keep their units.
Mosaic read_exr_mosaic(const DemosaicCmd& c) {
  const ExrContents e = read_exr(c.in);
  check_frame_size(c.in, e.width, e.height);  // a mosaic: at least one CFA tile
  if (e.channels.size() != 1)
    fail_at(c.in, fmt::format("a CFA mosaic has one channel; this image has {}", e.channels.size()));
  const auto& [name, plane] = *e.channels.begin();
  const bool counts = e.pixel_types.at(name) == ExrPixel::Uint;
  Mosaic m;
  m.image = plane;
  const auto has = [&](const char* k) { return e.attributes.count(k) > 0; };
  m.cfa = parse_cfa(c.cfa);
  std::string cfa_source = cfa_flag_source(c);
  if (has("photosite/cfa")) {
    const CfaPattern file_cfa = parse_cfa(e.attributes.at("photosite/cfa"));
    if (c.cfa_option->count() && file_cfa != m.cfa)
      fail_at(c.in, fmt::format("--cfa {} contradicts the mosaic's header, photosite/cfa {} (leave --cfa out to use the header's)",
                                to_string(m.cfa), to_string(file_cfa)));
    m.cfa = file_cfa;
    cfa_source = c.cfa_option->count() ? "input header and --cfa" : "input header";
  }
  m.attributes["photosite/cfa_source"] = cfa_source;
  m.attributes["photosite/source_channel"] = name;
  std::optional<int> bit_depth;
  if (has("photosite/bit_depth")) {
    const double b = header_number(e, c.in, "photosite/bit_depth");
    if (b != std::floor(b) || b < 1 || b > 32) fail_at(c.in, fmt::format("photosite/bit_depth {} is not a bit depth", b));
    bit_depth = static_cast<int>(b);
    m.attributes["photosite/bit_depth"] = *bit_depth;
  }
  const bool dn = plane.unit() == unit::dn;
  if (dn && has("photosite/black_level_dn")) {
    const double black = header_number(e, c.in, "photosite/black_level_dn");
    const float b = static_cast<float>(black);
    for (float& v : m.image.vec()) v -= b;
    m.stored_offset = b;
    m.image.set_unit("DN above black level");
    m.attributes["photosite/black_level_dn"] = black;  // subtracted: R,G,B are DN above it
    if (has("photosite/clipped_at_dn") && has("photosite/clip_neutral_dn")) {
      const double at = header_number(e, c.in, "photosite/clipped_at_dn");
      const double neutral = header_number(e, c.in, "photosite/clip_neutral_dn");
      if (!(at > black) || !(neutral > 0))
        fail_at(c.in, fmt::format("photosite/clipped_at_dn {} and clip_neutral_dn {} do not describe a clip above "
                                  "the black level {}", at, neutral, black));
      m.header_clip = {{at, neutral}};
    }
  }
  if (counts && !(dn && bit_depth)) {
    m.png_possible = false;  // counts of no known full scale
  } else if (counts) {
    m.png_scale = 1.0 / (std::ldexp(1.0, *bit_depth) - 1);
  }
  m.attributes["photosite/scale"] = std::string(counts ? "counts as stored (UINT channel)" : "input units");
  return m;
}

Mosaic read_mosaic(const DemosaicCmd& c) {
  // By the file's signature (probe_image reads the header alone; it refuses a missing file, a
  // folder or a pipe first).
  if (probe_image(c.in).format == "openexr") return read_exr_mosaic(c);
  ImageFileInfo info;
  Mosaic m;
  m.image = read_image(c.in, &info);
  check_frame_size(c.in, m.image.width(), m.image.height());  // a mosaic: at least one CFA tile
  if (m.image.channels() != 1)
    fail_at(c.in, fmt::format("a CFA mosaic has one channel; this image has {}", m.image.channels()));
  if (m.image.unit().empty()) m.image.set_unit(info.is_float ? "" : unit::dimensionless);
  m.cfa = parse_cfa(c.cfa);
  m.attributes["photosite/cfa_source"] = cfa_flag_source(c);
  m.png_bits = !info.is_float && info.bits_per_sample == 8 ? 8 : 16;
  if (!info.is_float) {
    m.integer_codes = true;
    m.stored_scale = 1.0 / (std::ldexp(1.0, info.bits_per_sample) - 1);
  }
  m.attributes["photosite/scale"] = std::string(info.is_float ? "input units" : "code / max code of the input");
  return m;
}

// A NaN or an infinity in a float mosaic (EXR, float TIFF) is refused, naming the file, the
// channel and the first such sample in reading order: every method interpolates each sample into
// its neighbours' missing colours (bilinear's 3x3, malvar's 5x5, LMMSE's and MLRI's filters
// wider still), so one bad sample would spread over a patch of the output, and a PNG out would
// write it as code 0 (NaN) or the top code (+inf) as if it were light. Negative samples are kept
// as they are: a mosaic whose black level is subtracted (photosite's own raw read here, or another
// tool's float raw) holds them wherever read noise takes a dark pixel below black, and dropping
// them would bias the dark level up; a PNG out clamps them to 0 (float_to_code8/16).
void check_finite_samples(const std::string& in, const Mosaic& m) {
  const auto& v = m.image.vec();
  const auto bad = std::find_if(v.begin(), v.end(), [](float s) { return !std::isfinite(s); });
  if (bad == v.end()) return;
  const int64_t i = bad - v.begin();
  const auto channel = m.attributes.find("photosite/source_channel");
  const std::string named =
      channel == m.attributes.end() ? "" : " of channel " + std::get<std::string>(channel->second);
  fail_at(in, fmt::format("the mosaic's sample at pixel ({}, {}){} is {}: a CFA sample must be a finite number "
                          "(NaN and Inf spread through the demosaic's interpolation); the file is damaged",
                          i % m.image.width(), i / m.image.width(), named,
                          std::isnan(*bad) ? std::string("nan") : fmt::format("{}", *bad)));  // a NaN's sign says nothing
}

void run(const DemosaicCmd& c) {
  if (c.list) {
    for (auto m : all_demosaic_methods()) std::printf("%-16s %s\n", to_string(m), demosaic_method_description(m));
    return;
  }
  if (c.in.empty()) fail("demosaic: --in MOSAIC is required (or --list)");
  if (c.out.empty()) fail("demosaic: --out RGB.exr is required");
  parse_cfa(c.cfa);
  const DemosaicMethod method = parse_demosaic_method(c.method);
  SensorRunner runner(resolve_backend(c.backend));
  const std::string ext = lower_extension(c.out);
  if (ext != ".exr" && ext != ".png")
    fail_at(c.out, "output must be .exr or .png (got '" + ext + "')");
  check_run_outputs({{"--out", {c.out}, ext}}, {{"--in", c.in}});
  check_output_path(c.out, c.overwrite);
  Mosaic m = read_mosaic(c);
  check_finite_samples(c.in, m);
  if (ext == ".png" && !m.png_possible)
    fail_at(c.out, c.in + " holds counts of no known full scale (a UINT channel in " + m.image.unit() +
                       " without photosite/bit_depth): write .exr");
  if (c.white_level) {
    const double v = *c.white_level;
    if (!is_clear_pattern(m.cfa))
      fail(fmt::format("--white-level: clip handling is for the clear patterns RCCB and RCCC; {} is {}", c.in,
                       to_string(m.cfa)));
    if (!std::isfinite(v))
      fail(fmt::format("--white-level {} is not a finite number (a stored value from which a sample counts as clipped)", v));
    if (!(v > m.stored_offset))
      fail(fmt::format("--white-level {} is not above {}'s black level ({})", v, c.in, m.stored_offset));
  }
  ImageF rgb = runner.demosaic(m.image, m.cfa, method);
  rgb.set_unit(m.image.unit());
  if (c.white_level) {
    neutralize_at_white_level(rgb, m.image, m.cfa, *c.white_level, m.stored_offset, m.stored_scale, m.integer_codes);
    m.attributes["photosite/white_level"] = *c.white_level;
    m.attributes["photosite/white_level_source"] = std::string("--white-level");
  } else if (m.header_clip && is_clear_pattern(m.cfa)) {
    // As expose made its own R,G,B (neutralize_clipped_highlights, sensor/pipeline.cpp), on the
    // mosaic with the black level taken off.
    const auto [at, neutral] = *m.header_clip;
    neutralize_clipped_highlights(rgb, m.image, m.cfa, static_cast<float>(at - m.stored_offset), static_cast<float>(neutral));
    m.attributes["photosite/white_level"] = at;
    m.attributes["photosite/white_level_source"] = std::string("input header (photosite/clipped_at_dn)");
  }
  if (ext == ".png") {
    if (m.png_scale != 1)
      for (float& v : rgb.vec()) v = static_cast<float>(v * m.png_scale);
    write_png(c.out, rgb, m.png_bits);
  } else {
    m.attributes["photosite/demosaic"] = std::string(to_string(method));
    m.attributes["photosite/cfa"] = std::string(to_string(m.cfa));
    m.attributes["photosite/source"] = c.in;
    write_exr(c.out, {{{"R", "G", "B"}, &rgb, rgb.unit()}}, m.attributes, ExrWriteOptions{.reproducible = true});
  }
  std::printf("%s\n", c.out.c_str());
}
}  // namespace

static Registrar reg("c-demosaic", [](CLI::App& app) {
  auto cmd = std::make_shared<DemosaicCmd>();
  auto* sub = app.add_subcommand("demosaic", "demosaic a single-channel CFA mosaic (PNG, TIFF, EXR) to RGB");
  auto* in = sub->add_option("--in", cmd->in, "single-channel mosaic: PNG 8/16-bit, TIFF or EXR");
  auto* out = sub->add_option("--out", cmd->out, "RGB output, .exr (float) or .png");
  cmd->cfa_option = sub->add_option("--cfa", cmd->cfa, "CFA pattern: RGGB, BGGR, GRBG, GBRG, RCCB, RCCC, MONO (default: the input's photosite/cfa, else RGGB)");
  sub->add_option("--method", cmd->method, "demosaic method (see --list)")->capture_default_str();
  // --list demosaics nothing: a mosaic or an output given with it would be silently left alone.
  sub->add_flag("--list", cmd->list, "list the demosaic methods and exit")->excludes(in)->excludes(out);
  sub->add_option("--white-level", cmd->white_level,
                  "RCCB/RCCC: the stored value (integer code; DN with black level for a photosite raw) at which the "
                  "input clipped: pixels whose 3x3 window holds a sample at or above it come out neutral at "
                  "(V - black level) / 3 (docs/demosaic.md; default: a photosite raw's own clip level from its "
                  "header, else no clip handling)");
  add_overwrite_flag(sub, cmd->overwrite);
  add_backend_option(sub, cmd->backend);
  sub->callback([cmd] { run(*cmd); });
});

}  // namespace photosite::cli
