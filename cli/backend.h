// `--backend cpu|vulkan|auto`: the command line's face of the library's backend choice
// (photosite/backend.h: resolve_backend, SensorRunner).
#pragma once
#include <CLI/CLI.hpp>
#include <string>

#include "photosite/backend.h"

namespace photosite::cli {

void add_backend_option(CLI::App* sub, std::string& backend);

}  // namespace photosite::cli
