// Private (not installed): the per-pixel maths of the photon and sense stages, written once in
// kernels/common/sensor_pixel.glsl (the C++/GLSL common subset, prelude in
// kernels/common/prelude.glsl) and compiled here as C++ in namespace photosite::shader; the
// Vulkan kernels photon.comp and sense.comp compile the same file.
#pragma once
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

#include "core/rng_detail.h"

namespace photosite::shader {
#include "common/prelude.glsl"
#include "common/sensor_pixel.glsl"
#include "common/prelude_end.glsl"
}  // namespace photosite::shader
