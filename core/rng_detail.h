// Private (not installed): Philox4x32-10 inline, for the library's hot loops. The generator is
// written once, in kernels/common/philox_round.glsl (the C++/GLSL common subset, prelude in
// kernels/common/prelude.glsl), compiled here as C++ inside namespace photosite::shader and
// into the Vulkan kernels by glslang. include/photosite/rng.h declares the public entry points
// (random_words, Philox4x32::generate), defined in core/rng.cpp from this header.
#pragma once
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>

#include "photosite/rng.h"

namespace photosite::shader {
#include "common/prelude.glsl"
#include "common/philox_round.glsl"
#include "common/prelude_end.glsl"
}  // namespace photosite::shader

namespace photosite::detail {

// A 64-bit value as the (low, high) halves the shared code takes.
inline shader::uvec2 halves(uint64_t v) {
  return shader::uvec2(static_cast<uint32_t>(v), static_cast<uint32_t>(v >> 32));
}

// random_words() inline.
inline std::array<uint32_t, 4> random_words_inline(uint64_t seed, uint32_t frame, uint64_t pixel, uint32_t stream) {
  const shader::uvec4 w = shader::random_words(halves(seed), frame, halves(pixel), stream);
  return {w.x, w.y, w.z, w.w};
}

}  // namespace photosite::detail
