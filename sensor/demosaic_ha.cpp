// Hamilton-Adams edge-directed demosaicing.
// J. F. Hamilton Jr., J. E. Adams Jr., "Adaptive color plan interpolation in single sensor color
// electronic camera", US Patent 5,629,734 (1997); see also B. K. Gunturk et al., "Demosaicking:
// color filter array interpolation", IEEE Signal Processing Magazine 22(1), 2005, Sec. III.
// Green at a red or blue pixel is interpolated along the row or the column, whichever has the
// smaller gradient (|first difference of green| + |second difference of the centre colour|),
// each directional estimate being the green mean plus half the Laplacian of the centre colour.
// Choosing the direction along an edge, never across it, removes bilinear's zipper. Red and
// blue then come from the colour differences G-R and G-B, which are smooth: at green pixels
// from the two neighbours of that colour, at blue (red) pixels along the diagonal with the
// smaller gradient.
#include <cmath>

#include "demosaic_detail.h"
#include "photosite/sensor/demosaic.h"

namespace photosite {
namespace {

// Pass 1: the full green plane.
struct HaGreen {
  static constexpr int kOut = 1;
  template <int T, class F>
  void px(const F& f, const detail::PixelOut& o) const {
    using namespace detail;
    const float c = f(0, 0, 0);
    if constexpr (T == kGr || T == kGb) {
      o[0] = c;
    } else {
      const float l = f(0, -1, 0), r = f(0, 1, 0), u = f(0, 0, -1), d = f(0, 0, 1);
      const float lap_h = 2.f * c - f(0, -2, 0) - f(0, 2, 0);
      const float lap_v = 2.f * c - f(0, 0, -2) - f(0, 0, 2);
      const float grad_h = std::fabs(l - r) + std::fabs(lap_h);
      const float grad_v = std::fabs(u - d) + std::fabs(lap_v);
      const float gh = 0.5f * (l + r) + 0.25f * lap_h;
      const float gv = 0.5f * (u + d) + 0.25f * lap_v;
      o[0] = grad_h < grad_v ? gh : (grad_v < grad_h ? gv : 0.5f * (gh + gv));
    }
  }
};

// Pass 2: red and blue from the colour differences; plane 0 is the mosaic, plane 1 green.
struct HaColour {
  static constexpr int kOut = 3;
  template <int T, class F>
  void px(const F& f, const detail::PixelOut& o) const {
    using namespace detail;
    const float c = f(0, 0, 0), g = f(1, 0, 0);
    auto diff = [&](int dx, int dy) { return f(1, dx, dy) - f(0, dx, dy); };  // G - colour
    if constexpr (T == kR || T == kB) {
      // The other colour sits on the diagonals: interpolate its colour difference along the
      // diagonal with the smaller gradient (as for green, first + second order).
      const float a1 = f(0, -1, -1), a2 = f(0, 1, 1), b1 = f(0, 1, -1), b2 = f(0, -1, 1);
      const float ga1 = f(1, -1, -1), ga2 = f(1, 1, 1), gb1 = f(1, 1, -1), gb2 = f(1, -1, 1);
      const float grad_a = std::fabs(a1 - a2) + std::fabs(2.f * g - ga1 - ga2);
      const float grad_b = std::fabs(b1 - b2) + std::fabs(2.f * g - gb1 - gb2);
      const float da = 0.5f * ((ga1 - a1) + (ga2 - a2)), db = 0.5f * ((gb1 - b1) + (gb2 - b2));
      const float other = g - (grad_a < grad_b ? da : (grad_b < grad_a ? db : 0.5f * (da + db)));
      o[0] = T == kR ? c : other;
      o[1] = g;
      o[2] = T == kR ? other : c;
    } else {
      const float horiz = g - 0.5f * (diff(-1, 0) + diff(1, 0));
      const float vert = g - 0.5f * (diff(0, -1) + diff(0, 1));
      o[0] = T == kGr ? horiz : vert;
      o[1] = c;
      o[2] = T == kGr ? vert : horiz;
    }
  }
};

}  // namespace

ImageF demosaic_hamilton_adams(const ImageF& m, CfaPattern pattern) {
  if (!detail::bayer_path_ok(m, pattern)) return detail::demosaic_bilinear_generic(m, pattern);
  const auto ph = detail::bayer_phase(pattern);
  const detail::GreenLevelMosaic in(m, ph);
  ImageF green(m.width(), m.height(), 1, uninitialized, m.unit());
  {
    const ImageF* planes[1] = {&in.get()};
    detail::run_stencil<2>(planes, ph, green, HaGreen{});
  }
  ImageF out(m.width(), m.height(), 3, uninitialized, m.unit());
  const ImageF* planes[2] = {&in.get(), &green};
  detail::run_stencil<1>(planes, ph, out, HaColour{});
  in.finish(out);
  return out;
}

}  // namespace photosite
