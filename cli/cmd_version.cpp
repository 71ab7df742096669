// `photosite version`: prints the version (also `photosite --version`); with --backends, what
// `--backend` can run on here and what `auto` picks (the same decision as resolve_backend()).
#include <omp.h>

#include <cstdio>
#include <string>

#include "core/isa_detail.h"
#include "photosite/error.h"
#include "registry.h"
#ifdef PHOTOSITE_HAVE_VULKAN
#include "photosite/gpu/context.h"
#endif

namespace photosite::cli {
namespace {
void print_backends() {
  // The vector level the CPU paths take (core/isa_detail.h: the CPU's, capped by $PHOTOSITE_MAX_ISA).
  std::printf("cpu: native C++, %d OpenMP threads%s%s\n", omp_get_max_threads(),
              photosite::detail::have_avx2() ? ", AVX2" : "", photosite::detail::have_avx512() ? ", AVX-512" : "");
#ifdef PHOTOSITE_HAVE_VULKAN
  try {
    const gpu::Context& ctx = gpu::shared_context();
    const gpu::DeviceInfo& d = ctx.device();
    std::printf("vulkan: %s (%s), Vulkan %u.%u, %s, %s\n", d.name.c_str(), d.type.c_str(), d.api_version >> 22,
                (d.api_version >> 12) & 0x3ff,
                !d.staged ? "mapped buffers" : d.host_import ? "staged transfers (host-page import offered: batch uses it)"
                                                            : "staged transfers",
                d.timestamps ? "kernel timestamps" : "no timestamps");
    std::printf("auto: %s\n", d.cpu ? "cpu (the Vulkan device is a CPU implementation, slower than the native path)"
                                    : "vulkan");
  } catch (const Error& e) {
    std::printf("vulkan: unavailable: %s\nauto: cpu\n", message(e).c_str());
  }
#else
  std::printf("vulkan: not built (PHOTOSITE_VULKAN=OFF)\nauto: cpu\n");
#endif
}
}  // namespace

static Registrar reg("zz-version", [](CLI::App& app) {
  auto* sub = app.add_subcommand("version", "print the photosite version");
  auto backends = std::make_shared<bool>(false);
  sub->add_flag("--backends", *backends,
                "also list the backends: the CPU path, the Vulkan device (or why there is none) and what "
                "--backend auto picks");
  sub->callback([backends] {
    std::printf("photosite %s\n", PHOTOSITE_VERSION);
    if (*backends) print_backends();
  });
});
}  // namespace photosite::cli
