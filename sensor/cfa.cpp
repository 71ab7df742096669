#include "photosite/sensor/cfa.h"

#include <algorithm>
#include <cctype>

#include "photosite/error.h"

namespace photosite {

const char* to_string(FilterColor c) {
  switch (c) {
    case FilterColor::R: return "R";
    case FilterColor::G: return "G";
    case FilterColor::B: return "B";
    case FilterColor::C: return "C";
  }
  return "?";
}

const char* to_string(CfaPattern p) {
  switch (p) {
    case CfaPattern::RGGB: return "RGGB";
    case CfaPattern::BGGR: return "BGGR";
    case CfaPattern::GRBG: return "GRBG";
    case CfaPattern::GBRG: return "GBRG";
    case CfaPattern::RCCB: return "RCCB";
    case CfaPattern::RCCC: return "RCCC";
    case CfaPattern::Mono: return "MONO";
  }
  return "?";
}

std::vector<CfaPattern> all_cfa_patterns() {
  return {CfaPattern::RGGB, CfaPattern::BGGR, CfaPattern::GRBG, CfaPattern::GBRG,
          CfaPattern::RCCB, CfaPattern::RCCC, CfaPattern::Mono};
}

CfaPattern parse_cfa(const std::string& name) {
  std::string u = name;
  std::transform(u.begin(), u.end(), u.begin(), [](unsigned char ch) { return std::toupper(ch); });
  for (auto p : all_cfa_patterns())
    if (u == to_string(p)) return p;
  fail("unknown CFA pattern '" + name + "' (expected RGGB, BGGR, GRBG, GBRG, RCCB, RCCC or MONO)");
}

bool is_bayer(CfaPattern p) {
  return p == CfaPattern::RGGB || p == CfaPattern::BGGR || p == CfaPattern::GRBG ||
         p == CfaPattern::GBRG;
}

bool is_clear_pattern(CfaPattern p) { return p == CfaPattern::RCCB || p == CfaPattern::RCCC; }

std::vector<FilterColor> cfa_colors(CfaPattern p) {
  std::vector<FilterColor> out;
  for (int c = 0; c < kFilterColorCount; ++c)
    for (int i = 0; i < 4; ++i)
      if (cfa_color(p, i & 1, i >> 1) == static_cast<FilterColor>(c)) {
        out.push_back(static_cast<FilterColor>(c));
        break;
      }
  return out;
}

ImageF mosaic(const ImageF& rgb, CfaPattern p) {
  if (rgb.channels() < 3) internal_error("mosaic: expected an RGB image");
  ImageF out(rgb.width(), rgb.height(), 1, uninitialized, rgb.unit());
  const int nc = rgb.channels();
#pragma omp parallel for schedule(static)
  for (int y = 0; y < rgb.height(); ++y) {
    const float* s = rgb.row(y);
    float* d = out.row(y);
    for (int x = 0; x < rgb.width(); ++x) {
      const FilterColor c = cfa_color(p, x, y);
      d[x] = c == FilterColor::C ? s[x * nc] + s[x * nc + 1] + s[x * nc + 2]
                                 : s[x * nc + static_cast<int>(c)];
    }
  }
  return out;
}

}  // namespace photosite
