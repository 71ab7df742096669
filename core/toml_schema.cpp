// The shared wording of preset errors and docs (core/toml_schema_detail.h).
#include "core/toml_schema_detail.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

namespace photosite::schema {

void key_error(const std::string& file, int line, const std::string& key, const std::string& problem) {
  fail(where(file, line, key) + ": " + problem);
}

toml::table parse_toml(const std::string& text, const std::string& file) {
  try {
    return toml::parse(text, file);
  } catch (const toml::parse_error& e) {
    fail(where(file, static_cast<int>(e.source().begin.line)) + ": malformed TOML: " +
         std::string(e.description()));
  }
}

int line_at(const toml::table& t, std::string_view path) {
  const toml::node* n = t.at_path(path).node();
  return n ? line_of(*n) : 0;
}

std::optional<std::string> preset_file(const std::filesystem::path& dir, const std::string& name_or_path) {
  if (name_or_path.find('/') != std::string::npos || name_or_path.ends_with(".toml")) return name_or_path;
  const auto path = dir / (name_or_path + ".toml");
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    fail_if_dangling(path.string());
    return std::nullopt;
  }
  return path.string();
}

void fail_if_dangling(const std::string& path) {
  // A symbolic link to nothing was an "unknown preset" that the same message listed as bundled.
  std::error_code ec;
  if (std::filesystem::is_symlink(path, ec) && !std::filesystem::exists(path, ec))
    fail_at(path, "a symbolic link to nothing (" + std::filesystem::read_symlink(path, ec).string() +
                      " is missing); mend or remove the link");
}

std::vector<std::string> preset_names(const std::filesystem::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  // Preset files only: a folder or a link to nothing of that name is none (they are named when asked
  // for: read_text, fail_if_dangling).
  for (const auto& e : std::filesystem::directory_iterator(dir, ec))
    if (std::error_code fe; e.path().extension() == ".toml" && e.is_regular_file(fe)) names.push_back(e.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

std::string comma_list(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

std::string read_text(const std::string& path, const std::string& what) {
  // A folder opens as a stream of no bytes, read as an empty file (`--scene-preset /tmp` said
  // "reflectance: required table is missing").
  if (std::error_code ec; std::filesystem::is_directory(path, ec)) fail_at(path, "is a folder, not a " + what + " file");
  std::ifstream in(path);
  if (!in) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) fail_missing(path, "cannot read " + what + " (no such file)");
    fail_at(path, "cannot read " + what);
  }
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string number_text(double v) {
  if (v == kUnbounded) return "∞";
  if (v == -kUnbounded) return "−∞";
  // "%g" where it gives the number back exactly (1e+08 rather than 100000000), else the shortest
  // round trip; the exponent then without sign padding and leading zeros.
  std::string s = fmt::format("{:g}", v);
  if (std::strtod(s.c_str(), nullptr) != v) s = fmt::format("{}", v);
  const auto e = s.find('e');
  if (e != std::string::npos) {
    std::string mant = s.substr(0, e), exp = s.substr(e + 1);
    const bool neg = !exp.empty() && exp[0] == '-';
    if (!exp.empty() && (exp[0] == '-' || exp[0] == '+')) exp.erase(0, 1);
    while (exp.size() > 1 && exp[0] == '0') exp.erase(0, 1);
    s = mant + "e" + (neg ? "-" : "") + exp;
  }
  return s;
}

std::string range_text(double lo, double hi) {
  return (lo == -kUnbounded ? "(" : "[") + number_text(lo) + ", " + number_text(hi) +
         (hi == kUnbounded ? ")" : "]");
}

std::string out_of_range(double v, double lo, double hi, std::string_view unit) {
  std::string s = "value " + number_text(v) + " is out of range, outside " + range_text(lo, hi);
  if (!unit.empty() && unit != "—") s += " (" + std::string(unit) + ")";
  return s;
}

std::string markdown_table(const std::vector<DocRow>& rows) {
  // A '|' in a cell would end it: Markdown's escape is "\|".
  auto cell = [](const std::string& s) {
    std::string o;
    for (char c : s) o += c == '|' ? std::string("\\|") : std::string(1, c);
    return o;
  };
  auto code = [&](const std::string& s) { return "`" + s + "`"; };
  std::string md = "| key | unit / type | required (default) | range | meaning | source |\n"
                   "|---|---|---|---|---|---|\n";
  for (const auto& r : rows)
    md += "| " + code(r.key) + " | " + cell(r.unit) + " | " + cell(r.required) + " | " + cell(r.range) + " | " +
          cell(r.meaning) + " | " + cell(r.source) + " |\n";
  return md;
}

}  // namespace photosite::schema
