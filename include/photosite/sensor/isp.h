// A small, documented ISP for previews (people look at these; the EXR is the data):
//  1. white balance: per-channel gains that make an equal-energy white (box radiance 1,1,1)
//     neutral through this camera's QE and CFA (von Kries on the camera's own response);
//  2. colour matrix: none (camera RGB is shown as if it were linear sRGB; documented);
//  3. exposure: the 99th percentile of luminance maps to `white_point` (default 1);
//  4. tone curve: the sRGB transfer function (IEC 61966-2-1), clipped to [0, 1].
#pragma once
#include <array>
#include <cstdint>

#include "photosite/image.h"
#include "photosite/sensor/pipeline.h"

namespace photosite {

std::array<double, 3> white_balance_gains(const CameraPreset& preset);
double srgb_encode(double linear);  // IEC 61966-2-1 OETF
double srgb_decode(double encoded);  // its inverse

// rgb: linear camera RGB (any scale, e.g. DN above black). Returns sRGB-encoded [0,1] floats.
ImageF preview_srgb(const ImageF& rgb, const std::array<double, 3>& wb_gains,
                    double percentile = 0.99, double white_point = 1.0);
// The same preview as 8-bit sRGB codes, what a PNG preview stores: each sample's code is the
// nearest to 255 · srgb_encode(x), x = rgb · wb · scale in float, found by comparing x with the
// 255 decision levels srgb_decode((k - 1/2) / 255) (no pow per sample). Exact: a level is kept
// as the smallest float not below its double value, so for a float x the comparison decides as
// the double one would.
uint8_t srgb_encode8(float linear);  // that code for one sample (NaN and below 0: 0)
ImageU8 preview_srgb8(const ImageF& rgb, const std::array<double, 3>& wb_gains,
                      double percentile = 0.99, double white_point = 1.0);

}  // namespace photosite
