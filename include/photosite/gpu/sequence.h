// The host layer, part 3: a sequence of dispatches recorded into one command buffer, with a
// compute-to-compute barrier between dispatches and one submit-and-wait, so a frame's stages run
// back to back on the device over buffers that stay there.
#pragma once
#include <initializer_list>
#include <memory>
#include <string>
#include <vector>

#include "photosite/gpu/kernel.h"

namespace photosite::gpu {

class Sequence {
 public:
  explicit Sequence(Context& ctx);
  ~Sequence();
  Sequence(const Sequence&) = delete;
  Sequence& operator=(const Sequence&) = delete;
  // Starts recording (drops what was recorded before).
  void begin();
  // One dispatch of groups_x x groups_y x groups_z work groups; a compute→compute barrier is
  // recorded before it when it follows another dispatch. `label` names it in stage timings.
  void dispatch(const Kernel& k, std::initializer_list<Buffer*> buffers, const void* params,
                uint32_t groups_x, uint32_t groups_y = 1, uint32_t groups_z = 1,
                const std::string& label = {});
  template <class P>
  void dispatch(const Kernel& k, std::initializer_list<Buffer*> buffers, const P& params,
                uint32_t gx, uint32_t gy = 1, uint32_t gz = 1, const std::string& label = {}) {
    static_assert(sizeof(P) <= 128, "push constants beyond Vulkan's guaranteed 128 bytes");
    dispatch(k, buffers, static_cast<const void*>(&params), gx, gy, gz, label);
  }
  // Submits, waits for completion (results visible to the host).
  void submit_and_wait();
  // Device time of each dispatch of the last submit (ms), from timestamps; empty when the
  // device has none. Labels as given to dispatch().
  struct StageTime { std::string label; double ms; };
  std::vector<StageTime> stage_times() const;
  // Their sum (ms), or -1 when the device has no timestamps.
  double device_ms() const;

  struct Impl;

 private:
  Context& ctx_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace photosite::gpu
