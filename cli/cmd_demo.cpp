// `photosite demo`: `photosite night` on the bundled KITTI frame (samples/kitti), writing the
// EXR and an sRGB preview beside it.
#include <string>

#include "backend.h"
#include "registry.h"
#include "sensor_options.h"

namespace photosite::cli {
void run_demo(const std::string& out, const std::string& preview, bool overwrite, bool timings,
              const std::string& backend, const std::string& poisson);

static Registrar reg("c-night-demo", [](CLI::App& app) {
  struct Opts {
    std::string out = "photosite-demo.exr", preview = "photosite-demo.png", backend = "auto", poisson = "exact";
    bool overwrite = false, timings = false;
  };
  auto o = std::make_shared<Opts>();
  auto* sub = app.add_subcommand("demo", "run `photosite night` on the bundled KITTI sample");
  sub->add_option("--out", o->out, "output EXR")->capture_default_str();
  sub->add_option("--preview", o->preview, "sRGB preview PNG (empty: none)")->capture_default_str();
  sub->add_flag("--timings", o->timings, "print the per-stage time table");
  sub->add_option("--poisson", o->poisson, "shot-noise sampler: exact, cornish-fisher or normal")->capture_default_str();
  add_overwrite_flag(sub, o->overwrite);
  add_backend_option(sub, o->backend);
  sub->callback([o] { run_demo(o->out, o->preview, o->overwrite, o->timings, o->backend, o->poisson); });
});
}  // namespace photosite::cli
