// Private (not installed): scene::darken's per-pixel maths, written once in
// kernels/common/darken.glsl (the C++/GLSL common subset, prelude in kernels/common/prelude.glsl)
// and compiled here as C++ in namespace photosite::shader; kernels/darken.comp compiles the same
// file.
#pragma once
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

#include "core/rng_detail.h"
#include "photosite/scene/night.h"

namespace photosite::shader {
#include "common/prelude.glsl"
#include "common/darken.glsl"
#include "common/prelude_end.glsl"
}  // namespace photosite::shader

namespace photosite::scene {

// One pixel of the darkened radiance: texture t (3 floats) of class id under the night
// illuminance d (darken_params()), written to o (3 floats).
inline void darken_pixel(const float* t, int id, const DarkenParams& d, float* o) {
  if (id == static_cast<int>(Label::Sky)) {
    const double yr = shader::darken_sky_relative(d.K[0], d.K[1], d.K[2], d.rho_sky, t[0], t[1], t[2]);
    for (int k = 0; k < 3; ++k) o[k] = shader::darken_sky_channel(d.glow[k], yr);
    return;
  }
  for (int k = 0; k < 3; ++k) o[k] = shader::darken_lit_channel(t[k], d.ambient[k]);
}

}  // namespace photosite::scene
