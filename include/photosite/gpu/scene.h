// The day-to-night per-pixel stages on the Vulkan backend: per-class darkening and composition
// (glare is the lens's, in the sensor chain: gpu/sensor.h). Geometry stays on the CPU (lane
// markings, Canny, Hough, vanishing point clustering, light placement), as in Baek 2020.
#pragma once
#include <memory>
#include <string>

#include "photosite/gpu/context.h"
#include "photosite/gpu/sequence.h"
#include "photosite/image.h"
#include "photosite/scene/night.h"

namespace photosite::gpu {

// scene::darken() on the device: bit-equal (the same darken_pixel operations).
ImageF darken(Context& ctx, const ImageF& texture, const ImageU16& labels, const scene::ScenePreset& p);
// scene::linearize() on the device: bit-equal (the same table and float operations); a NaN or
// Inf pixel is refused with the CPU path's message.
ImageF linearize(Context& ctx, const ImageF& day, const ImageFileInfo& info, double* device_ms = nullptr);
// scene::compose() on the device (darken, then low beam + lights), `depth` being the low beam's
// illuminance image (scene::low_beam_illuminance, lx): bit-equal (tests/gpu_test.cpp).
ImageF compose(Context& ctx, const ImageF& texture, const ImageF& lights, const ImageU16& labels,
               const ImageF& depth, const scene::ScenePreset& p, double* device_ms = nullptr);
// device_ms: the kernels' device time (timestamps), -1 without them.

// Recording into a caller's sequence (for chains that keep images on the device).
void record_darken(Context& ctx, Sequence& s, Buffer& texture, Buffer& labels, Buffer& out, size_t n,
                   const scene::DarkenParams& d);

// The scene stages with their device buffers kept from one call to the next (a batch or a run of
// frames of one size allocates them once). Not thread-safe: one per thread of work.
class SceneStages {
 public:
  explicit SceneStages(Context& ctx);
  ~SceneStages();
  ImageF darken(const ImageF& texture, const ImageU16& labels, const scene::ScenePreset& p);
  ImageF compose(const ImageF& texture, const ImageF& lights, const ImageU16& labels, const ImageF& depth,
                 const scene::ScenePreset& p, double* device_ms = nullptr);
  // night_scene()'s whole per-pixel tail as one sequence: darken (into `darkened` too with
  // keep_darkened), low beam + lights. Uploads the texture, light map, labels and depth once
  // each; downloads the radiance, which also stays
  // on the device under the returned token (resident_radiance).
  scene::PixelTail tail(const ImageF& texture, ImageF& lights, const ImageU16& labels, const ImageF& depth,
                        const scene::ScenePreset& p, bool keep_darkened, double* device_ms = nullptr);
  // The device buffer holding the radiance of the tail() that gave `token`, or nullptr when
  // the token is 0 or stale (a later call has overwritten the buffer).
  Buffer* resident_radiance(DeviceImage image);
  // Large staged copies of these stages' buffers from (to) the host's imported pages
  // (Buffer::set_host_import).
  void set_host_import(bool on) { buffers_.set_host_import(on); }

 private:
  Buffer& buffer(const std::string& name, size_t bytes);
  Buffer& upload_labels(const ImageU16& labels);
  // The inputs of compose and tail (shapes already checked) uploaded; the radiance buffer they
  // write, its token dropped.
  struct TailBuffers { Buffer *texture, *lights, *depth, *radiance, *labels; };
  TailBuffers upload_tail(const ImageF& texture, const ImageF& lights, const ImageU16& labels,
                          const ImageF& depth);
  void record_compose(Sequence& s, Buffer& texture, Buffer& lights, Buffer& labels, Buffer& depth, Buffer& out,
                      int w, int h, const scene::ScenePreset& p);
  Context& ctx_;
  BufferCache buffers_;
  DeviceImage radiance_token_;  // what buffer "radiance" holds; empty: nothing promised
};

}  // namespace photosite::gpu
