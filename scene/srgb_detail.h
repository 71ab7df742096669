// Private (not installed): the sRGB encode of a float in [0, 1] rounded to float, as the lane
// stage's working luminance needs it (scene/lanes.cpp).
#pragma once

namespace photosite::scene {

// out[i] = static_cast<float>(srgb_encode(clamp(v[i], 0, 1))) to the bit (tests/scene_test.cpp
// checks every float in [0, 1]), faster than through std::pow: see lanes.cpp. out may be v.
void srgb_encode_floats(const float* v, int n, float* out);

}  // namespace photosite::scene
