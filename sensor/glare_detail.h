// Private (not installed): the lens glare's per-pixel maths, written once in
// kernels/common/glare.glsl (the C++/GLSL common subset, prelude in kernels/common/prelude.glsl)
// and compiled here as C++ in namespace photosite::shader; kernels/glare_*.comp and photon.comp
// compile the same file.
#pragma once
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

namespace photosite::shader {
#include "common/prelude.glsl"
#include "common/glare.glsl"
#include "common/prelude_end.glsl"
}  // namespace photosite::shader
