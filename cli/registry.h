// Each cli/cmd_*.cpp adds its subcommand through a static Registrar. The subcommand's callback
// does the work and throws photosite::Error on bad input; main() turns that into a message on
// stderr and exit status 2 (1 for internal errors).
#pragma once
#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

namespace photosite::cli {

using SetupFn = std::function<void(CLI::App& root)>;
std::vector<std::pair<std::string, SetupFn>>& registry();

struct Registrar {
  Registrar(std::string order_key, SetupFn fn) { registry().emplace_back(std::move(order_key), std::move(fn)); }
};

// Options shared by several commands.
struct CommonOutputOptions {
  bool overwrite = false;
};
void add_overwrite_flag(CLI::App* sub, bool& overwrite);

}  // namespace photosite::cli
