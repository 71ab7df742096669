// Single-stage entry points (one upload, one dispatch, one download): the device twins of CPU
// functions, used by the parity tests and the benchmark.
#include "photosite/gpu/stages.h"

#include <algorithm>
#include <iterator>
#include <memory>

#include "kernels.h"
#include "photosite/error.h"
#include "photosite/gpu/sequence.h"

namespace photosite::gpu {

void poisson_fill(Context& ctx, const float* mean, float* out, uint64_t n, uint64_t first_pixel,
                  uint64_t seed, uint32_t frame, uint32_t stream, PoissonMethod method) {
  if (n == 0) return;
  (void)grid_1d(n);  // refuses a job beyond the kernels' index before allocating
  Buffer in(ctx, n * sizeof(float)), res(ctx, n * sizeof(float));
  in.upload(mean, n * sizeof(float));
  Sequence s(ctx);
  record_poisson(ctx, s, in, res, n, first_pixel, seed, frame, stream, method);
  s.submit_and_wait();
  res.download(out, n * sizeof(float));
}

void record_poisson(Context& ctx, Sequence& s, Buffer& mean, Buffer& out, uint64_t n, uint64_t first_pixel,
                    uint64_t seed, uint32_t frame, uint32_t stream, PoissonMethod method) {
  Kernel& k = ctx.kernel("poisson", 2, sizeof(PoissonParams));
  const PoissonParams p{static_cast<uint32_t>(n), frame, stream, static_cast<uint32_t>(method), U64::of(first_pixel),
                        U64::of(seed)};
  const Grid g = grid_1d(n);
  s.dispatch(k, {&mean, &out}, p, g.x, g.y, 1, "poisson");
}

std::vector<uint32_t> philox_words(Context& ctx, uint64_t n, uint64_t first_pixel, uint64_t seed,
                                   uint32_t frame, uint32_t stream) {
  std::vector<uint32_t> out(4 * n);
  if (n == 0) return out;
  Buffer res(ctx, out.size() * sizeof(uint32_t));
  Kernel& k = ctx.kernel("philox_words", 1, sizeof(PoissonParams));
  const PoissonParams p{static_cast<uint32_t>(n), frame, stream, 0, U64::of(first_pixel), U64::of(seed)};
  Sequence s(ctx);
  const Grid g = grid_1d(n);
  s.dispatch(k, {&res}, p, g.x, g.y);
  s.submit_and_wait();
  res.download(out.data(), out.size() * sizeof(uint32_t));
  return out;
}

std::vector<float> rounding_probe(Context& ctx, const std::vector<float>& ab, int shift_ulps) {
  const uint64_t n = ab.size() / 2;
  std::vector<float> out(2 * n);
  if (n == 0) return out;
  Buffer in(ctx, ab.size() * sizeof(float)), res(ctx, out.size() * sizeof(float));
  in.upload(ab.data(), 2 * n * sizeof(float));
  Kernel& k = ctx.kernel("rounding", 2, sizeof(RoundingParams));
  const RoundingParams p{static_cast<uint32_t>(n), shift_ulps};
  Sequence s(ctx);
  const Grid g = grid_1d(n);
  s.dispatch(k, {&in, &res}, p, g.x, g.y);
  s.submit_and_wait();
  res.download(out.data(), out.size() * sizeof(float));
  return out;
}

bool has_demosaic_kernel(DemosaicMethod m) {
  switch (m) {
    case DemosaicMethod::Bilinear:
    case DemosaicMethod::Malvar:
    case DemosaicMethod::HamiltonAdams:
    case DemosaicMethod::Lmmse: return true;
    case DemosaicMethod::Mlri: return true;
  }
  return false;
}

void record_demosaic(Context& ctx, Sequence& s, DemosaicMethod method, const DemosaicParams& p, Buffer& raw,
                     Buffer& rgb, const ScratchBuffers& scratch, const std::string& label) {
  const uint64_t w = p.width, h = p.height, n = w * h;
  const Grid g = grid_1d(n);
  // The mirrored Bayer path (demosaic_detail.h bayer_path_ok); elsewhere every method is the
  // generic bilinear path, which the bilinear kernel holds.
  const bool bayer = p.planes_to_rgb <= 1 && w >= 2 && h >= 2;
  auto part = [&](const char* what) { return label.empty() ? label : label + " (" + what + ")"; };
  switch (bayer ? method : DemosaicMethod::Bilinear) {
    case DemosaicMethod::Bilinear:
      s.dispatch(ctx.kernel("demosaic_bilinear", 2, sizeof(p)), {&raw, &rgb}, p, g.x, g.y, 1, label);
      break;
    case DemosaicMethod::Malvar:
      s.dispatch(ctx.kernel("demosaic_malvar", 2, sizeof(p)), {&raw, &rgb}, p, g.x, g.y, 1, label);
      break;
    case DemosaicMethod::HamiltonAdams: {
      Buffer& green = scratch("demosaic_green", n * sizeof(float));
      s.dispatch(ctx.kernel("demosaic_ha_green", 2, sizeof(p)), {&raw, &green}, p, g.x, g.y, 1, part("green"));
      s.dispatch(ctx.kernel("demosaic_ha_colour", 3, sizeof(p)), {&raw, &rgb, &green}, p, g.x, g.y, 1, label);
      break;
    }
    case DemosaicMethod::Lmmse: {
      LmmseParams lp{p, {}};
      detail::lmmse_gauss_weights(lp.gw);
      Buffer& dv = scratch("lmmse_dv", n * sizeof(float));
      Buffer& sv = scratch("lmmse_sv", n * sizeof(float));
      Buffer& zh = scratch("lmmse_zh", (w + 16) * h * sizeof(float));
      Buffer& sh = scratch("lmmse_sh", (w + 8) * h * sizeof(float));
      Buffer& d = scratch("lmmse_d", n * sizeof(float));
      const Grid gz = grid_1d((w + 16) * h), gl = grid_1d(n + (w + 8) * h);
      s.dispatch(ctx.kernel("demosaic_lmmse_vobs", 2, sizeof(lp)), {&raw, &dv}, lp, g.x, g.y, 1, part("observations"));
      s.dispatch(ctx.kernel("demosaic_lmmse_hobs", 2, sizeof(lp)), {&raw, &zh}, lp, gz.x, gz.y, 1, part("observations"));
      s.dispatch(ctx.kernel("demosaic_lmmse_low", 5, sizeof(lp)), {&raw, &dv, &zh, &sv, &sh}, lp, gl.x, gl.y, 1,
                 part("low-pass"));
      s.dispatch(ctx.kernel("demosaic_lmmse_fuse", 6, sizeof(lp)), {&raw, &dv, &zh, &sv, &sh, &d}, lp, g.x, g.y, 1,
                 part("estimate"));
      s.dispatch(ctx.kernel("demosaic_lmmse_colour", 3, sizeof(lp)), {&raw, &rgb, &d}, lp, g.x, g.y, 1, label);
      break;
    }
    case DemosaicMethod::Mlri: {
      // Every plane covers the frame plus the support radius on each side; each stage is
      // dispatched over the frame plus its margins (sensor/demosaic_mlri.cpp's geometry).
      const auto geo = detail::mlri_geometry();
      const auto& c = detail::mlri_constants();
      MlriParams mp{p, 0, 0, 0, geo.margin, {}, {}, {}, {}, {}, c.inv_box_g, c.inv_box_b};
      std::copy(std::begin(c.gw), std::end(c.gw), mp.gw);
      std::copy(std::begin(c.tau_n_g), std::end(c.tau_n_g), mp.tau_n_g);
      std::copy(std::begin(c.inv_n_g), std::end(c.inv_n_g), mp.inv_n_g);
      std::copy(std::begin(c.tau_n_b), std::end(c.tau_n_b), mp.tau_n_b);
      std::copy(std::begin(c.inv_n_b), std::end(c.inv_n_b), mp.inv_n_b);
      const uint64_t plane = (w + 2 * geo.margin) * (h + 2 * geo.margin) * sizeof(float);
      Buffer& lap = scratch("mlri_lap", 2 * plane);
      Buffer& coef = scratch("mlri_coef", 4 * plane);
      Buffer& tent = scratch("mlri_tent", 2 * plane);
      Buffer& dif = scratch("mlri_dif", 2 * plane);
      Buffer& wt = scratch("mlri_wt", 2 * plane);
      Buffer& green = scratch("mlri_green", plane);
      auto stage = [&](const char* kernel, uint32_t dir, int mx, int my, const std::string& what) {
        mp.dir = dir, mp.mx = mx, mp.my = my;
        const Grid gr = grid_1d((w + 2 * mx) * (h + 2 * my));
        if (std::string(kernel) == "demosaic_mlri_rgb")
          s.dispatch(ctx.kernel(kernel, 8, sizeof(mp)), {&raw, &lap, &coef, &tent, &dif, &wt, &green, &rgb}, mp, gr.x,
                     gr.y, 1, label);
        else
          s.dispatch(ctx.kernel(kernel, 7, sizeof(mp)), {&raw, &lap, &coef, &tent, &dif, &wt, &green}, mp, gr.x, gr.y, 1,
                     part(what.c_str()));
      };
      for (uint32_t d = 0; d < 2; ++d) {
        auto along = [&](const char* k, int m, const char* what) {
          stage(k, d, d == 0 ? m : geo.across, d == 0 ? geo.across : m, what);
        };
        along("demosaic_mlri_lap", geo.lap, "green Laplacians");
        along("demosaic_mlri_coef", geo.ab, "green coefficients");
        along("demosaic_mlri_q", geo.q, "green tentative");
        along("demosaic_mlri_dif", geo.dif, "green differences");
      }
      stage("demosaic_mlri_weight", 0, geo.green + 1, geo.green, "green weights");
      stage("demosaic_mlri_weight", 1, geo.green, geo.green + 1, "green weights");
      stage("demosaic_mlri_green", 0, geo.green, geo.green, "green");
      stage("demosaic_mlri_rblap", 0, 1 + 2 * geo.rb, 1 + 2 * geo.rb, "red/blue Laplacians");
      stage("demosaic_mlri_rbcoef", 0, 1 + geo.rb, 1 + geo.rb, "red/blue coefficients");
      stage("demosaic_mlri_rbq", 0, 1, 1, "red/blue tentative");
      stage("demosaic_mlri_rgb", 0, 0, 0, "");
      break;
    }
  }
}

ImageF demosaic(Context& ctx, const ImageF& mosaic, CfaPattern pattern, DemosaicMethod method, double* device_ms) {
  if (mosaic.channels() != 1) fail("demosaic: the mosaic must have exactly one channel");
  const size_t n = mosaic.pixel_count();
  ImageF out(mosaic.width(), mosaic.height(), 3, uninitialized, mosaic.unit());
  if (n == 0) return out;
  Buffer in(ctx, n * sizeof(float)), res(ctx, 3 * n * sizeof(float));
  BufferCache planes(ctx);
  const ScratchBuffers scratch = [&](const std::string& name, size_t bytes) -> Buffer& {
    return planes.get(name, bytes);
  };
  in.upload(mosaic.data(), n * sizeof(float));
  const DemosaicParams p{static_cast<uint32_t>(mosaic.width()), static_cast<uint32_t>(mosaic.height()),
                         pack_cfa(pattern), planes_mode(pattern), 0.f};
  Sequence s(ctx);
  record_demosaic(ctx, s, method, p, in, res, scratch, "demosaic");
  s.submit_and_wait();
  if (device_ms) *device_ms = s.device_ms();
  res.download(out.data(), 3 * n * sizeof(float));
  return out;
}

}  // namespace photosite::gpu
