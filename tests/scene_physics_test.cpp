// Physical relations of the night stages (scene/lights.cpp, scene/darken.cpp, scene/night.cpp),
// checked through the public chain on synthetic scenes: retroreflection of lane markings, the
// low beam's illuminance against depth, traffic-signal detection and vehicle colour cues. The
// relations are independent of how depth is parameterised, so they hold for any geometry model.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "photosite/scene/night.h"
#include "photosite/sensor/spectrum.h"

using namespace photosite;
using namespace photosite::scene;

namespace {
// The urban preset without bloom, so each pixel of the light map holds only what was put there.
ScenePreset no_bloom() {
  ScenePreset p = load_scene_preset("night-urban");
  p.bloom_fraction = 0;
  return p;
}
double lum(const ImageF& img, size_t i) {
  const float c[3] = {img[3 * i], img[3 * i + 1], img[3 * i + 2]};
  return spectrum::luminance_cd_m2(c);
}
double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}
}  // namespace

// Retroreflection (EN 1436): a lane marking under the ego beam's illuminance E has luminance
// L = R_L · E. E is not read from the code's beam model: it is recovered at the same pixel from
// the beam's diffuse reflection that compose() adds to the ground, night − lights − darkened =
// f_k t_k E / π (f the reflectance texture, t the beam's tint), whose luminance is
// E · Σ_k K_k t_k f_k / π. So at each marking pixel R_L·E follows from the images alone. Only
// pixels where the beam term is at least 10% of the night luminance are used, so the float
// subtraction loses at most a factor 10 of single precision (10 × 6e-8 relative per operand):
// the ratio is 1 within 1e-4 at the median pixel (lamp discs of the cars may cover a few).
TEST(ScenePhysics, MarkingLuminanceIsRLTimesBeamIlluminance) {
  const ScenePreset p = no_bloom();
  const SyntheticScene s = make_synthetic_road({});
  const NightScene n = night_scene(s.day_linear_srgb, s.labels, p, 1, /*keep_darkened=*/true);
  ASSERT_EQ(n.lanes_work.width(), n.radiance.width()) << "the synthetic scene is below work_max_width";
  const ImageF tex = reflectance_texture(s.day_linear_srgb, s.labels.ids, p);
  const auto tb = illuminant_tint(p.beam_cct_K);
  const auto& K = spectrum::band_luminous_efficacy_lm_per_W();
  std::vector<double> ratio;
  for (size_t i = 0; i < n.radiance.pixel_count(); ++i) {
    if (!n.lanes_work[i]) continue;
    float beam[3];
    for (int k = 0; k < 3; ++k) beam[k] = n.radiance[3 * i + k] - n.lights[3 * i + k] - n.darkened[3 * i + k];
    const double beam_lum = spectrum::luminance_cd_m2(beam);
    if (beam_lum < 0.1 * lum(n.radiance, i)) continue;
    double ktf = 0;
    for (int k = 0; k < 3; ++k) ktf += K[k] * tb[k] * tex[3 * i + k];
    const double E = M_PI * beam_lum / ktf;
    ratio.push_back(lum(n.lights, i) / (p.marking_RL * E));
  }
  ASSERT_GE(ratio.size(), 100u);
  const double m = median(ratio);
  std::fprintf(stderr, "[scene] %zu marking pixels: median L / (R_L E) = %.6f\n", ratio.size(), m);
  EXPECT_NEAR(m, 1.0, 1e-4);
}
