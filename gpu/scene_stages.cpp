#include <array>
#include <cmath>
#include <cstring>
#include <fmt/format.h>
#include <vector>

#include "kernels.h"
#include "photosite/error.h"
#include "photosite/gpu/scene.h"

namespace photosite::gpu {

namespace {
// scene::DarkenParams::ground_class as the kernels read it: bit id set for a ground class.
U64 ground_mask(const scene::DarkenParams& d) {
  static_assert(scene::kLabelCount <= 64, "ground classes travel as a 64-bit mask");
  uint64_t mask = 0;
  for (int id = 0; id < scene::kLabelCount; ++id)
    if (d.ground_class[id]) mask |= uint64_t{1} << id;
  return U64::of(mask);
}
}  // namespace

void record_darken(Context& ctx, Sequence& s, Buffer& texture, Buffer& labels, Buffer& out, size_t n,
                   const scene::DarkenParams& d) {
  DarkenParams p{};
  for (int k = 0; k < 3; ++k) {
    p.ground[k] = d.ground[k];
    p.vertical[k] = d.vertical[k];
    p.K[k] = d.K[k];
    p.glow[k] = d.glow[k];
  }
  p.rho_sky = d.rho_sky;
  p.ground_mask = ground_mask(d);
  p.n = static_cast<uint32_t>(n);
  p.sky_id = static_cast<uint32_t>(scene::Label::Sky);
  const Grid g = grid_1d(n);
  s.dispatch(ctx.kernel("darken", 3, sizeof(DarkenParams)), {&texture, &labels, &out}, p, g.x, g.y, 1, "darken");
}

struct BloomBuffers {
  int w = 0, h = 0, levels = 0;
  std::vector<std::pair<int, int>> size;           // per level (0 = the image)
  std::vector<std::unique_ptr<Buffer>> mip, tmp, acc;
};
void BloomBuffersDeleter::operator()(BloomBuffers* b) const { delete b; }

namespace {
// cv::getGaussianKernel(13, 1.5, CV_32F): exp(−x²/2σ²) in double, normalised, then float;
// w[0] the centre tap.
std::array<float, 7> gaussian_taps(double sigma) {
  std::array<double, 13> k;
  double sum = 0;
  for (int i = 0; i < 13; ++i) sum += k[i] = std::exp(-0.5 / (sigma * sigma) * (i - 6) * (i - 6));
  std::array<float, 7> w;
  for (int i = 0; i < 7; ++i) w[i] = static_cast<float>(k[6 + i] / sum);
  return w;
}
}  // namespace

bool record_bloom(Context& ctx, Sequence& s, Buffer& img, int W, int H, double fraction, int levels,
                  BloomCache& cache) {
  if (fraction <= 0 || levels <= 0 || W < 4 || H < 4) return false;
  if (!cache || cache->w != W || cache->h != H || cache->levels != levels) {
    cache = BloomCache(new BloomBuffers);
    cache->w = W, cache->h = H, cache->levels = levels;
    cache->size.push_back({W, H});
    cache->mip.emplace_back(nullptr);
    cache->tmp.emplace_back(nullptr);
    cache->acc.emplace_back(nullptr);
    // The chain of bloom_in_place: stop before a level narrower or shorter than 4 is made from.
    for (int l = 1; l <= levels; ++l) {
      const auto [tw, th] = cache->size.back();
      if (tw < 4 || th < 4) break;
      const int w = (tw + 1) / 2, h = (th + 1) / 2;
      cache->size.push_back({w, h});
      const size_t bytes = 3 * sizeof(float) * static_cast<size_t>(w) * h;
      cache->mip.push_back(std::make_unique<Buffer>(ctx, bytes));
      cache->tmp.push_back(std::make_unique<Buffer>(ctx, bytes));
      cache->acc.push_back(std::make_unique<Buffer>(ctx, bytes));
    }
  }
  BloomBuffers& B = *cache;
  const int used = static_cast<int>(B.size.size()) - 1;
  if (used == 0) return false;
  Kernel& down = ctx.kernel("bloom_down", 2, sizeof(BloomParams));
  Kernel& blur = ctx.kernel("bloom_blur", 2, sizeof(BloomParams));
  Kernel& up = ctx.kernel("bloom_up", 2, sizeof(BloomParams));
  Kernel& mix = ctx.kernel("bloom_mix", 2, sizeof(BloomParams));
  const auto taps = gaussian_taps(1.5);
  auto params = [&](int src, int dst, int mode) {
    BloomParams p{};
    p.src_w = B.size[src].first, p.src_h = B.size[src].second;
    p.dst_w = B.size[dst].first, p.dst_h = B.size[dst].second;
    p.mode = mode;
    std::memcpy(p.weights, taps.data(), sizeof(p.weights));
    return p;
  };
  auto pixels = [&](int l) { return static_cast<uint64_t>(B.size[l].first) * B.size[l].second; };
  for (int l = 1; l <= used; ++l) {
    const Grid g = grid_1d(pixels(l));
    s.dispatch(down, {l == 1 ? &img : B.mip[l - 1].get(), B.mip[l].get()}, params(l - 1, l, l == 1 ? 0 : 1), g.x, g.y,
               1, "bloom down");
  }
  // Coarse to fine: acc_l = blur(mip_l) + up(acc_{l+1}).
  for (int l = used; l >= 1; --l) {
    const Grid g = grid_1d(pixels(l));
    s.dispatch(blur, {B.mip[l].get(), B.tmp[l].get()}, params(l, l, 0), g.x, g.y, 1, "bloom blur");
    s.dispatch(blur, {B.tmp[l].get(), B.acc[l].get()}, params(l, l, 1), g.x, g.y, 1, "bloom blur");
    if (l < used) s.dispatch(up, {B.acc[l + 1].get(), B.acc[l].get()}, params(l + 1, l, 0), g.x, g.y, 1, "bloom up");
  }
  BloomParams mp = params(1, 0, 0);
  mp.a = static_cast<float>(1.0 - fraction);
  mp.b = static_cast<float>(fraction / used);
  const Grid g = grid_1d(pixels(0));
  s.dispatch(mix, {B.acc[1].get(), &img}, mp, g.x, g.y, 1, "bloom mix");
  return true;
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

void SceneStages::bloom_in_place(ImageF& img, double fraction, int levels) {
  if (img.channels() != 3) fail("bloom: the image must have 3 channels");
  if (fraction <= 0 || levels <= 0 || img.width() < 4 || img.height() < 4) return;
  const size_t bytes = img.size() * sizeof(float);
  Buffer& b = buffer("lights", bytes);
  b.upload(img.data(), bytes);
  Sequence s(ctx_);
  record_bloom(ctx_, s, b, img.width(), img.height(), fraction, levels, bloom_);
  s.submit_and_wait();
  b.download(img.data(), bytes);
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
                                 const scene::VanishingPoint& vp, const scene::ScenePreset& sp) {
  const size_t n = static_cast<size_t>(W) * H;
  const scene::DarkenParams dp = scene::darken_params(sp);
  record_darken(ctx_, s, t, ids, o, n, dp);
  ComposeParams cp{};
  cp.width = static_cast<uint32_t>(W), cp.height = static_cast<uint32_t>(H);
  cp.ground_mask = ground_mask(dp);
  cp.vp_y = vp.y;
  cp.beam_half_width = sp.beam_half_width;
  cp.beam_road_lux = sp.beam_road_lux;
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
  radiance_token_ = 0;  // the radiance buffer is about to be overwritten
  b.texture->upload(texture.data(), rgb_bytes);
  b.lights->upload(lights.data(), rgb_bytes);
  b.depth->upload(depth.data(), n * sizeof(float));
  b.labels = &upload_labels(labels);
  return b;
}

ImageF SceneStages::compose(const ImageF& texture, const ImageF& lights, const ImageU16& labels, const ImageF& depth,
                            const scene::VanishingPoint& vp, const scene::ScenePreset& sp, double* device_ms) {
  check_tail_shapes("compose", texture, lights, labels, depth);
  ImageF out(texture.width(), texture.height(), 3, uninitialized, unit::radiance);
  if (texture.pixel_count() == 0) return out;
  const TailBuffers b = upload_tail(texture, lights, labels, depth);
  Sequence s(ctx_);
  record_compose(s, *b.texture, *b.lights, *b.labels, *b.depth, *b.radiance, texture.width(), texture.height(), vp, sp);
  s.submit_and_wait();
  if (device_ms) *device_ms = s.device_ms();
  b.radiance->download(out.data(), out.size() * sizeof(float));
  return out;
}

scene::PixelTail SceneStages::tail(const ImageF& texture, ImageF& lights, const ImageU16& labels,
                                   const ImageF& depth, const scene::VanishingPoint& vp,
                                   const scene::ScenePreset& sp, bool keep_darkened, double* device_ms) {
  check_tail_shapes("night tail", texture, lights, labels, depth);
  const int W = texture.width(), H = texture.height();
  const size_t n = texture.pixel_count(), rgb_bytes = 3 * n * sizeof(float);
  scene::PixelTail out;
  out.radiance = ImageF(W, H, 3, uninitialized, unit::radiance);
  if (keep_darkened) out.darkened = ImageF(W, H, 3, uninitialized, unit::radiance);
  if (n == 0) return out;
  const TailBuffers b = upload_tail(texture, lights, labels, depth);
  Sequence s(ctx_);
  const bool bloomed = record_bloom(ctx_, s, *b.lights, W, H, sp.bloom_fraction, sp.bloom_levels, bloom_);
  // The darkened image for --maps: darken once more into its own buffer (compose darkens in place).
  if (keep_darkened)
    record_darken(ctx_, s, *b.texture, *b.labels, buffer("darkened", rgb_bytes), n, scene::darken_params(sp));
  record_compose(s, *b.texture, *b.lights, *b.labels, *b.depth, *b.radiance, W, H, vp, sp);
  s.submit_and_wait();
  if (device_ms) *device_ms = s.device_ms();
  if (bloomed) b.lights->download(lights.data(), rgb_bytes);
  if (keep_darkened) buffer("darkened", rgb_bytes).download(out.darkened.data(), rgb_bytes);
  b.radiance->download(out.radiance.data(), rgb_bytes);
  out.resident = radiance_token_ = new_residency_token();
  return out;
}

Buffer* SceneStages::resident_radiance(uint64_t token) {
  if (token == 0 || token != radiance_token_) return nullptr;
  return buffers_.find("radiance");
}

ImageF darken(Context& ctx, const ImageF& texture, const ImageU16& labels, const scene::ScenePreset& p) {
  return SceneStages(ctx).darken(texture, labels, p);
}
void bloom_in_place(Context& ctx, ImageF& img, double fraction, int levels) {
  SceneStages(ctx).bloom_in_place(img, fraction, levels);
}
ImageF compose(Context& ctx, const ImageF& texture, const ImageF& lights, const ImageU16& labels,
               const ImageF& depth, const scene::VanishingPoint& vp, const scene::ScenePreset& p,
               double* device_ms) {
  return SceneStages(ctx).compose(texture, lights, labels, depth, vp, p, device_ms);
}

scene::PixelStages pixel_stages(std::shared_ptr<SceneStages> stages) {
  scene::PixelStages st;
  st.tail = [stages](const ImageF& t, ImageF& lights, const ImageU16& ids, const ImageF& d,
                     const scene::VanishingPoint& vp, const scene::ScenePreset& p, bool keep_darkened) {
    return stages->tail(t, lights, ids, d, vp, p, keep_darkened);
  };
  return st;
}

}  // namespace photosite::gpu
