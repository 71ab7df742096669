// `photosite version`: prints the version (also `photosite --version`).
#include <cstdio>

#include "registry.h"

namespace photosite::cli {
static Registrar reg("zz-version", [](CLI::App& app) {
  auto* sub = app.add_subcommand("version", "print the photosite version");
  sub->callback([] { std::printf("photosite %s\n", PHOTOSITE_VERSION); });
});
}  // namespace photosite::cli
