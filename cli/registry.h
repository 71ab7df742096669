// Each cli/cmd_*.cpp adds its subcommand through a static Registrar. The subcommand's callback
// does the work and throws photosite::Error on bad input; main() turns that into a message on
// stderr and exit status 2 (1 for internal errors).
#pragma once
#include <CLI/CLI.hpp>
#include <exception>
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

// The command line's wording of a library error: a ParameterError names its parameter by the
// flag that sets it (label_format → --label-format); other errors as they are.
std::string flag_for(const std::string& parameter);
std::string message(const std::exception& e);
// The exit status of a library error: 2 for bad input, 1 for internal errors.
int exit_status(const std::exception& e);

}  // namespace photosite::cli
