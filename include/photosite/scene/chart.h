// The night test chart: a scene in radiance (W·sr⁻¹·m⁻², linear, the sensor's box basis) with the
// 24 ColorChecker patches lit by a lamp of a given illuminance and colour temperature, a grey wedge
// of 20 steps over 5 decades of luminance (1e-3 to 1e2 cd/m²), and two lamp heads (2000 K and
// 4000 K) on a dark background. It is `photosite chart`'s output, the bundled sample of `expose`
// (samples/night-chart.exr) and a standard input for sensor checks.
#pragma once

#include <map>
#include <string>

#include "photosite/image.h"
#include "photosite/io.h"

namespace photosite::scene {

struct ChartOptions {
  int width = 640, height = 480;
  double illuminance_lux = 10.0;      // on the patches
  double cct_k = 3000.0;              // of the light on the patches and of the wedge
  double lamp_cd_m2 = 2e4;            // luminance of the two lamp heads
  double background_cd_m2 = 0.005;    // of the 4000 K background
};

// Bad input (Error, Kind::BadInput, naming the parameter) on a size outside 64x48..16384x16384, a negative
// illuminance or luminance, or a CCT outside [1000, 25000] K.
ImageF render_chart(const ChartOptions& o);

// The EXR header attributes that describe the chart (content, illuminance, CCT, version).
std::map<std::string, ExrAttribute> chart_attributes(const ChartOptions& o);

// Where the chart puts things, for checks: patch p's rectangle [x0, x1) x [y0, y1), and the wedge's
// step s (0..19) and its luminance.
struct ChartRect {
  int x0, y0, x1, y1;
};
ChartRect chart_patch_rect(const ChartOptions& o, int patch);
ChartRect chart_wedge_rect(const ChartOptions& o, int step);
double chart_wedge_luminance_cd_m2(int step);
// The patch's published sRGB (BabelColor ColorChecker 2005, 8-bit, D65).
const unsigned char* chart_patch_srgb8(int patch);

}  // namespace photosite::scene
