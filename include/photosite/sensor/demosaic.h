// Demosaicing: a single-channel CFA mosaic (linear, float) in, a full-colour linear RGB image
// out, for every pattern in cfa.h. For the clear patterns the output is still R, G, B: with a
// clear pixel passing R+G+B (photosite's box spectral basis), G = C - R - B for RCCB, and for
// RCCC (red + clear only) G = B = (C - R) / 2, a red-and-grey image.
#pragma once
#include <string>
#include <vector>

#include "photosite/image.h"
#include "photosite/sensor/cfa.h"

namespace photosite {

enum class DemosaicMethod { Bilinear };

std::vector<std::string> demosaic_method_names();
DemosaicMethod parse_demosaic_method(const std::string& name);  // bad input on unknown names
const char* to_string(DemosaicMethod m);

ImageF demosaic(const ImageF& mosaic, CfaPattern pattern,
                DemosaicMethod method = DemosaicMethod::Bilinear);

// Bilinear interpolation as normalized convolution with the 3x3 kernel [1 2 1; 2 4 2; 1 2 1]
// over the pixels of each filter colour: exactly the textbook bilinear on Bayer data, and
// borders use only the neighbours that exist (no black frame, no wrap-around).
ImageF demosaic_bilinear(const ImageF& mosaic, CfaPattern pattern);

// Turns per-filter planes (R, G, B, C interpolated at every pixel) into RGB for the pattern.
void filter_planes_to_rgb(CfaPattern pattern, const float planes[4], float rgb[3]);

}  // namespace photosite
