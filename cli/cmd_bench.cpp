// `photosite bench <target>`: the benchmarks live in bench/cmd/ (library photosite_benchlib);
// the command line only adds them as subcommands.
#include "bench/cmd/bench.h"
#include "registry.h"

namespace photosite::cli {
static Registrar reg("m-bench", [](CLI::App& app) {
  auto* bench = app.add_subcommand("bench", "run a benchmark; writes CSV and a chart to docs/");
  bench->require_subcommand(1);
  bench::add_bench_targets(bench);
});
}  // namespace photosite::cli
