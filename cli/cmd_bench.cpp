// `photosite bench <target>`: the benchmarks live in bench/cmd/ (library photosite_benchlib);
// the command line only adds them as subcommands.
#include <fmt/format.h>

#include "bench/cmd/bench.h"
#include "photosite/error.h"
#include "registry.h"

namespace photosite::cli {
static Registrar reg("m-bench", [](CLI::App& app) {
  auto* bench = app.add_subcommand("bench", "run a benchmark; writes CSV and a chart to docs/");
  bench::add_bench_targets(bench);
  // A word that is no target (`bench nosuch`) is kept as an extra and refused here with the
  // list of targets, when the command line has been parsed (before any target runs).
  bench->allow_extras();
  bench->parse_complete_callback([bench] {
    std::vector<std::string> names;
    for (const CLI::App* t : bench->get_subcommands([](const CLI::App*) { return true; })) names.push_back(t->get_name());
    const std::vector<std::string> extra = bench->remaining();
    if (!extra.empty())
      fail(fmt::format("bench: unknown target '{}'; the targets are: {}", extra.front(), fmt::join(names, ", ")));
    if (bench->get_subcommands().empty()) fail(fmt::format("bench: name a target: {}", fmt::join(names, ", ")));
  });
});
}  // namespace photosite::cli
