// `photosite chart`: renders a night test scene in radiance (W·sr⁻¹·m⁻²): the 24 ColorChecker
// patches lit by a lamp of a given illuminance and colour temperature, a grey wedge spanning
// 5 decades of luminance, and two bright lamp heads on a dark background. It is the bundled
// sample of `expose` and a standard input for sensor checks.
#include <cmath>
#include <cstdio>

#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/sensor/isp.h"
#include "photosite/sensor/spectrum.h"
#include "registry.h"

namespace photosite::cli {
namespace {
// ColorChecker sRGB (8-bit, D65) values as published by BabelColor (ColorChecker 2005 data).
constexpr unsigned char kPatches[24][3] = {
    {115, 82, 68},   {194, 150, 130}, {98, 122, 157},  {87, 108, 67},   {133, 128, 177}, {103, 189, 170},
    {214, 126, 44},  {80, 91, 166},   {193, 90, 99},   {94, 60, 108},   {157, 188, 64},  {224, 163, 46},
    {56, 61, 150},   {70, 148, 73},   {175, 54, 60},   {231, 199, 31},  {187, 86, 149},  {8, 133, 161},
    {243, 243, 242}, {200, 200, 200}, {160, 160, 160}, {122, 122, 121}, {85, 85, 85},    {52, 52, 52}};

struct ChartCmd {
  std::string out;
  int width = 640, height = 480;
  double illuminance_lux = 10.0, cct_k = 3000.0, lamp_cd_m2 = 2e4, background_cd_m2 = 0.005;
  bool overwrite = false;
};

void run(const ChartCmd& c) {
  if (c.width < 64 || c.height < 48 || c.width > 16384 || c.height > 16384)
    fail("chart size must be between 64x48 and 16384x16384");
  if (!(c.illuminance_lux >= 0) || !(c.cct_k >= 1000 && c.cct_k <= 25000) || !(c.lamp_cd_m2 >= 0) ||
      !(c.background_cd_m2 >= 0))
    fail("chart: illuminance, lamp and background luminance must be >= 0, CCT in [1000, 25000] K");
  check_output_path(c.out, c.overwrite);
  // Illuminant colour in the box basis, normalised to unit luminance.
  const auto illum = spectrum::blackbody_rgb(c.cct_k, 1.0);
  const auto& to_box = spectrum::linear_srgb_to_box();
  // Luminance of a Lambertian white under E lux: L = E/π cd/m².
  const double white_cd_m2 = c.illuminance_lux / 3.14159265358979;
  // Box-space reflectance ρ_k = (M⁻¹·sRGB_lin)_k / (M⁻¹·1)_k, clamped at 0, so a perfect white is
  // ρ = (1,1,1); the illuminant (unit luminance) multiplies band by band, scaled to E/π cd/m².
  auto radiance_of = [&](const double srgb_lin[3], double luminance_scale, float* px) {
    for (int k = 0; k < 3; ++k) {
      double rho = 0, white = 0;
      for (int j = 0; j < 3; ++j) {
        rho += to_box[k][j] * srgb_lin[j];
        white += to_box[k][j];
      }
      px[k] = static_cast<float>(std::max(0.0, rho / white) * illum[k] * luminance_scale);
    }
  };
  ImageF img(c.width, c.height, 3, 0.f, unit::radiance);
  const auto bg = spectrum::blackbody_rgb(4000, c.background_cd_m2);
  for (size_t i = 0; i < img.pixel_count(); ++i)
    for (int k = 0; k < 3; ++k) img[3 * i + k] = static_cast<float>(bg[k]);
  // Patches: 6 x 4 grid in the upper 70% of the frame.
  const int cw = c.width / 7, ch = static_cast<int>(c.height * 0.7) / 5, gap = cw / 8;
  for (int p = 0; p < 24; ++p) {
    const int gx = p % 6, gy = p / 6;
    double lin[3];
    for (int j = 0; j < 3; ++j) lin[j] = srgb_decode(kPatches[p][j] / 255.0);
    float px[3];
    radiance_of(lin, white_cd_m2, px);
    for (int y = gap + gy * (ch + gap / 2); y < gap + gy * (ch + gap / 2) + ch; ++y)
      for (int x = gap + gx * (cw + gap / 2); x < gap + gx * (cw + gap / 2) + cw; ++x)
        if (x < c.width && y < c.height)
          for (int k = 0; k < 3; ++k) img.at(x, y, k) = px[k];
  }
  // Grey wedge: 20 steps from 1e-3 to 1e2 cd/m² along the bottom.
  const int y0 = static_cast<int>(c.height * 0.78), y1 = static_cast<int>(c.height * 0.92);
  for (int s = 0; s < 20; ++s) {
    const double lum = std::pow(10.0, -3.0 + 5.0 * s / 19.0);
    const auto v = spectrum::blackbody_rgb(c.cct_k, lum);
    for (int y = y0; y < y1; ++y)
      for (int x = s * c.width / 20; x < (s + 1) * c.width / 20; ++x)
        for (int k = 0; k < 3; ++k) img.at(x, y, k) = static_cast<float>(v[k]);
  }
  // Two lamp heads (sodium-like 2000 K and LED 4000 K) at the right edge, upper area.
  const double cts[2] = {2000.0, 4000.0};
  for (int l = 0; l < 2; ++l) {
    const auto v = spectrum::blackbody_rgb(cts[l], c.lamp_cd_m2);
    const int cx = c.width - c.width / 14, cy = c.height / 6 + l * c.height / 4, r = std::max(2, c.width / 80);
    for (int y = cy - r; y <= cy + r; ++y)
      for (int x = cx - r; x <= cx + r; ++x)
        if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r)
          for (int k = 0; k < 3; ++k) img.at(x, y, k) = static_cast<float>(v[k]);
  }
  ExrWriteOptions wo;
  wo.reproducible = true;
  write_exr(c.out, {{{"R", "G", "B"}, &img, unit::radiance}},
            {{"photosite/version", std::string(PHOTOSITE_VERSION)},
             {"photosite/content", std::string("night test chart: ColorChecker, grey wedge, lamps")},
             {"photosite/illuminance_lux", c.illuminance_lux},
             {"photosite/cct_k", c.cct_k}},
            wo);
  std::printf("%s\n", c.out.c_str());
}
}  // namespace

static Registrar reg("d-chart", [](CLI::App& app) {
  auto cmd = std::make_shared<ChartCmd>();
  auto* sub = app.add_subcommand("chart", "render a night test-chart scene in radiance (EXR)");
  sub->add_option("--out", cmd->out, "output EXR")->required();
  sub->add_option("--width", cmd->width)->capture_default_str();
  sub->add_option("--height", cmd->height)->capture_default_str();
  sub->add_option("--illuminance-lux", cmd->illuminance_lux, "illuminance on the chart, lux")->capture_default_str();
  sub->add_option("--cct-k", cmd->cct_k, "colour temperature of the light, K")->capture_default_str();
  sub->add_option("--lamp-cd-m2", cmd->lamp_cd_m2, "luminance of the lamp heads, cd/m2")->capture_default_str();
  sub->add_option("--background-cd-m2", cmd->background_cd_m2, "background luminance, cd/m2")->capture_default_str();
  add_overwrite_flag(sub, cmd->overwrite);
  sub->callback([cmd] { run(*cmd); });
});

}  // namespace photosite::cli
