#include "backend.h"

namespace photosite::cli {

void add_backend_option(CLI::App* sub, std::string& backend) {
  sub->add_option("--backend", backend,
                  "where the per-pixel sensor stages run: cpu, vulkan, or auto (a real GPU when "
                  "present, else cpu)")
      ->capture_default_str()
      ->check(CLI::IsMember({"cpu", "vulkan", "auto"}));
}

}  // namespace photosite::cli
