#include <fmt/format.h>

#include <algorithm>
#include <climits>
#include <cstring>

#include "kernels.h"
#include "photosite/backend.h"
#include "photosite/error.h"
#include "photosite/gpu/sensor.h"
#include "photosite/gpu/stages.h"
#include "photosite/rng.h"

namespace photosite::gpu {

SensorChain::SensorChain(Context& ctx) : ctx_(ctx), buffers_(ctx), seq_(std::make_unique<Sequence>(ctx)) {}
SensorChain::~SensorChain() = default;

Buffer& SensorChain::buffer(const std::string& name, size_t bytes) { return buffers_.get(name, bytes); }

void SensorChain::record_photon(Sequence& s, const ImageF& radiance, const CameraPreset& p,
                                const LensPreset& lens, const ResolvedExposure& ex, Buffer* radiance_on_device) {
  detail::check_radiance_shape(radiance);
  const int w = radiance.width(), h = radiance.height();
  const size_t n = static_cast<size_t>(w) * h;
  if (radiance_on_device && radiance_on_device->bytes() < n * 3 * sizeof(float))
    internal_error("gpu::SensorChain: the resident radiance buffer is smaller than the image");
  Buffer& rad = radiance_on_device ? *radiance_on_device : buffer("radiance", n * 3 * sizeof(float));
  if (!radiance_on_device) rad.upload(radiance.data(), n * 3 * sizeof(float));
  const PhotonMatrix m = photon_matrix(p, lens, ex);
  Buffer& mat = buffer("photon_matrix", 12 * sizeof(double));
  double rows[12];
  for (int c = 0; c < 4; ++c) std::memcpy(rows + 3 * c, m[c].data(), 3 * sizeof(double));
  mat.upload(rows, sizeof(rows));
  Buffer& bad = buffer("bad", sizeof(uint32_t));
  bad.store(UINT32_MAX);
  // The lens's veiling glare (sensor/glare.h): the pyramid on the device, its last upsample and
  // mix inside the photon kernel.
  const GlarePlan plan = lens_glare_plan(p, lens);
  const bool glare = plan.active && record_glare(s, rad, w, h, plan);
  PhotonParams pp{static_cast<uint32_t>(w), static_cast<uint32_t>(h), pack_cfa(p.cfa), glare ? 1u : 0u,
                  lens.cos4_falloff ? p.pixel_pitch_um * 1e-3 / lens.focal_length_mm : 0.0,
                  0.5 * (w - 1), 0.5 * (h - 1), plan.keep, 0};
  Kernel& k = ctx_.kernel("photon", 6, sizeof(PhotonParams));
  const Grid g = grid_1d(n);
  Buffer& acc1 = glare ? buffer("glare_acc1", glare_bytes(w, h, 1)) : buffer("glare_absent", 16);
  Buffer& scale = glare ? buffer("glare_scale", 4 * sizeof(float)) : buffer("glare_absent", 16);
  s.dispatch(k, {&rad, &mat, &buffer("mean_e", n * sizeof(float)), &bad, &acc1, &scale}, pp, g.x, g.y, 1, "photon");
}

size_t SensorChain::glare_bytes(int w, int h, int level) {
  return 3 * sizeof(float) * static_cast<size_t>(glare_level_size(w, level)) * glare_level_size(h, level);
}

// The glare pyramid of sensor/glare.cpp glare_skirt(), kernel for kernel: level 1 by the 2x2
// box, coarser levels by (1,3,3,1)/8 rows then columns; coarse to fine, the row blur then
// glare_up (column blur, weight, + the upsampled coarser accumulator); the energies and scale.
// Leaves acc_1 in "glare_acc1" and s_c in "glare_scale".
bool SensorChain::record_glare(Sequence& s, Buffer& rad, int w, int h, const GlarePlan& plan) {
  const auto taps = glare_blur_taps();
  auto params = [&](int sw, int sh, int dw, int dh, int mode, int flags, float weight) {
    GlareParams gp{};
    gp.src_w = sw, gp.src_h = sh, gp.dst_w = dw, gp.dst_h = dh, gp.mode = mode, gp.flags = flags;
    gp.weight = weight;
    for (int k = 0; k <= kGlareBlurRadius; ++k) gp.taps[k] = taps[k];
    gp.eta = plan.eta;
    return gp;
  };
  auto level = [&](int l) -> Buffer& { return buffer(fmt::format("glare_level{}", l), glare_bytes(w, h, l)); };
  auto acc = [&](int l) -> Buffer& {
    return l == 1 ? buffer("glare_acc1", glare_bytes(w, h, 1)) : buffer(fmt::format("glare_acc{}", l), glare_bytes(w, h, l));
  };
  auto W = [&](int l) { return glare_level_size(w, l); };
  auto H = [&](int l) { return glare_level_size(h, l); };
  Buffer& tmp = buffer("glare_tmp", glare_bytes(w, h, 1));
  Kernel& down = ctx_.kernel("glare_down", 2, sizeof(GlareParams));
  Kernel& blur = ctx_.kernel("glare_blur", 2, sizeof(GlareParams));
  Kernel& up = ctx_.kernel("glare_up", 3, sizeof(GlareParams));
  Kernel& norm = ctx_.kernel("glare_norm", 4, sizeof(GlareParams));
  auto grid = [](int a, int b) { return grid_1d(static_cast<uint64_t>(a) * b); };
  Grid g = grid(W(1), H(1));
  s.dispatch(down, {&rad, &level(1)}, params(w, h, W(1), H(1), 0, 0, 0.f), g.x, g.y, 1, "glare down");
  for (int l = 2; l <= plan.hi; ++l) {
    g = grid(W(l), H(l - 1));
    s.dispatch(down, {&level(l - 1), &tmp}, params(W(l - 1), H(l - 1), W(l), H(l - 1), 1, 0, 0.f), g.x, g.y, 1,
               "glare down");
    g = grid(W(l), H(l));
    s.dispatch(down, {&tmp, &level(l)}, params(W(l), H(l - 1), W(l), H(l), 2, 0, 0.f), g.x, g.y, 1, "glare down");
  }
  for (int l = plan.hi; l >= 1; --l) {
    const bool blurred = l >= plan.lo, coarser = l < plan.hi;
    g = grid(W(l), H(l));
    if (blurred)
      s.dispatch(blur, {&level(l), &tmp}, params(W(l), H(l), W(l), H(l), 0, 0, 0.f), g.x, g.y, 1, "glare blur");
    Buffer& coarse = coarser ? acc(l + 1) : buffer("glare_absent", 16);
    const int flags = (blurred ? 1 : 0) | (coarser ? 2 : 0);
    const float weight = blurred ? plan.weight[l - plan.lo] : 0.f;
    s.dispatch(up, {blurred ? &tmp : &buffer("glare_absent", 16), &coarse, &acc(l)},
               params(coarser ? W(l + 1) : 1, coarser ? H(l + 1) : 1, W(l), H(l), 0, flags, weight), g.x, g.y, 1,
               "glare up");
  }
  Buffer& rows = buffer("glare_rows", 2 * 3 * sizeof(double) * static_cast<size_t>(H(1)));
  Buffer& scale = buffer("glare_scale", 4 * sizeof(float));
  const Grid gr = grid_1d(2 * static_cast<uint64_t>(H(1)), 64);
  s.dispatch(norm, {&level(1), &acc(1), &rows, &scale}, params(w, h, W(1), H(1), 0, 0, 0.f), gr.x, gr.y, 1,
             "glare norm");
  s.dispatch(norm, {&level(1), &acc(1), &rows, &scale}, params(w, h, W(1), H(1), 1, 0, 0.f), 1, 1, 1, "glare norm");
  return true;
}

void SensorChain::record_sense(Sequence& s, int w, int h, const CameraPreset& p, const ResolvedExposure& ex,
                               const ExposureSettings& st, const FixedPatternMaps& fpn) {
  detail::check_sense_inputs(w, h, p, fpn);
  if (!vulkan_runs_camera(p))  // the same test as auto's choice (choose_auto)
    fail_parameter("backend",
                   fmt::format("the Vulkan backend has no Tukey-lambda read noise yet (preset '{}', lambda {}); use ",
                               p.name, p.read_noise_tukey_lambda),
                   " cpu");
  const size_t n = static_cast<size_t>(w) * h;
  // Fixed-pattern maps: uploaded once per device, kept for every later frame.
  const std::string fpn_id = fmt::format("{}|{}|{}x{}", fpn.device_id, fpn.checksum, w, h);
  uint32_t flags = 0;
  auto map = [&](const char* name, const ImageF& img, uint32_t flag) -> Buffer& {
    if (img.empty()) return buffer(std::string(name) + "_absent", 4);
    flags |= flag;
    Buffer& b = buffer(name, n * sizeof(float));
    if (fpn_loaded_ != fpn_id || fpn.checksum.empty()) b.upload(img.data(), n * sizeof(float));
    return b;
  };
  Buffer& prnu = map("prnu", fpn.prnu_gain, kHasPrnu);
  Buffer& dsnu = map("dsnu", fpn.dsnu_offset_e, kHasDsnu);
  Buffer& dark = map("dark_rate", fpn.dark_rate_factor, kHasDarkRate);
  fpn_loaded_ = fpn_id;
  const uint64_t key = detail::temporal_key(fpn.device_seed, st.seed);
  std::vector<float> row_e, col_e;
  detail::row_column_noise(p, key, st.frame, w, h, row_e, col_e);
  Buffer& row = buffer("row_e", std::max<size_t>(4, row_e.size() * sizeof(float)));
  Buffer& col = buffer("col_e", std::max<size_t>(4, col_e.size() * sizeof(float)));
  if (!row_e.empty()) row.upload(row_e.data(), row_e.size() * sizeof(float)), flags |= kHasRowNoise;
  if (!col_e.empty()) col.upload(col_e.data(), col_e.size() * sizeof(float)), flags |= kHasColumnNoise;
  SenseParams sp{};
  sp.width = static_cast<uint32_t>(w);
  sp.height = static_cast<uint32_t>(h);
  sp.frame = st.frame;
  sp.stream = static_cast<uint32_t>(Stream::PhotonShot);
  sp.key = U64::of(key);
  sp.flags = flags | static_cast<uint32_t>(st.poisson) << kSensePoissonShift;
  sp.dark_mean_e = static_cast<float>(ex.dark_current_e_per_s * ex.exposure_s);
  sp.full_well_e = static_cast<float>(p.full_well_e);
  sp.read_noise_e = static_cast<float>(p.read_noise_e);
  sp.gain_dn_per_e = ex.system_gain_dn_per_e;
  sp.black_dn = p.black_level_dn;
  sp.max_code = std::ldexp(1.0, p.bit_depth) - 1.0;
  Kernel& k = ctx_.kernel("sense", 8, sizeof(SenseParams));
  const Grid g = grid_1d(n);
  Buffer& electrons = buffer("electrons", n * sizeof(float));
  Buffer& raw = buffer("raw_dn", n * sizeof(float));
  s.dispatch(k, {&buffer("mean_e", n * sizeof(float)), &prnu, &dsnu, &dark, &row, &col, &electrons, &raw}, sp,
             g.x, g.y, 1, "sense");
  if (has_demosaic_kernel(st.demosaic)) {
    DemosaicParams dp{static_cast<uint32_t>(w), static_cast<uint32_t>(h), pack_cfa(p.cfa), planes_mode(p.cfa),
                      static_cast<float>(p.black_level_dn)};
    record_demosaic(ctx_, s, st.demosaic, dp, raw, buffer("rgb", n * 3 * sizeof(float)),
                    [this](const std::string& name, size_t bytes) -> Buffer& { return buffer(name, bytes); },
                    "demosaic");
  }
}

SensorOutput SensorChain::finish(int w, int h, const CameraPreset& p, const ResolvedExposure& ex,
                                 const ExposureSettings& st) {
  const size_t n = static_cast<size_t>(w) * h;
  SensorOutput out;
  out.electrons = ImageF(w, h, 1, uninitialized, unit::electrons);
  out.raw_dn = ImageF(w, h, 1, uninitialized, unit::dn);
  buffer("electrons", n * sizeof(float)).download(out.electrons.data(), n * sizeof(float));
  buffer("raw_dn", n * sizeof(float)).download(out.raw_dn.data(), n * sizeof(float));
  if (has_demosaic_kernel(st.demosaic)) {
    out.rgb = ImageF(w, h, 3, uninitialized, unit::dn);
    buffer("rgb", n * 3 * sizeof(float)).download(out.rgb.data(), n * 3 * sizeof(float));
  } else {  // other methods run on the CPU, on the downloaded mosaic (as sense() does)
    ImageF above_black(w, h, 1, uninitialized, unit::dn);
    const float blk = static_cast<float>(p.black_level_dn);
    for (size_t i = 0; i < n; ++i) above_black[i] = out.raw_dn[i] - blk;
    out.rgb = demosaic(above_black, p.cfa, st.demosaic);
    out.rgb.set_unit(unit::dn);
  }
  neutralize_clipped_highlights(out, p, ex);
  return out;
}

static void check_bad(Buffer& bad, const ImageF& radiance) {
  const uint32_t i = bad.load<uint32_t>();
  if (i == UINT32_MAX) return;
  detail::fail_bad_radiance(radiance, static_cast<int>(i % radiance.width()), static_cast<int>(i / radiance.width()));
}

ImageF SensorChain::mean_signal_electrons(const ImageF& radiance, const CameraPreset& p, const LensPreset& lens,
                                          const ResolvedExposure& ex, Buffer* radiance_on_device) {
  mean_e_token_ = {};
  seq_->begin();
  record_photon(*seq_, radiance, p, lens, ex, radiance_on_device);
  seq_->submit_and_wait();
  times_ = seq_->stage_times();
  check_bad(buffer("bad", sizeof(uint32_t)), radiance);
  const size_t n = radiance.pixel_count();
  ImageF out(radiance.width(), radiance.height(), 1, uninitialized, unit::electrons);
  buffer("mean_e", n * sizeof(float)).download(out.data(), n * sizeof(float));
  mean_e_token_ = DeviceImage::issue();
  return out;
}

SensorOutput SensorChain::sense(const ImageF& mean_e, const CameraPreset& p, const ResolvedExposure& ex,
                                const ExposureSettings& st, const FixedPatternMaps& fpn, DeviceImage mean_e_token) {
  const int w = mean_e.width(), h = mean_e.height();
  const size_t n = mean_e.pixel_count();
  seq_->begin();
  const Buffer* held = buffers_.find("mean_e");
  const bool resident = mean_e_token && mean_e_token == mean_e_token_ && held &&
                        held->bytes() == n * sizeof(float);
  if (!resident && w >= 1 && h >= 1) {
    mean_e_token_ = {};
    buffer("mean_e", n * sizeof(float)).upload(mean_e.data(), n * sizeof(float));
  }
  record_sense(*seq_, w, h, p, ex, st, fpn);
  seq_->submit_and_wait();
  times_ = seq_->stage_times();
  return finish(w, h, p, ex, st);
}

SensorOutput SensorChain::expose(const ImageF& radiance, const CameraPreset& p, const LensPreset& lens,
                                 const ExposureSettings& st, const FixedPatternMaps& fpn,
                                 Buffer* radiance_on_device) {
  const ResolvedExposure ex = resolve(p, lens, st);
  mean_e_token_ = {};
  seq_->begin();
  record_photon(*seq_, radiance, p, lens, ex, radiance_on_device);
  record_sense(*seq_, radiance.width(), radiance.height(), p, ex, st, fpn);
  seq_->submit_and_wait();
  times_ = seq_->stage_times();
  check_bad(buffer("bad", sizeof(uint32_t)), radiance);
  return finish(radiance.width(), radiance.height(), p, ex, st);
}

}  // namespace photosite::gpu
