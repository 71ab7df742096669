// `photosite chart`: writes the night test chart (include/photosite/scene/chart.h) as an EXR in
// radiance (W·sr⁻¹·m⁻²).
#include <cstdio>

#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/scene/chart.h"
#include "registry.h"
#include "sensor_options.h"

namespace photosite::cli {
namespace {
struct ChartCmd {
  std::string out;
  scene::ChartOptions chart;
  bool overwrite = false;
};

void run(const ChartCmd& c) {
  const ImageF img = scene::render_chart(c.chart);  // checks the options before any output
  check_output_path(c.out, c.overwrite);
  check_run_outputs({{"--out", {c.out}, ".exr"}});
  ExrWriteOptions wo;
  wo.reproducible = true;
  write_exr(c.out, {{{"R", "G", "B"}, &img, unit::radiance}}, scene::chart_attributes(c.chart), wo);
  std::printf("%s\n", c.out.c_str());
}
}  // namespace

static Registrar reg("d-chart", [](CLI::App& app) {
  auto cmd = std::make_shared<ChartCmd>();
  auto* sub = app.add_subcommand("chart", "render a night test-chart scene in radiance (EXR)");
  sub->add_option("--out", cmd->out, "output EXR")->required();
  sub->add_option("--width", cmd->chart.width, "chart width in pixels, 64 to 16384")->capture_default_str();
  sub->add_option("--height", cmd->chart.height, "chart height in pixels, 48 to 16384")->capture_default_str();
  sub->add_option("--illuminance-lux", cmd->chart.illuminance_lux, "illuminance on the chart, lux")->capture_default_str();
  sub->add_option("--cct-k", cmd->chart.cct_k, "colour temperature of the light, K")->capture_default_str();
  sub->add_option("--lamp-cd-m2", cmd->chart.lamp_cd_m2, "luminance of the lamp heads, cd/m2")->capture_default_str();
  sub->add_option("--background-cd-m2", cmd->chart.background_cd_m2, "background luminance, cd/m2")->capture_default_str();
  add_overwrite_flag(sub, cmd->overwrite);
  sub->callback([cmd] { run(*cmd); });
});

}  // namespace photosite::cli
