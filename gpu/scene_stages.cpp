#include <array>
#include <cmath>
#include <cstring>
#include <fmt/format.h>
#include <vector>

#include "kernels.h"
#include "photosite/error.h"
#include "photosite/gpu/scene.h"

namespace photosite::gpu {

static_assert(scene::kLabelCount <= 64, "the beam's classes travel as a 64-bit mask");

void record_darken(Context& ctx, Sequence& s, Buffer& texture, Buffer& labels, Buffer& out, size_t n,
                   const scene::DarkenParams& d) {
  DarkenParams p{};
  for (int k = 0; k < 3; ++k) {
    p.ambient[k] = d.ambient[k];
    p.K[k] = d.K[k];
    p.glow[k] = d.glow[k];
  }
  p.rho_sky = d.rho_sky;
  p.n = static_cast<uint32_t>(n);
  p.sky_id = static_cast<uint32_t>(scene::Label::Sky);
  const Grid g = grid_1d(n);
  s.dispatch(ctx.kernel("darken", 3, sizeof(DarkenParams)), {&texture, &labels, &out}, p, g.x, g.y, 1, "darken");
}

ImageF linearize(Context& ctx, const ImageF& day, const ImageFileInfo& info, double* device_ms) {
  const int c = day.channels();
  if (c < 1 || c > 4) fail(fmt::format("linearize: {} channels (1 to 4 expected)", c));
  const size_t n = day.pixel_count();
  ImageF out(day.width(), day.height(), 3, uninitialized, "linear sRGB");
  if (n == 0) return out;
  const Grid g = grid_1d(n);  // refuses a frame beyond the kernels' index before allocating
  const std::vector<float>& lut = scene::srgb_decode_table();
  Buffer in(ctx, day.size() * sizeof(float)), table(ctx, lut.size() * sizeof(float)),
      o(ctx, 3 * n * sizeof(float)), bad(ctx, sizeof(uint32_t));
  in.upload(day.data(), day.size() * sizeof(float));
  table.upload(lut.data(), lut.size() * sizeof(float));
  bad.store(UINT32_MAX);
  LinearizeParams p{static_cast<uint32_t>(n), static_cast<uint32_t>(c), info.is_float ? 0u : 1u, 0};
  Sequence s(ctx);
  s.dispatch(ctx.kernel("linearize", 4, sizeof(LinearizeParams)), {&in, &table, &o, &bad}, p, g.x, g.y, 1,
             "linearize");
  s.submit_and_wait();
  if (device_ms) *device_ms = s.device_ms();
  const uint32_t first_bad = bad.load<uint32_t>();
  if (first_bad != UINT32_MAX) scene::fail_damaged_pixel(day, info, first_bad);
  o.download(out.data(), 3 * n * sizeof(float));
  return out;
}

SceneStages::SceneStages(Context& ctx) : ctx_(ctx), buffers_(ctx) {}
SceneStages::~SceneStages() = default;

Buffer& SceneStages::buffer(const std::string& name, size_t bytes) { return buffers_.get(name, bytes); }

// uint16 labels as the kernels read them: two per 32-bit word.
Buffer& SceneStages::upload_labels(const ImageU16& labels) {
  const size_t n = labels.pixel_count();
  Buffer& b = buffer("labels", std::max<size_t>(4, ((n + 1) / 2) * sizeof(uint32_t)));
  b.upload(labels.data(), n * sizeof(uint16_t));
  return b;
}

ImageF SceneStages::darken(const ImageF& texture, const ImageU16& labels, const scene::ScenePreset& sp) {
  if (texture.channels() != 3 || !labels.same_shape(texture)) fail("darken: texture and labels differ in size");
  const size_t n = texture.pixel_count();
  ImageF out(texture.width(), texture.height(), 3, uninitialized, unit::radiance);
  if (n == 0) return out;
  Buffer& t = buffer("texture", 3 * n * sizeof(float));
  Buffer& o = buffer("darkened", 3 * n * sizeof(float));
  t.upload(texture.data(), 3 * n * sizeof(float));
  Buffer& l = upload_labels(labels);
  Sequence s(ctx_);
  record_darken(ctx_, s, t, l, o, n, scene::darken_params(sp));
  s.submit_and_wait();
  o.download(out.data(), 3 * n * sizeof(float));
  return out;
}

namespace {
void check_tail_shapes(const char* what, const ImageF& texture, const ImageF& lights, const ImageU16& labels,
                       const ImageF& depth) {
  const int W = texture.width(), H = texture.height();
  if (texture.channels() != 3 || lights.channels() != 3 || !lights.same_shape(texture) || labels.width() != W ||
      labels.height() != H || depth.width() != W || depth.height() != H || depth.channels() != 1)
    fail(fmt::format("{}: texture, lights, labels and depth differ in size", what));
  (void)grid_1d(texture.pixel_count());  // refuses a frame beyond the kernels' index before allocating
}
}  // namespace

void SceneStages::record_compose(Sequence& s, Buffer& t, Buffer& l, Buffer& ids, Buffer& d, Buffer& o, int W, int H,
                                 const scene::ScenePreset& sp) {
  const size_t n = static_cast<size_t>(W) * H;
  const scene::DarkenParams dp = scene::darken_params(sp);
  record_darken(ctx_, s, t, ids, o, n, dp);
  ComposeParams cp{};
  cp.width = static_cast<uint32_t>(W), cp.height = static_cast<uint32_t>(H);
  cp.beam_mask = U64::of(scene::beam_lit_class_bits());
  // The CPU's tint / π (scene::compose): the beam's colour relative to D65.
  const auto tb = scene::illuminant_tint(sp.beam_cct_K);
  for (int k = 0; k < 3; ++k) cp.tint_over_pi[k] = static_cast<float>(tb[k] / M_PI);
  const Grid g = grid_1d(n);
  s.dispatch(ctx_.kernel("compose", 5, sizeof(ComposeParams)), {&t, &l, &ids, &d, &o}, cp, g.x, g.y, 1, "compose");
}

SceneStages::TailBuffers SceneStages::upload_tail(const ImageF& texture, const ImageF& lights,
                                                  const ImageU16& labels, const ImageF& depth) {
  const size_t n = texture.pixel_count(), rgb_bytes = 3 * n * sizeof(float);
  TailBuffers b{&buffer("texture", rgb_bytes), &buffer("lights", rgb_bytes), &buffer("depth", n * sizeof(float)),
                &buffer("radiance", rgb_bytes), nullptr};
  radiance_token_ = {};  // the radiance buffer is about to be overwritten
  b.texture->upload(texture.data(), rgb_bytes);
  b.lights->upload(lights.data(), rgb_bytes);
  b.depth->upload(depth.data(), n * sizeof(float));
  b.labels = &upload_labels(labels);
  return b;
}

ImageF SceneStages::compose(const ImageF& texture, const ImageF& lights, const ImageU16& labels, const ImageF& depth,
                            const scene::ScenePreset& sp, double* device_ms) {
  check_tail_shapes("compose", texture, lights, labels, depth);
  ImageF out(texture.width(), texture.height(), 3, uninitialized, unit::radiance);
  if (texture.pixel_count() == 0) return out;
  const TailBuffers b = upload_tail(texture, lights, labels, depth);
  Sequence s(ctx_);
  record_compose(s, *b.texture, *b.lights, *b.labels, *b.depth, *b.radiance, texture.width(), texture.height(), sp);
  s.submit_and_wait();
  if (device_ms) *device_ms = s.device_ms();
  b.radiance->download(out.data(), out.size() * sizeof(float));
  return out;
}

scene::PixelTail SceneStages::tail(const ImageF& texture, ImageF& lights, const ImageU16& labels,
                                   const ImageF& depth, const scene::ScenePreset& sp, bool keep_darkened,
                                   double* device_ms) {
  check_tail_shapes("night tail", texture, lights, labels, depth);
  const int W = texture.width(), H = texture.height();
  const size_t n = texture.pixel_count(), rgb_bytes = 3 * n * sizeof(float);
  scene::PixelTail out;
  out.radiance = ImageF(W, H, 3, uninitialized, unit::radiance);
  if (keep_darkened) out.darkened = ImageF(W, H, 3, uninitialized, unit::radiance);
  if (n == 0) return out;
  const TailBuffers b = upload_tail(texture, lights, labels, depth);
  Sequence s(ctx_);
  // The darkened image for --maps: darken once more into its own buffer (compose darkens in place).
  if (keep_darkened)
    record_darken(ctx_, s, *b.texture, *b.labels, buffer("darkened", rgb_bytes), n, scene::darken_params(sp));
  record_compose(s, *b.texture, *b.lights, *b.labels, *b.depth, *b.radiance, W, H, sp);
  s.submit_and_wait();
  if (device_ms) *device_ms = s.device_ms();
  if (keep_darkened) buffer("darkened", rgb_bytes).download(out.darkened.data(), rgb_bytes);
  b.radiance->download(out.radiance.data(), rgb_bytes);
  out.resident = radiance_token_ = DeviceImage::issue();
  return out;
}

Buffer* SceneStages::resident_radiance(DeviceImage image) {
  if (!image || image != radiance_token_) return nullptr;
  return buffers_.find("radiance");
}

ImageF darken(Context& ctx, const ImageF& texture, const ImageU16& labels, const scene::ScenePreset& p) {
  return SceneStages(ctx).darken(texture, labels, p);
}
ImageF compose(Context& ctx, const ImageF& texture, const ImageF& lights, const ImageU16& labels,
               const ImageF& depth, const scene::ScenePreset& p, double* device_ms) {
  return SceneStages(ctx).compose(texture, lights, labels, depth, p, device_ms);
}


}  // namespace photosite::gpu
