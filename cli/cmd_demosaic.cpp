// `photosite demosaic`: one demosaicing method on a single-channel CFA mosaic from a file.
//   photosite demosaic --in MOSAIC --cfa RGGB --method NAME --out RGB.exr
//   photosite demosaic --list
// Integer mosaics (8/16-bit PNG, TIFF) are read as code / max code and give a result on that
// scale: a PNG out keeps the input's bit depth; float mosaics (EXR, float TIFF) keep their units
// (a PNG out from them is clipped to [0, 1], 16-bit).
#include <cstdio>
#include <filesystem>

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
};

void run(const DemosaicCmd& c) {
  if (c.list) {
    for (auto m : all_demosaic_methods()) std::printf("%-16s %s\n", to_string(m), demosaic_method_description(m));
    return;
  }
  if (c.in.empty()) fail("demosaic: --in MOSAIC is required (or --list)");
  if (c.out.empty()) fail("demosaic: --out RGB.exr is required");
  const CfaPattern cfa = parse_cfa(c.cfa);
  const DemosaicMethod method = parse_demosaic_method(c.method);
  SensorRunner runner(resolve_backend(c.backend));
  const std::string ext = lower_extension(c.out);
  if (ext != ".exr" && ext != ".png")
    fail_at(c.out, "output must be .exr or .png (got '" + ext + "')");
  check_output_path(c.out, c.overwrite);
  if (!std::filesystem::is_regular_file(c.in)) fail_at(c.in, "no such file");
  ImageFileInfo info;
  ImageF mosaic_img = read_image(c.in, &info);
  if (mosaic_img.channels() != 1)
    fail_at(c.in, fmt::format("a CFA mosaic has one channel; this image has {}", mosaic_img.channels()));
  if (mosaic_img.width() < 1 || mosaic_img.height() < 1) fail_at(c.in, "empty image");
  if (mosaic_img.unit().empty()) mosaic_img.set_unit(info.is_float ? "" : unit::dimensionless);
  ImageF rgb = runner.demosaic(mosaic_img, cfa, method);
  rgb.set_unit(mosaic_img.unit());
  if (ext == ".png") {
    write_png(c.out, rgb, !info.is_float && info.bits_per_sample == 8 ? 8 : 16);
  } else {
    write_exr(c.out, {{{"R", "G", "B"}, &rgb, rgb.unit()}},
              {{"photosite/demosaic", std::string(to_string(method))},
               {"photosite/cfa", std::string(to_string(cfa))},
               {"photosite/source", c.in},
               {"photosite/scale", std::string(info.is_float ? "input units" : "code / max code of the input")}},
              ExrWriteOptions{.reproducible = true});
  }
  std::printf("%s\n", c.out.c_str());
}
}  // namespace

static Registrar reg("c-demosaic", [](CLI::App& app) {
  auto cmd = std::make_shared<DemosaicCmd>();
  auto* sub = app.add_subcommand("demosaic", "demosaic a single-channel CFA mosaic (PNG, TIFF, EXR) to RGB");
  sub->add_option("--in", cmd->in, "single-channel mosaic: PNG 8/16-bit, TIFF or EXR");
  sub->add_option("--out", cmd->out, "RGB output, .exr (float) or .png");
  sub->add_option("--cfa", cmd->cfa, "CFA pattern: RGGB, BGGR, GRBG, GBRG, RCCB, RCCC, MONO")->capture_default_str();
  sub->add_option("--method", cmd->method, "demosaic method (see --list)")->capture_default_str();
  sub->add_flag("--list", cmd->list, "list the demosaic methods and exit");
  add_overwrite_flag(sub, cmd->overwrite);
  add_backend_option(sub, cmd->backend);
  sub->callback([cmd] { run(*cmd); });
});

}  // namespace photosite::cli
