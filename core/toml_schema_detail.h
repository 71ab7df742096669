// One parameter schema, one TOML reader (issue 18 §4). A preset kind is declared once as a table of
// Param rows (key, unit, allowed range, required or default, meaning, source); the same rows drive
//   * read():      the TOML reader (toml++), every error "file:line: key: problem";
//   * to_json():   `presets show --json`, the keys being the TOML keys;
//   * markdown():  the reference tables in docs/presets.md (`photosite presets doc`);
//   * attributes(): the EXR header attributes of the rows marked Exr::Header (names are contracts).
// The idea is pbrt-v4's ParameterDictionary + ReportUnused: nothing in a file goes unread, and
// nothing is read that the table does not declare. Defaults are not in the table: they are the
// initialisers of the preset struct (P{}), so the docs print what the code uses.
//
// Private header (toml++ and nlohmann-json): included by sensor/preset.cpp (cameras, lenses),
// scene/rig.cpp (camera rigs) and scene/scene_preset.cpp (scenes).
#pragma once
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>
#include <toml++/toml.h>

#include "photosite/error.h"
#include "photosite/io.h"

namespace photosite::schema {

inline constexpr double kUnbounded = std::numeric_limits<double>::infinity();

enum class Kind {
  Number,      // TOML float or integer, finite, in [lo, hi]
  Integer,     // TOML integer in [lo, hi]
  Text,        // TOML string
  Choice,      // TOML string naming one of a fixed set, stored as an enum (Choice<P>)
  Boolean,     // true / false
  NumberList,  // array of finite numbers, each in [lo, hi]
  NumberRows,  // array of rows (arrays of finite numbers, each in [lo, hi]) of one length, stored
               // row-major in a std::vector<double> (Rows<P>)
  Table,       // [key]: its rows are the keys "key.*"; slot: none, or a bool set when present
};
enum class Need { Required, Optional };
// Whether an output's EXR header carries the key's value, as the attribute <prefix><key>
// (attributes(); Number, Integer, Text and Choice rows).
enum class Exr { No, Header };

// A text key stored as an enum: set() throws photosite::Error on an unknown name (its message is
// kept after "file:line: key: "), get() gives the name back.
template <class P>
struct Choice {
  void (*set)(P&, const std::string&);
  std::string (*get)(const P&);
  std::string_view names;  // the allowed names, for the docs
};

// A matrix key stored row-major: values() holds the numbers, columns() says how many a row has
// (for to_json; the reader checks only that the rows are of one length, the preset's own check
// ties the length to another key).
template <class P>
struct Rows {
  std::vector<double>& (*values)(P&);
  std::size_t (*columns)(const P&);
};

// Where a row's value lives in the preset struct P: an accessor returning a reference.
template <class P>
using Slot = std::variant<std::monostate, double& (*)(P&), int& (*)(P&), std::string& (*)(P&),
                          bool& (*)(P&), std::vector<double>& (*)(P&), Choice<P>, Rows<P>>;

template <class P>
struct Param {
  std::string_view key;  // TOML key; a table's keys are "table.key"
  Kind kind;
  Slot<P> slot;
  std::string_view unit;  // "mm", "e⁻", "fraction"; "—" dimensionless; empty for text, bool, table
  double lo = -kUnbounded, hi = kUnbounded;  // closed range (Number, Integer, NumberList elements)
  Need need = Need::Required;
  std::string_view meaning;     // one line
  std::string_view source;      // where the definition comes from, and how sure it is
  std::string_view check = {};  // a cross-key condition checked after reading (validate), for docs
  Exr exr = Exr::No;
};

// An accessor for a Slot: PHOTOSITE_AT(CameraPreset, qe.wavelength_nm).
#define PHOTOSITE_AT(P, member) +[](P& p_) -> decltype(auto) { return (p_.member); }

// ---- error wording shared by every preset reader ("file:line: key: problem") ----

inline int line_of(const toml::node& n) { return static_cast<int>(n.source().begin.line); }
[[noreturn]] void key_error(const std::string& file, int line, const std::string& key,
                            const std::string& problem);
// The TOML text parsed; a syntax error is "file:line: malformed TOML: ...".
toml::table parse_toml(const std::string& text, const std::string& file);
// Numbers as the messages and the docs print them: shortest round trip, exponent without padding
// (1e-6, 1e+300 → 1e300).
std::string number_text(double v);
// "[0.1, 100]", "[0, ∞)", "(−∞, 5]"
std::string range_text(double lo, double hi);
// "value 120 is out of range, outside [0, 50] (%)": the range and, where the key has one, the unit.
std::string out_of_range(double v, double lo, double hi, std::string_view unit);

// The line of the key at `path` ("windows.width_m") in `t`, for a cross-key check after read();
// 0 (no line) where the key is absent.
int line_at(const toml::table& t, std::string_view path);

// ---- preset files ----

// The file of a preset: `name_or_path` itself when it holds a '/' or ends in ".toml", else
// <dir>/<name>.toml if that exists; nullopt for a bare name with no file (the caller words that
// error, listing preset_names(dir)).
std::optional<std::string> preset_file(const std::filesystem::path& dir, const std::string& name_or_path);
// Bad input naming `path` when it is a symbolic link whose target is missing.
void fail_if_dangling(const std::string& path);
// The bundled presets in `dir`: the stems of its *.toml files, sorted.
std::vector<std::string> preset_names(const std::filesystem::path& dir);
// "a, b, c"
std::string comma_list(const std::vector<std::string>& names);
// The file's text; "path: cannot read <what>" when it cannot be opened.
std::string read_text(const std::string& path, const std::string& what);

// ---- the reader ----

namespace detail {
inline std::string_view parent_of(std::string_view key) {
  const auto dot = key.rfind('.');
  return dot == std::string_view::npos ? std::string_view{} : key.substr(0, dot);
}
template <class P>
const Param<P>* find(std::span<const Param<P>> schema, std::string_view key) {
  for (const auto& p : schema)
    if (p.key == key) return &p;
  return nullptr;
}
template <class P>
std::string keys_of(std::span<const Param<P>> schema, std::string_view parent) {
  std::string s;
  for (const auto& p : schema)
    if (parent_of(p.key) == parent)
      s += (s.empty() ? "" : ", ") + std::string(p.key.substr(parent.empty() ? 0 : parent.size() + 1));
  return s;
}
template <class P, class T>
T& slot_ref(const Param<P>& p, P& out) {
  return std::get<T& (*)(P&)>(p.slot)(out);
}
template <class P>
void check_range(const Param<P>& p, double v, const std::string& file, int line, const std::string& key) {
  if (!std::isfinite(v) || v < p.lo || v > p.hi) key_error(file, line, key, out_of_range(v, p.lo, p.hi, p.unit));
}

template <class P>
void set_value(const Param<P>& p, const toml::node& n, const std::string& file, const std::string& key, P& out) {
  const int line = line_of(n);
  switch (p.kind) {
    case Kind::Number: {
      const auto v = n.value<double>();
      if (!v || n.is_boolean()) key_error(file, line, key, "expected a number");
      check_range(p, *v, file, line, key);
      slot_ref<P, double>(p, out) = *v;
      return;
    }
    case Kind::Integer: {
      // The type first: toml++ 3.3's value<int64_t>() of a float casts it unchecked, which is
      // undefined for 15E60 (UBSan, found by fuzz_preset; docs/robustness.md).
      if (!n.is_integer()) key_error(file, line, key, "expected an integer");
      const auto v = *n.value<int64_t>();
      if (static_cast<double>(v) < p.lo || static_cast<double>(v) > p.hi)
        key_error(file, line, key, out_of_range(static_cast<double>(v), p.lo, p.hi, p.unit));
      slot_ref<P, int>(p, out) = static_cast<int>(v);
      return;
    }
    case Kind::Text: {
      if (!n.is_string()) key_error(file, line, key, "expected a string");
      slot_ref<P, std::string>(p, out) = *n.value<std::string>();
      return;
    }
    case Kind::Choice: {
      if (!n.is_string()) key_error(file, line, key, "expected a string");
      try {
        std::get<Choice<P>>(p.slot).set(out, *n.value<std::string>());
      } catch (const Error& e) {
        key_error(file, line, key, e.what());
      }
      return;
    }
    case Kind::Boolean: {
      if (!n.is_boolean()) key_error(file, line, key, "expected true or false");
      slot_ref<P, bool>(p, out) = *n.value<bool>();
      return;
    }
    case Kind::NumberList: {
      const toml::array* a = n.as_array();
      if (!a) key_error(file, line, key, "expected an array of numbers");
      std::vector<double> v;
      for (const auto& e : *a) {
        const auto x = e.value<double>();
        if (!x || e.is_boolean() || !std::isfinite(*x)) key_error(file, line_of(e), key, "expected a number");
        check_range(p, *x, file, line_of(e), key);
        v.push_back(*x);
      }
      slot_ref<P, std::vector<double>>(p, out) = std::move(v);
      return;
    }
    case Kind::NumberRows: {
      const toml::array* a = n.as_array();
      if (!a) key_error(file, line, key, "expected an array of rows (arrays of numbers)");
      std::vector<double> v;
      std::size_t cols = 0;
      bool first = true;
      for (const auto& row : *a) {
        const toml::array* r = row.as_array();
        if (!r) key_error(file, line_of(row), key, "expected an array of rows (arrays of numbers)");
        if (!first && r->size() != cols) key_error(file, line_of(row), key, "rows differ in length");
        first = false;
        cols = r->size();
        for (const auto& e : *r) {
          const auto x = e.value<double>();
          if (!x || e.is_boolean() || !std::isfinite(*x)) key_error(file, line_of(e), key, "expected a number");
          check_range(p, *x, file, line_of(e), key);
          v.push_back(*x);
        }
      }
      std::get<Rows<P>>(p.slot).values(out) = std::move(v);
      return;
    }
    case Kind::Table: break;  // read() descends
  }
}
}  // namespace detail

// Reads the TOML table `t` (the keys under `prefix`, "" for the file's top level) into `out`.
// Unknown keys, wrong types, out-of-range values and missing required keys are errors
// "file:line: key: problem"; a missing key is reported at the line of its table's header (0, no
// line, at the top level).
template <class P>
void read(const toml::table& t, std::span<const Param<P>> schema, const std::string& file, P& out,
          const std::string& prefix = {}) {
  const std::string_view parent =
      prefix.empty() ? std::string_view{} : std::string_view(prefix).substr(0, prefix.size() - 1);
  for (const auto& [k, node] : t) {
    const std::string leaf(k.str());
    const std::string key = prefix + leaf;
    const Param<P>* p = leaf.find('.') == std::string::npos ? detail::find(schema, key) : nullptr;
    if (!p) {
      // Inside a table, the few keys it may hold are listed; at the top level, see the docs.
      key_error(file, line_of(node), key,
                parent.empty() ? "unknown key" : "unknown key (expected " + detail::keys_of(schema, parent) + ")");
    }
    if (p->kind == Kind::Table) {
      const toml::table* sub = node.as_table();
      if (!sub) key_error(file, line_of(node), key, "expected a table [" + key + "]");
      if (auto* flag = std::get_if<bool& (*)(P&)>(&p->slot)) (*flag)(out) = true;
      read(*sub, schema, file, out, key + ".");
      continue;
    }
    detail::set_value(*p, node, file, key, out);
  }
  const int here = prefix.empty() ? 0 : line_of(t);
  for (const auto& p : schema) {
    if (p.need != Need::Required || detail::parent_of(p.key) != parent) continue;
    const std::string leaf(p.key.substr(parent.empty() ? 0 : parent.size() + 1));
    if (!t.contains(leaf))
      key_error(file, here, std::string(p.key),
                p.kind == Kind::Table ? "required table is missing" : "required key is missing");
  }
}

// The preset as a JSON object whose keys are the TOML keys (a table is an object; an optional
// table that is absent is null; an empty list is left out).
template <class P>
nlohmann::json to_json(std::span<const Param<P>> schema, const P& preset, std::string_view parent = {}) {
  P& p = const_cast<P&>(preset);  // the accessors are only read here
  nlohmann::json j = nlohmann::json::object();
  for (const auto& r : schema) {
    if (detail::parent_of(r.key) != parent) continue;
    const std::string leaf(r.key.substr(parent.empty() ? 0 : parent.size() + 1));
    switch (r.kind) {
      case Kind::Number: j[leaf] = detail::slot_ref<P, double>(r, p); break;
      case Kind::Integer: j[leaf] = detail::slot_ref<P, int>(r, p); break;
      case Kind::Text: j[leaf] = detail::slot_ref<P, std::string>(r, p); break;
      case Kind::Choice: j[leaf] = std::get<Choice<P>>(r.slot).get(p); break;
      case Kind::Boolean: j[leaf] = detail::slot_ref<P, bool>(r, p); break;
      case Kind::NumberList: {
        const auto& v = detail::slot_ref<P, std::vector<double>>(r, p);
        if (!v.empty()) j[leaf] = v;
        break;
      }
      case Kind::NumberRows: {
        const auto& rows = std::get<Rows<P>>(r.slot);
        const auto& v = rows.values(p);
        const std::size_t cols = rows.columns(preset);
        if (v.empty()) break;
        if (cols == 0 || v.size() % cols != 0) {  // not a matrix: the numbers as they are
          j[leaf] = v;
          break;
        }
        nlohmann::json m = nlohmann::json::array();
        for (std::size_t i = 0; i < v.size(); i += cols)
          m.push_back(std::vector<double>(v.begin() + static_cast<long>(i), v.begin() + static_cast<long>(i + cols)));
        j[leaf] = std::move(m);
        break;
      }
      case Kind::Table: {
        const auto* flag = std::get_if<bool& (*)(P&)>(&r.slot);
        j[leaf] = (flag && !(*flag)(p)) ? nlohmann::json(nullptr) : to_json(schema, preset, r.key);
        break;
      }
    }
  }
  return j;
}

// The values of the rows marked Exr::Header as EXR header attributes "<prefix><key>": a Number as
// double, an Integer as int, Text and Choice as their text, a Boolean as the int 1 or 0.
template <class P>
std::map<std::string, ExrAttribute> attributes(std::span<const Param<P>> schema, const P& preset,
                                               std::string_view prefix) {
  P& p = const_cast<P&>(preset);  // the accessors are only read here
  std::map<std::string, ExrAttribute> a;
  for (const auto& r : schema) {
    if (r.exr != Exr::Header) continue;
    const std::string name = std::string(prefix) + std::string(r.key);
    switch (r.kind) {
      case Kind::Number: a[name] = detail::slot_ref<P, double>(r, p); break;
      case Kind::Integer: a[name] = detail::slot_ref<P, int>(r, p); break;
      case Kind::Text: a[name] = detail::slot_ref<P, std::string>(r, p); break;
      case Kind::Choice: a[name] = std::get<Choice<P>>(r.slot).get(p); break;
      case Kind::Boolean: a[name] = detail::slot_ref<P, bool>(r, p) ? 1 : 0; break;
      default: break;  // lists and tables have no attribute
    }
  }
  return a;
}

// ---- the docs ----

struct DocRow {
  std::string key, unit, required, range, meaning, source;
};
// The Markdown table of the rows, "| key | unit / type | required (default) | range | meaning | source |".
std::string markdown_table(const std::vector<DocRow>& rows);

template <class P>
std::vector<DocRow> doc_rows(std::span<const Param<P>> schema) {
  P defaults{};
  std::vector<DocRow> rows;
  for (const auto& r : schema) {
    DocRow d;
    const std::string_view parent = detail::parent_of(r.key);
    d.key = r.kind == Kind::Table ? "[" + std::string(r.key) + "]" : std::string(r.key);
    switch (r.kind) {
      case Kind::Text: d.unit = "text"; break;
      case Kind::Choice: d.unit = std::string(std::get<Choice<P>>(r.slot).names); break;
      case Kind::Boolean: d.unit = "true / false"; break;
      case Kind::Table: d.unit = "table"; break;
      case Kind::NumberList: d.unit = "list, " + std::string(r.unit); break;
      case Kind::NumberRows: d.unit = "rows of lists, " + std::string(r.unit); break;
      default: d.unit = std::string(r.unit);
    }
    if (r.need == Need::Required) {
      d.required = parent.empty() ? "yes" : "yes, in [" + std::string(parent) + "]";
    } else {
      std::string def;
      switch (r.kind) {
        case Kind::Number: def = number_text(detail::slot_ref<P, double>(r, defaults)); break;
        case Kind::Integer: def = std::to_string(detail::slot_ref<P, int>(r, defaults)); break;
        case Kind::Boolean: def = detail::slot_ref<P, bool>(r, defaults) ? "true" : "false"; break;
        case Kind::Text: def = "empty"; break;
        case Kind::Choice: def = std::get<Choice<P>>(r.slot).get(defaults); break;
        case Kind::Table: def = "absent"; break;
        default: break;
      }
      d.required = def.empty() ? "no" : "no (" + def + ")";
    }
    if (r.kind == Kind::Number || r.kind == Kind::Integer || r.kind == Kind::NumberList ||
        r.kind == Kind::NumberRows)
      if (r.lo != -kUnbounded || r.hi != kUnbounded) d.range = range_text(r.lo, r.hi);
    if (!r.check.empty()) d.range += (d.range.empty() ? "" : "; ") + std::string(r.check);
    d.meaning = r.meaning;
    d.source = r.source;
    rows.push_back(std::move(d));
  }
  return rows;
}

}  // namespace photosite::schema
