// The SPIR-V of kernels/*.comp, embedded at build time (kernels/CMakeLists.txt generates the
// table behind find_spirv).
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>

#include "photosite/error.h"

namespace photosite::gpu {
struct Spirv {
  const char* name;
  const uint32_t* code;
  size_t words;
};
Spirv find_spirv(const std::string& name);  // internal error when absent
}  // namespace photosite::gpu
