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

namespace photosite::detail {
// sense_electrons then sense_raw_dn over a row of w pixels (the full well, then the analog chain
// to DN), and the mosaic above black d − black: erow (drawn electrons in, collected out), drow,
// abrow; off, read, col: the DSNU, read-noise normal and column noise per pixel. analog_row
// takes the AVX-512 path where the CPU has it (sensor/pipeline.cpp), analog_row_definition is
// the per-pixel loop; the same bits (test SenseFastPath.AnalogRowEqualsItsDefinition).
void analog_row(float* erow, const float* off, const float* read, const float* col, float row_noise, float rn, float fw,
                double K, double black, double max_code, int w, float* drow, float* abrow);
void analog_row_definition(float* erow, const float* off, const float* read, const float* col, float row_noise,
                           float rn, float fw, double K, double black, double max_code, int w, float* drow,
                           float* abrow);
// Caps the vector level of the photon stage's glared row (0 the per-pixel loops, 1 AVX2, 2
// AVX-512; the machine's level is the most it takes) for the stages made after the call; the
// tests run each level. Every level gives the same bits.
void photon_row_max_isa(int isa);
}  // namespace photosite::detail
