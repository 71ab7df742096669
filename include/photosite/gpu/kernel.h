// The host layer, part 2: a compute kernel, a pipeline from embedded SPIR-V. Each kernel's parameters are one plain struct passed as push constants and
// mirrored field for field in its GLSL (kernels/*.comp); static_asserts in gpu/kernels.h pin the
// sizes and offsets of the C++ side to the std430 layout of the GLSL side.
#pragma once
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <memory>
#include <string>
#include <vector>

#include "photosite/gpu/context.h"

namespace photosite::gpu {

class Kernel {
 public:
  // `name` is a kernels/<name>.comp (its SPIR-V is embedded); `buffers` storage buffers at
  // bindings 0..buffers-1; `push_bytes` the size of its parameter struct; local size in x.
  Kernel(Context& ctx, const std::string& name, int buffers, uint32_t push_bytes);
  ~Kernel();
  Kernel(const Kernel&) = delete;
  Kernel& operator=(const Kernel&) = delete;
  const std::string& name() const { return name_; }
  int buffers() const { return buffers_; }
  uint32_t push_bytes() const { return push_bytes_; }
  struct Impl;
  Impl& impl() const { return *impl_; }

 private:
  Context& ctx_;
  std::string name_;
  int buffers_;
  uint32_t push_bytes_;
  std::unique_ptr<Impl> impl_;
};

// Work groups to cover n items with groups of `local`.
inline uint32_t groups_for(uint64_t n, uint32_t local) { return static_cast<uint32_t>((n + local - 1) / local); }

}  // namespace photosite::gpu
