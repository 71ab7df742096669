// `photosite presets list`, `photosite presets show NAME [--json]` and `photosite presets doc`.
#include <cstdio>

#include <nlohmann/json.hpp>

#include "photosite/sensor/preset.h"
#include "registry.h"

namespace photosite::cli {

static Registrar reg("a-presets", [](CLI::App& app) {
  auto* presets = app.add_subcommand("presets", "list and show the camera, lens, scene and camera rig presets");
  presets->require_subcommand(1);
  auto* list = presets->add_subcommand("list", "one preset per line: name, kind, description");
  list->callback([] {
    for (const auto& e : list_presets())
      std::printf("%s\t%s\t%s\n", e.name.c_str(), e.kind.c_str(), e.description.c_str());
  });
  auto name = std::make_shared<std::string>();
  auto json = std::make_shared<bool>(false);
  auto* show = presets->add_subcommand("show", "the resolved parameters of one preset");
  show->add_option("name", *name, "preset name or path")->required();
  show->add_flag("--json", *json, "print JSON");
  show->callback([name, json] {
    const nlohmann::json j = nlohmann::json::parse(show_preset(*name));
    if (*json) {
      std::printf("%s\n", j.dump(2).c_str());
    } else {
      for (auto it = j.begin(); it != j.end(); ++it)
        std::printf("%-36s %s\n", it.key().c_str(), it.value().dump().c_str());
    }
  });
  auto* doc = presets->add_subcommand(
      "doc", "the Markdown reference of the camera, lens, scene and rig keys (docs/presets.md's generated section)");
  doc->callback([] { std::printf("%s", presets_doc_markdown().c_str()); });
});

}  // namespace photosite::cli
