// Malvar-He-Cutler gradient-corrected bilinear interpolation.
// H. S. Malvar, L.-W. He, R. Cutler, "High-quality linear interpolation for demosaicing of
// Bayer-patterned color images", Proc. IEEE ICASSP 2004, vol. 3, pp. 485-488.
// Each missing colour is its bilinear estimate plus a gain times the Laplacian of the colour that
// is present at the pixel (the high frequencies of the channels are strongly correlated); the
// gains (1/2, 5/8, 3/4) were fitted to the Kodak set by Wiener-style optimisation, giving the
// eight fixed 5x5 filters below (Fig. 2 of the paper, in units of 1/8).
#include "demosaic_detail.h"
#include "photosite/sensor/demosaic.h"

namespace photosite {
namespace {

struct MalvarKernel {
  static constexpr int kOut = 3;
  template <int T, class F>
  void px(const F& f, const detail::PixelOut& o) const {
    using namespace detail;
    const float c = f(0, 0, 0);
    const float l = f(0, -1, 0), r = f(0, 1, 0), u = f(0, 0, -1), d = f(0, 0, 1);
    const float l2 = f(0, -2, 0), r2 = f(0, 2, 0), u2 = f(0, 0, -2), d2 = f(0, 0, 2);
    const float diag = (f(0, -1, -1) + f(0, 1, -1)) + (f(0, -1, 1) + f(0, 1, 1));
    const float h2 = l2 + r2, v2 = u2 + d2;
    if constexpr (T == kR || T == kB) {
      // G at R/B: [0 0 -1 0 0; 0 0 2 0 0; -1 2 4 2 -1; ...] / 8
      const float g = 0.125f * (4.f * c + 2.f * ((l + r) + (u + d)) - (h2 + v2));
      // B at R (R at B): [0 0 -3/2 0 0; 0 2 0 2 0; -3/2 0 6 0 -3/2; ...] / 8
      const float other = 0.125f * (6.f * c + 2.f * diag - 1.5f * (h2 + v2));
      o[0] = T == kR ? c : other;
      o[1] = g;
      o[2] = T == kR ? other : c;
    } else {
      // The colour whose samples sit left and right of this green pixel:
      // [0 0 1/2 0 0; 0 -1 0 -1 0; -1 4 5 4 -1; 0 -1 0 -1 0; 0 0 1/2 0 0] / 8
      const float horiz = 0.125f * (5.f * c + 4.f * (l + r) - h2 - diag + 0.5f * v2);
      // ... and the colour above and below (the transposed filter).
      const float vert = 0.125f * (5.f * c + 4.f * (u + d) - v2 - diag + 0.5f * h2);
      o[0] = T == kGr ? horiz : vert;
      o[1] = c;
      o[2] = T == kGr ? vert : horiz;
    }
  }
};

}  // namespace

ImageF demosaic_malvar(const ImageF& m, CfaPattern pattern) {
  if (!detail::bayer_path_ok(m, pattern)) return detail::demosaic_bilinear_generic(m, pattern);
  const auto ph = detail::bayer_phase(pattern);
  ImageF out(m.width(), m.height(), 3, uninitialized, m.unit());
  const detail::GreenLevelMosaic in(m, ph);
  const ImageF* planes[1] = {&in.get()};
  detail::run_stencil<2>(planes, ph, out, MalvarKernel{});
  in.finish(out);
  return out;
}

}  // namespace photosite
