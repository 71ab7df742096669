// Colour filter arrays. A closed set of 2x2 patterns, named by their top-left 2x2 cell read
// row by row (RGGB = R G / G B). RCCB and RCCC are the automotive "clear" patterns, in which
// the green filters are replaced by unfiltered (clear) pixels for low-light sensitivity.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "photosite/image.h"

namespace photosite {

enum class FilterColor : uint8_t { R = 0, G = 1, B = 2, C = 3 };  // C: clear (no dye)
enum class CfaPattern : uint8_t { RGGB, BGGR, GRBG, GBRG, RCCB, RCCC, Mono };

inline constexpr int kFilterColorCount = 4;
const char* to_string(FilterColor c);
const char* to_string(CfaPattern p);
// Parses "RGGB", "rggb", ...; throws a bad-input Error naming the value otherwise.
CfaPattern parse_cfa(const std::string& name);
std::vector<CfaPattern> all_cfa_patterns();
bool is_bayer(CfaPattern p);  // one of the four RGB Bayer phases
// RCCB or RCCC: clear samples beside coloured ones (the patterns whose clipped highlights are
// made neutral, neutralize_clipped_highlights; Mono is all clear and has no colour to lose).
bool is_clear_pattern(CfaPattern p);

// The filter over pixel (x, y). Mono is all clear.
inline FilterColor cfa_color(CfaPattern p, int x, int y) {
  static constexpr FilterColor R = FilterColor::R, G = FilterColor::G, B = FilterColor::B,
                               C = FilterColor::C;
  static constexpr FilterColor cells[7][4] = {
      {R, G, G, B}, {B, G, G, R}, {G, R, B, G}, {G, B, R, G}, {R, C, C, B}, {R, C, C, C},
      {C, C, C, C}};
  return cells[static_cast<int>(p)][((y & 1) << 1) | (x & 1)];
}

// The distinct filter colours a pattern uses, in R, G, B, C order.
std::vector<FilterColor> cfa_colors(CfaPattern p);

// Samples a full-colour linear RGB image through the pattern: the value at each pixel is the
// channel its filter passes; a clear filter passes R+G+B (all the light, as for radiance in the
// box basis of photosite's spectral model). Used by the demosaic benchmarks and tests.
ImageF mosaic(const ImageF& rgb, CfaPattern p);

}  // namespace photosite
