#include "photosite/sensor/demosaic.h"

#include <algorithm>
#include <cctype>

#include "photosite/error.h"

namespace photosite {

std::vector<std::string> demosaic_method_names() { return {"bilinear"}; }

const char* to_string(DemosaicMethod m) {
  switch (m) {
    case DemosaicMethod::Bilinear: return "bilinear";
  }
  return "?";
}

DemosaicMethod parse_demosaic_method(const std::string& name) {
  std::string l = name;
  std::transform(l.begin(), l.end(), l.begin(), [](unsigned char c) { return std::tolower(c); });
  if (l == "bilinear") return DemosaicMethod::Bilinear;
  std::string known;
  for (const auto& n : demosaic_method_names()) known += (known.empty() ? "" : ", ") + n;
  fail("unknown demosaic method '" + name + "' (known: " + known + ")");
}

ImageF demosaic(const ImageF& mosaic, CfaPattern pattern, DemosaicMethod method) {
  if (mosaic.channels() != 1) fail("demosaic: the mosaic must have exactly one channel");
  switch (method) {
    case DemosaicMethod::Bilinear: return demosaic_bilinear(mosaic, pattern);
  }
  internal_error("demosaic: unhandled method");
}

void filter_planes_to_rgb(CfaPattern pattern, const float planes[4], float rgb[3]) {
  switch (pattern) {
    case CfaPattern::RCCB:
      rgb[0] = planes[0];
      rgb[2] = planes[2];
      rgb[1] = planes[3] - planes[0] - planes[2];
      break;
    case CfaPattern::RCCC:
      rgb[0] = planes[0];
      rgb[1] = rgb[2] = 0.5f * (planes[3] - planes[0]);
      break;
    case CfaPattern::Mono:
      rgb[0] = rgb[1] = rgb[2] = planes[3] / 3.f;
      break;
    default:
      rgb[0] = planes[0];
      rgb[1] = planes[1];
      rgb[2] = planes[2];
  }
}

ImageF demosaic_bilinear(const ImageF& m, CfaPattern pattern) {
  const int w = m.width(), h = m.height();
  ImageF out(w, h, 3, uninitialized, m.unit());
  static constexpr float k[3][3] = {{1, 2, 1}, {2, 4, 2}, {1, 2, 1}};
#pragma omp parallel for schedule(static)
  for (int y = 0; y < h; ++y) {
    float* o = out.row(y);
    for (int x = 0; x < w; ++x) {
      float sum[4] = {0, 0, 0, 0}, wsum[4] = {0, 0, 0, 0};
      for (int dy = -1; dy <= 1; ++dy) {
        const int yy = y + dy;
        if (yy < 0 || yy >= h) continue;
        const float* r = m.row(yy);
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = x + dx;
          if (xx < 0 || xx >= w) continue;
          const int c = static_cast<int>(cfa_color(pattern, xx, yy));
          const float kw = k[dy + 1][dx + 1];
          sum[c] += kw * r[xx];
          wsum[c] += kw;
        }
      }
      float planes[4];
      for (int c = 0; c < 4; ++c) planes[c] = wsum[c] > 0 ? sum[c] / wsum[c] : 0.f;
      filter_planes_to_rgb(pattern, planes, o + 3 * x);
    }
  }
  return out;
}

}  // namespace photosite
