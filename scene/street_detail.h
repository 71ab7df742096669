// Private (not installed): scene/street.cpp's instruction-set cap and the pole components of
// plan_street_lighting, for the tests that pin them (the same bits on every path; OpenCV's labels).
#pragma once
#include <vector>

#include "photosite/image.h"

namespace photosite::scene {

// The widest instruction set the street light's row paths (pools, vertical surfaces, façade
// windows) may take: 2 AVX-512 (the AVX2 code compiled for AVX-512VL), 1 AVX2, 0 the scalar
// twins (default 2; the machine's support and PHOTOSITE_SCALAR_LIGHTS=1 cap it). All give the
// same bits; the test runs each. Not thread-safe: set it before a light map, not during one.
void street_light_max_isa(int isa);

// A connected component's bounding box (inclusive pixel bounds).
struct PoleBox {
  int x0, y0, x1, y1;
};
// The 8-connected components of the pole pixels (Label::Pole or Label::PoleGroup) of a label
// image, as bounding boxes, in the order cv::connectedComponents(mask, cc, 8) numbers them: by
// the first 2x2 block (on the even grid, in raster order of the blocks) holding a pixel of the
// component. Found from the rows' runs of pole pixels (union-find over the runs), without a
// mask image or a labelling of the whole frame.
std::vector<PoleBox> pole_components(const ImageU16& labels);

}  // namespace photosite::scene
