// A handle on an image a backend still holds on its device (Vulkan), given out with the host copy
// by the stage that left it there: a later stage of the same SensorRunner handed it reads the
// device buffer instead of uploading the host copy again. Empty on the CPU. Whoever overwrites
// the buffer forgets the handle, so a stale one costs an upload, never a wrong image. Handles are
// never reused within a process; they only compare equal to copies of themselves.
#pragma once
#include <cstdint>

namespace photosite {

class DeviceImage {
 public:
  DeviceImage() = default;  // empty: no image promised
  // A handle never given before in this process (thread-safe).
  static DeviceImage issue();
  explicit operator bool() const { return id_ != 0; }
  bool operator==(const DeviceImage&) const = default;

 private:
  explicit DeviceImage(uint64_t id) : id_(id) {}
  uint64_t id_ = 0;
};

}  // namespace photosite
