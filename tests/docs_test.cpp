// The docs say what the code does. A user copies a command from README.md or docs/*.md and must
// not get "unknown option"; a reader of docs/cli.md must find every option a command takes, with
// the default the command uses; the channels and header keys the docs list must be the ones a run
// writes. These tests read the repository's docs (PHOTOSITE_SOURCE_DIR, the checkout the test
// binary was built from) and hold them to the built command: its options come from its own
// `--help` (CLI11's table, the one the parser uses), its outputs from a run on a small frame.
// docs/presets.md's key tables are checked by PresetSchema.DocsTablesAreGenerated, docs/python.md's
// Reference by tests/python/test_docs.py.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "photosite/io.h"
#include "test_util.h"

namespace fs = std::filesystem;
using photosite::test::run_cli;
using photosite::test::TempDir;

namespace {

const fs::path kRoot = PHOTOSITE_SOURCE_DIR;

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  EXPECT_TRUE(f.good()) << p;
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

bool starts_with(const std::string& s, const std::string& p) { return s.rfind(p, 0) == 0; }
bool ends_with(const std::string& s, const std::string& p) {
  return s.size() >= p.size() && s.compare(s.size() - p.size(), p.size(), p) == 0;
}

// The text of the Markdown section that starts with the heading line `heading` (up to the next
// heading of the same or a higher level).
std::string section(const std::string& text, const std::string& heading) {
  const auto b = text.find("\n" + heading + "\n");
  EXPECT_NE(b, std::string::npos) << heading;
  if (b == std::string::npos) return {};
  const std::string hashes = heading.substr(0, heading.find(' '));
  size_t e = b + heading.size() + 2;
  for (;;) {
    e = text.find("\n#", e);
    if (e == std::string::npos) return text.substr(b);
    const size_t n = text.find_first_not_of('#', e + 1) - (e + 1);
    if (n <= hashes.size() && text[e + 1 + n] == ' ') return text.substr(b, e - b);
    ++e;
  }
}

// Every `...` span of a text.
std::vector<std::string> code_spans(const std::string& text) {
  std::vector<std::string> out;
  for (size_t b = text.find('`'); b != std::string::npos;) {
    const size_t e = text.find('`', b + 1);
    if (e == std::string::npos) break;
    out.push_back(text.substr(b + 1, e - b - 1));
    b = text.find('`', e + 1);
  }
  return out;
}

// ---- the command's options, from its --help ----------------------------------------------------

struct OptionHelp {
  std::string type;                      // CLI11's type column: TEXT, INT:at least 1, ... (empty: a flag)
  std::optional<std::string> default_value;  // after '=' in the type column
  std::string description;
};
struct CommandHelp {
  std::map<std::string, OptionHelp> options;  // by long name (--out); -h/--help included
  std::vector<std::string> subcommands;
};

// CLI11's help: "Options:" then one line per option, "  -y,--overwrite  description" or
// "  --repeats INT:at least 1=5  description" (the type column may hold spaces; its default follows
// '='), a long description wrapped onto lines of its own; then "Subcommands:", one per line.
CommandHelp parse_help(const std::string& text) {
  static const std::regex option(R"(^  (-\S+)(?: ((?:TEXT|INT|FLOAT|UINT)[^=\s]*(?: [^=\s]+)*(?:=\S+)?))?(?:\s+(.*))?$)");
  static const std::regex sub(R"(^  (\S+)\s)");
  CommandHelp h;
  enum { None, Options, Subcommands } part = None;
  std::string last;
  for (const auto& l : lines_of(text)) {
    if (starts_with(l, "Options:")) { part = Options; continue; }
    if (starts_with(l, "Subcommands:")) { part = Subcommands; continue; }
    std::smatch m;
    if (part == Options && std::regex_match(l, m, option)) {
      OptionHelp o;
      o.type = m[2];
      if (const auto eq = o.type.find('='); eq != std::string::npos) o.default_value = o.type.substr(eq + 1);
      o.description = m[3];
      std::stringstream names(m[1].str());
      for (std::string n; std::getline(names, n, ',');)
        if (starts_with(n, "--")) h.options[last = n] = o;
    } else if (part == Options && !last.empty() && l.find_first_not_of(' ') != std::string::npos) {
      h.options[last].description += " " + l.substr(l.find_first_not_of(' '));
    } else if (part == Subcommands && std::regex_search(l, m, sub)) {
      h.subcommands.push_back(m[1]);
    }
  }
  return h;
}

// Every command and subcommand ("night", "bench night", "presets show", ...) with its options.
const std::map<std::string, CommandHelp>& commands() {
  static const std::map<std::string, CommandHelp> all = [] {
    std::map<std::string, CommandHelp> out;
    std::vector<std::string> todo;
    const auto root = parse_help(run_cli("--help").output);
    for (const auto& s : root.subcommands) todo.push_back(s);
    while (!todo.empty()) {
      const std::string c = todo.back();
      todo.pop_back();
      const auto r = run_cli(c + " --help");
      EXPECT_EQ(r.exit_code, 0) << c << "\n" << r.output;
      out[c] = parse_help(r.output);
      for (const auto& s : out[c].subcommands) todo.push_back(c + " " + s);
    }
    return out;
  }();
  return all;
}

// ---- commands in the docs -------------------------------------------------------------------------

// One command line in the docs: an indented synopsis (`    photosite night --image DAY ...` and
// its continuation lines, indented further, starting with [ or --) or a `photosite ...` line of a
// code block, or a `command --option` code span.
struct DocCommand {
  std::string where;    // file:line
  std::string command;  // "night", "bench night"; "bench" alone for `bench --threads`
  std::string text;     // what follows the command's name, comments removed
};

std::string command_of(const std::vector<std::string>& words, size_t& used) {
  const auto& cmds = commands();
  used = 0;
  if (words.empty() || !cmds.count(words[0])) return {};
  used = 1;
  if (words.size() > 1 && cmds.count(words[0] + " " + words[1])) {
    used = 2;
    return words[0] + " " + words[1];
  }
  return words[0];
}

std::vector<std::string> words_of(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> w;
  for (std::string x; in >> x;) w.push_back(x);
  return w;
}

// A file's text with its "## Edge cases ..." sections blanked (their lines kept, empty, so that
// line numbers stay): those tables record what photosite refuses, bad options included
// (`presets list --json`: exit 2), by design.
std::string without_edge_case_tables(const std::string& raw) {
  std::string text;
  bool edge = false;
  for (const auto& l : lines_of(raw)) {
    if (l.rfind("## ", 0) == 0) edge = l.rfind("## Edge cases", 0) == 0;
    text += (edge ? std::string() : l) + "\n";
  }
  return text;
}

std::vector<DocCommand> doc_commands(const std::string& file) {
  const std::string text = without_edge_case_tables(slurp(kRoot / file));
  const auto ls = lines_of(text);
  std::vector<DocCommand> out;
  // A line that runs photosite: optional "$ ", VAR=value assignments and a path before the name.
  static const std::regex run(R"(^\s*(?:\$ )?(?:[A-Z_]+=\S+ )*(?:[\w./-]*/)?photosite (.*)$)");
  static const std::regex continuation(R"(^ {6,}[\[-].*)");
  static const std::regex comment(R"(\s#\s.*$)");
  for (size_t i = 0; i < ls.size(); ++i) {
    std::smatch m;
    if (!std::regex_match(ls[i], m, run)) continue;
    size_t used = 0;
    const auto words = words_of(m[1]);
    const std::string cmd = command_of(words, used);
    if (cmd.empty()) continue;  // prose ("photosite is ...")
    // A command wrapped inside a code span ends at the span's closing backquote.
    const std::string line = m[1].str().substr(0, m[1].str().find('`'));
    DocCommand d{file + ":" + std::to_string(i + 1), cmd, std::regex_replace(line, comment, "")};
    d.text = d.text.substr(std::min(d.text.size(), d.text.find(words[used - 1]) + words[used - 1].size()));
    while (i + 1 < ls.size() && (std::regex_match(ls[i + 1], continuation) || ends_with(ls[i], "\\")))
      d.text += " " + std::regex_replace(ls[++i], comment, "");
    out.push_back(d);
  }
  // Code spans: `photosite night --x`, `night --x`, `bench night --threads 1`.
  for (const auto& span : code_spans(text)) {
    auto words = words_of(span);
    const bool named = !words.empty() && ends_with(words[0], "photosite");
    if (named) words.erase(words.begin());
    size_t used = 0;
    const std::string cmd = command_of(words, used);
    if (cmd.empty() || (!named && span.find("--") == std::string::npos)) continue;
    std::string rest;
    for (size_t k = used; k < words.size(); ++k) rest += " " + words[k];
    out.push_back({file + " `" + span + "`", cmd, rest});
  }
  return out;
}

struct DocOption {
  std::string name;                  // --exposure-s
  std::optional<std::string> value;  // "S=0.02", "led|hps", "5"
  bool optional = false;             // inside [ ]
};

std::vector<DocOption> options_in(const std::string& text) {
  std::vector<DocOption> out;
  int depth = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '[') ++depth;
    if (text[i] == ']') --depth;
    if (text.compare(i, 2, "--") != 0 || (i > 0 && (std::isalnum(static_cast<unsigned char>(text[i - 1])) || text[i - 1] == '-')))
      continue;
    size_t e = i + 2;
    while (e < text.size() && (std::islower(static_cast<unsigned char>(text[e])) || std::isdigit(static_cast<unsigned char>(text[e])) || text[e] == '-')) ++e;
    if (e == i + 2) continue;
    DocOption o{text.substr(i, e - i), std::nullopt, depth > 0};
    if (e < text.size() && (text[e] == ' ' || text[e] == '=')) {
      size_t v = e + 1, ve = v;
      while (ve < text.size() && !std::isspace(static_cast<unsigned char>(text[ve])) && text[ve] != '[' && text[ve] != ']') ++ve;
      const std::string value = text.substr(v, ve - v);
      if (!value.empty() && !starts_with(value, "--")) o.value = value;
    }
    out.push_back(o);
    i = e - 1;
  }
  return out;
}

bool is_number(const std::string& s, double& v) {
  char* end = nullptr;
  v = std::strtod(s.c_str(), &end);
  return !s.empty() && end == s.c_str() + s.size();
}

// What a synopsis value says about the option, checked against its help line: `S=0.02` and a
// plain `5` or `piz` state the default; `led|hps` lists the choices, each named in the help; an
// upper-case placeholder (`N`, `DIR`, `OUT.exr`) says nothing. "" when they agree.
std::string value_mismatch(const DocOption& o, const OptionHelp& h) {
  if (!o.value || !o.optional) return {};
  const std::string v = *o.value;
  static const std::regex placeholder(R"([A-Z0-9_./<>*-]+(\.[a-z]+)?)");
  static const std::regex choice_word(R"([a-z][A-Za-z0-9-]*)");
  double num = 0, hnum = 0;
  std::string stated;
  if (const auto eq = v.find('='); eq != std::string::npos) {
    stated = v.substr(eq + 1);
  } else if (v.find('|') != std::string::npos) {
    std::stringstream parts(v);
    for (std::string c; std::getline(parts, c, '|');)
      if (std::regex_match(c, choice_word) &&
          !std::regex_search(h.type + " " + h.description, std::regex("(^|[^A-Za-z0-9-])" + c + "($|[^A-Za-z0-9-])")))
        return "choice '" + c + "' is not in the help: " + h.type + "  " + h.description;
    return {};
  } else if (std::regex_match(v, placeholder) && !is_number(v, num)) {
    return {};
  } else {
    stated = v;
  }
  if (!h.default_value) {  // a default the help words: "(default docs/)", "(default <preset>-0)"
    if (h.description.find("default " + stated) != std::string::npos ||
        h.description.find("default: " + stated) != std::string::npos)
      return {};
    return "the docs give the default " + stated + ", the help none: " + h.type + "  " + h.description;
  }
  const std::string& d = *h.default_value;
  if (d == stated) return {};
  if (is_number(stated, num) && is_number(d, hnum) && num == hnum) return {};
  // A path the command resolves from its source tree: docs say ../shared/data/kodak24 or docs,
  // the help /path/to/checkout/../shared/data/kodak24 or /path/to/checkout/docs.
  std::string tail = stated;
  while (starts_with(tail, "./") || starts_with(tail, "../")) tail = tail.substr(tail.find('/') + 1);
  if (ends_with(d, "/" + tail) && d.find('/') != std::string::npos) return {};
  return "the docs give the default " + stated + ", the command " + d;
}

const std::vector<std::string> kDocsWithCommands = [] {
  std::vector<std::string> f{"README.md"};
  for (const auto& e : fs::directory_iterator(kRoot / "docs"))
    if (e.path().extension() == ".md") f.push_back("docs/" + e.path().filename().string());
  std::sort(f.begin(), f.end());
  return f;
}();

// The options docs/cli.md documents for each command: those of its synopses, and those of the
// sections `## --poisson (expose, flat, ...)` for the commands they name.
std::map<std::string, std::set<std::string>> documented_in_cli_md() {
  std::map<std::string, std::set<std::string>> doc;
  for (const auto& d : doc_commands("docs/cli.md"))
    if (d.where.find('`') == std::string::npos) {  // synopses, not spans in the prose
      auto& options = doc[d.command];
      for (const auto& o : options_in(d.text)) options.insert(o.name);
    }
  static const std::regex heading(R"(^## (--[a-z0-9-]+) \(([^)]*)\)$)");
  for (const auto& l : lines_of(slurp(kRoot / "docs/cli.md"))) {
    std::smatch m;
    if (!std::regex_match(l, m, heading)) continue;
    std::stringstream cs(m[2].str());
    for (std::string c; std::getline(cs, c, ',');) {
      c.erase(0, c.find_first_not_of(' '));
      EXPECT_TRUE(commands().count(c)) << "docs/cli.md: '" << l << "' names no command " << c;
      doc[c].insert(m[1]);
    }
  }
  return doc;
}

}  // namespace

// The help table itself is read right: the options every later test leans on are found.
TEST(Docs, HelpIsParsed) {
  const auto& c = commands();
  ASSERT_TRUE(c.count("night") && c.count("bench night") && c.count("presets show")) << c.size();
  EXPECT_EQ(c.at("night").options.at("--exposure-s").default_value, "0.02");
  EXPECT_EQ(c.at("bench night").options.at("--threads").default_value, "2");  // "INT:at least 1:at most 4096=2"
  EXPECT_EQ(c.at("expose").options.count("--overwrite"), 1u);                   // "-y,--overwrite"
  EXPECT_FALSE(c.at("expose").options.at("--half").default_value);
  EXPECT_NE(c.at("demosaic").options.at("--white-level").description.find("docs/demosaic.md"), std::string::npos);
}

// Every option a command line in README.md or docs/*.md gives is one the command takes, and a
// default or a list of choices in a synopsis is the command's.
TEST(Docs, CommandsInTheDocsTakeTheOptionsTheyName) {
  const auto& cmds = commands();
  size_t checked = 0;
  for (const auto& file : kDocsWithCommands)
    for (const auto& d : doc_commands(file)) {
      for (const auto& o : options_in(d.text)) {
        ++checked;
        if (cmds.at(d.command).subcommands.size() && !cmds.at(d.command).options.count(o.name)) {
          // A group named alone (`bench --threads`): an option of one of its subcommands.
          bool any = false;
          for (const auto& s : cmds.at(d.command).subcommands) any |= cmds.at(d.command + " " + s).options.count(o.name) > 0;
          EXPECT_TRUE(any) << d.where << ": no '" << d.command << "' subcommand takes " << o.name;
          continue;
        }
        const auto it = cmds.at(d.command).options.find(o.name);
        if (it == cmds.at(d.command).options.end()) {
          ADD_FAILURE() << d.where << ": 'photosite " << d.command << "' takes no " << o.name;
          continue;
        }
        const std::string bad = value_mismatch(o, it->second);
        EXPECT_EQ(bad, "") << d.where << ": " << d.command << " " << o.name << " " << o.value.value_or("");
      }
    }
  EXPECT_GT(checked, 300u);  // the docs' command lines were found
}

// Every option of every command and subcommand is in docs/cli.md, in that command's synopsis or
// in a section of the option that names the command.
TEST(Docs, EveryOptionIsInDocsCli) {
  const auto doc = documented_in_cli_md();
  for (const auto& [cmd, help] : commands())
    for (const auto& [name, h] : help.options) {
      if (name == "--help") continue;
      EXPECT_TRUE(doc.count(cmd) && doc.at(cmd).count(name))
          << "docs/cli.md does not list 'photosite " << cmd << " " << name << "' (" << h.description << ")";
    }
  // Every subcommand has a synopsis of its own (a group without options of its own excepted).
  for (const auto& [cmd, help] : commands())
    if (help.subcommands.empty()) EXPECT_TRUE(doc.count(cmd)) << "docs/cli.md has no synopsis of 'photosite " << cmd << "'";
}

namespace {

// The commands a section heading `## --poisson (expose, flat, ...)` of docs/cli.md names, by option.
std::map<std::string, std::set<std::string>> cli_md_option_sections() {
  static const std::regex heading(R"(^## (--[a-z0-9-]+) \(([^)]*)\)$)");
  std::map<std::string, std::set<std::string>> out;
  for (const auto& l : lines_of(slurp(kRoot / "docs/cli.md"))) {
    std::smatch m;
    if (!std::regex_match(l, m, heading)) continue;
    std::stringstream cs(m[2].str());
    for (std::string c; std::getline(cs, c, ',');) out[m[1]].insert(c.substr(c.find_first_not_of(' ')));
  }
  return out;
}

// The commands that take an option; the bench targets (`bench night --backend`) are left out:
// each has its own synopsis in docs/cli.md's bench section, and the lists are of the commands.
std::set<std::string> commands_taking(const std::string& option) {
  std::set<std::string> out;
  for (const auto& [cmd, help] : commands())
    if (help.options.count(option) && !starts_with(cmd, "bench ")) out.insert(cmd);
  return out;
}

// The `...` spans of README.md's sentence that ends in `tail`: "`expose`, `flat` ... take `--backend".
std::set<std::string> readme_spans_before(const std::string& tail) {
  const std::string readme = slurp(kRoot / "README.md");
  const auto e = readme.find(tail);
  EXPECT_NE(e, std::string::npos) << tail;
  if (e == std::string::npos) return {};
  const auto b = readme.rfind("\n\n", e);
  std::set<std::string> out;
  for (const auto& s : code_spans(readme.substr(b, e - b))) out.insert(s);
  return out;
}

}  // namespace

// The lists of commands the docs give for an option are exactly the commands that take it: the
// sections `## --poisson (...)` and `## --backend (...)` of docs/cli.md, README.md's "... take
// `--backend`" sentence and its list of bench targets (a command dropped from a list, or a list
// naming one that lacks the option, fails; the converse of EveryOptionIsInDocsCli, which finds an
// option in any section that names its command).
TEST(Docs, CommandListsForAnOptionAreTheCommandsThatTakeIt) {
  const auto sections = cli_md_option_sections();
  ASSERT_TRUE(sections.count("--poisson") && sections.count("--backend")) << sections.size();
  for (const auto& [option, named] : sections) EXPECT_EQ(named, commands_taking(option)) << "docs/cli.md: ## " << option;
  const auto backend = commands_taking("--backend");
  EXPECT_GE(backend.size(), 7u);
  EXPECT_EQ(readme_spans_before("take `--backend cpu|vulkan|auto`"), backend);
  // README.md's "photosite bench noise | night | ..." line: every target of `photosite bench`.
  const std::string readme = slurp(kRoot / "README.md");
  const auto b = readme.find("photosite bench noise");
  ASSERT_NE(b, std::string::npos);
  const size_t from = b + std::string("photosite bench").size();
  std::set<std::string> listed;
  std::stringstream targets(readme.substr(from, readme.find('\n', b) - from));
  for (std::string w; targets >> w && w != "#";)
    if (w != "|") listed.insert(w);
  const auto& bench = commands().at("bench").subcommands;
  EXPECT_GE(bench.size(), 10u);
  EXPECT_EQ(listed, std::set<std::string>(bench.begin(), bench.end()));
}

namespace {

// "R,G,B" -> R, G, B; "radiance.R/G/B" -> radiance.R, radiance.G, radiance.B; "raw.Y" -> raw.Y.
std::set<std::string> channel_names(const std::string& text) {
  static const std::regex channel(R"(^(?:R,G,B|[a-z_]+\.[A-Z](?:/[A-Z])*)$)");
  std::set<std::string> out;
  for (const auto& s : code_spans(text)) {
    if (!std::regex_match(s, channel)) continue;
    if (s == "R,G,B") {
      out.insert({"R", "G", "B"});
      continue;
    }
    const auto dot = s.find('.');
    for (size_t i = dot + 1; i < s.size(); i += 2) out.insert(s.substr(0, dot + 1) + s[i]);
  }
  return out;
}

std::set<std::string> keys_of(const std::map<std::string, photosite::ImageF>& m) {
  std::set<std::string> k;
  for (const auto& [n, _] : m) k.insert(n);
  return k;
}

// docs/cli.md's expose header list: "Header:\n`photosite/version, preset, lens, ...`".
std::set<std::string> expose_header_keys(const std::string& expose_section) {
  const auto b = expose_section.find("Header:\n`photosite/");
  EXPECT_NE(b, std::string::npos);
  const auto s = expose_section.find('`', b) + 1, e = expose_section.find('`', s);
  std::set<std::string> keys;
  std::stringstream list(expose_section.substr(s, e - s));
  for (std::string k; std::getline(list, k, ',');) {
    k.erase(0, k.find_first_not_of(" \n"));
    keys.insert(starts_with(k, "photosite/") ? k : "photosite/" + k);
  }
  return keys;
}

// The photosite/ attributes of a header that are not a channel's unit or a float's _text copy.
std::set<std::string> photosite_keys(const std::map<std::string, std::string>& attrs, const std::string& prefix = "photosite/") {
  std::set<std::string> k;
  for (const auto& [n, _] : attrs)
    if (starts_with(n, prefix) && !starts_with(n, "photosite/unit/") && !ends_with(n, "_text")) k.insert(n);
  return k;
}

}  // namespace

// expose's and flat's channels and header keys are the ones docs/cli.md (and README.md's chart
// row) name, both ways.
TEST(Docs, ExposeAndFlatChannelsAndHeaderAreDocumented) {
  TempDir tmp;
  ASSERT_EQ(run_cli("chart --width 64 --height 48 --out " + tmp.file("c.exr")).exit_code, 0);
  auto r = run_cli("expose --backend cpu --preset onsemi-ar0331 --radiance " + tmp.file("c.exr") + " --out " + tmp.file("e.exr"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = run_cli("flat --backend cpu --preset onsemi-ar0331 --photons 100 --wavelength-nm 525 --width 16 --height 16 --frames 1 --out " +
              tmp.file("f.exr"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto e = photosite::read_exr(tmp.file("e.exr"));
  const auto f = photosite::read_exr(tmp.file("f.exr"));
  const std::string cli = slurp(kRoot / "docs/cli.md");
  const std::string expose = section(cli, "## expose");

  // Channels: docs/cli.md's "Output channels:" sentence and README.md's out/chart.exr row.
  const auto out_channels = expose.substr(expose.find("Output channels:"), expose.find("Header:") - expose.find("Output channels:"));
  EXPECT_EQ(channel_names(out_channels), keys_of(e.channels)) << out_channels;
  const std::string readme = slurp(kRoot / "README.md");
  const auto row = readme.substr(readme.find("| `out/chart.exr` |"));
  EXPECT_EQ(channel_names(row.substr(0, row.find('\n'))), keys_of(e.channels));
  // Every channel names its unit.
  for (const auto& [n, _] : e.channels) EXPECT_TRUE(e.attributes.count("photosite/unit/" + n)) << n;

  // Header: the list, both ways, and each float's _text copy.
  const auto listed = expose_header_keys(expose);
  EXPECT_EQ(listed, photosite_keys(e.attributes));
  for (const auto& [n, v] : e.attributes)
    if (starts_with(n, "photosite/") && ends_with(n, "_text"))
      EXPECT_TRUE(e.attributes.count(n.substr(0, n.size() - 5))) << n;

  // flat: expose's channels less radiance, its header plus and less what docs/cli.md's flat says.
  std::set<std::string> flat_channels;
  for (const auto& c : keys_of(e.channels))
    if (!starts_with(c, "radiance.")) flat_channels.insert(c);
  EXPECT_EQ(keys_of(f.channels), flat_channels);
  const std::string flat = section(cli, "## flat");
  const auto without = flat.find("without");
  ASSERT_NE(without, std::string::npos);
  auto flat_keys = listed;
  for (const auto& s : code_spans(flat.substr(0, flat.find("`--lens`"))))
    if (starts_with(s, "photosite/")) {
      if (flat.find("`" + s + "`") < without) flat_keys.insert(s);
      else flat_keys.erase(s);
    }
  EXPECT_EQ(photosite_keys(f.attributes), flat_keys);
}

namespace {

// "a_{x,y}_{R,G}" -> a_x_R, a_x_G, a_y_R, a_y_G.
std::vector<std::string> expand_braces(const std::string& s) {
  const auto b = s.find('{');
  if (b == std::string::npos) return {s};
  const auto e = s.find('}', b);
  std::vector<std::string> out;
  std::stringstream alts(s.substr(b + 1, e - b - 1));
  for (std::string a; std::getline(alts, a, ',');)
    for (const auto& tail : expand_braces(s.substr(e + 1))) out.push_back(s.substr(0, b) + a + tail);
  return out;
}

}  // namespace

// night's channels are those docs/night.md's Output section and README.md's night row list; its
// photosite/night/ keys those of docs/night.md's header table (the "always" ones in every run),
// its photosite/scene/ keys rows of docs/presets.md's scene table, and its sensor attributes
// docs/cli.md's expose list.
TEST(Docs, NightChannelsAndHeaderKeysAreDocumented) {
  TempDir tmp;
  const auto r = run_cli("night --backend cpu --out " + tmp.file("n.exr"));  // the bundled KITTI sample
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto n = photosite::read_exr(tmp.file("n.exr"));
  const std::string night_md = slurp(kRoot / "docs/night.md");
  const std::string output = section(night_md, "## Output");
  const auto header_at = output.find("\nHeader:");
  ASSERT_NE(header_at, std::string::npos);
  EXPECT_EQ(channel_names(output.substr(0, header_at)), keys_of(n.channels));
  const std::string readme = slurp(kRoot / "README.md");
  const auto row = readme.substr(readme.find("| `out/night.exr` |"));
  EXPECT_EQ(channel_names(row.substr(0, row.find('\n'))), keys_of(n.channels));
  for (const auto& [c, _] : n.channels) EXPECT_TRUE(n.attributes.count("photosite/unit/" + c)) << c;

  // The header table: | `key`, `key_{a,b}` | what | written |.
  std::set<std::string> documented, always;
  bool in_table = false;
  for (const auto& l : lines_of(output.substr(header_at))) {
    if (starts_with(l, "| key |")) { in_table = true; continue; }
    if (!in_table || starts_with(l, "|---")) continue;
    if (!starts_with(l, "| `")) break;
    const std::string keys = l.substr(2, l.find(" | ") - 2);
    const std::string written = l.substr(l.rfind(" | ") + 3, l.size() - l.rfind(" | ") - 5);
    for (const auto& k : code_spans(keys))
      for (const auto& x : expand_braces(k)) {
        documented.insert("photosite/night/" + x);
        if (written == "always") always.insert("photosite/night/" + x);
      }
  }
  ASSERT_GT(always.size(), 40u) << "docs/night.md's header table was not found";
  const auto written = photosite_keys(n.attributes, "photosite/night/");
  for (const auto& k : written) EXPECT_TRUE(documented.count(k)) << k << " is written but not in docs/night.md's header table";
  for (const auto& k : always) EXPECT_TRUE(written.count(k)) << k << " is 'always' in docs/night.md but not written";

  // Scene parameters: every photosite/scene/<section.key> is a row of docs/presets.md's scene keys.
  const std::string scene_keys = section(slurp(kRoot / "docs/presets.md"), "### Scene keys (`presets/scenes/*.toml`)");
  size_t scene = 0;
  for (const auto& k : photosite_keys(n.attributes, "photosite/scene/")) {
    if (k == "photosite/scene/preset") continue;  // the preset's name (docs/night.md)
    ++scene;
    const std::string key = k.substr(std::string("photosite/scene/").size());
    EXPECT_NE(scene_keys.find("\n| `" + key + "` |"), std::string::npos) << k << " has no row in docs/presets.md";
  }
  EXPECT_GT(scene, 50u);
  EXPECT_TRUE(n.attributes.count("photosite/scene/preset"));
  // The sensor's attributes: those of expose's list (less its input file).
  auto sensor = expose_header_keys(section(slurp(kRoot / "docs/cli.md"), "## expose"));
  sensor.erase("photosite/radiance_file");
  std::set<std::string> rest;
  for (const auto& k : photosite_keys(n.attributes))
    if (!starts_with(k, "photosite/night/") && !starts_with(k, "photosite/scene/")) rest.insert(k);
  EXPECT_EQ(rest, sensor);
}

// `presets show --json` and `characterize --json` have the keys docs/cli.md names.
TEST(Docs, JsonKeysAreTheDocumentedOnes) {
  const std::string cli = slurp(kRoot / "docs/cli.md");
  // presets: the comment of the `presets show NAME [--json]` synopsis, "JSON keys: name, ..., qe{...}, …".
  const std::string presets = section(cli, "## presets");
  ASSERT_NE(presets.find("JSON keys:"), std::string::npos);
  std::string listed;  // the rest of that line, then the comments of the lines below it up to "…"
  for (const auto& l : lines_of(presets.substr(presets.find("JSON keys:") + 10))) {
    listed += " " + (listed.empty() ? l : l.substr(l.find('#') + 1));
    if (l.find("…") != std::string::npos) break;
  }
  listed = listed.substr(0, listed.find("…"));
  const auto qe = listed.find("qe{");
  ASSERT_NE(qe, std::string::npos) << listed;
  const std::string qe_keys = listed.substr(qe + 3, listed.find('}', qe) - qe - 3);
  listed = listed.substr(0, qe) + "qe";
  auto r = run_cli("presets show onsemi-ar0331 --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto rgb = nlohmann::json::parse(r.output);
  r = run_cli("presets show onsemi-ar0132at-rccc --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto rccc = nlohmann::json::parse(r.output);
  std::stringstream ks(listed);
  size_t n = 0;
  for (std::string k; std::getline(ks, k, ',');) {
    k.erase(0, k.find_first_not_of(' '));
    k.erase(k.find_last_not_of(' ') + 1);
    ++n;
    EXPECT_TRUE(rgb.contains(k)) << "presets show --json has no " << k;
  }
  EXPECT_GT(n, 10u);
  // qe{wavelength_nm, r, g, b | c}: an RGB camera's r, g, b, the clear channel's c.
  for (const char* k : {"wavelength_nm", "r", "g", "b"}) {
    EXPECT_NE(qe_keys.find(k), std::string::npos) << qe_keys;
    EXPECT_TRUE(rgb["qe"].contains(k)) << k;
  }
  EXPECT_NE(qe_keys.find("| c"), std::string::npos) << qe_keys;
  EXPECT_TRUE(rccc["qe"].contains("c"));
  // The JSON keys are the TOML keys plus name and file.
  EXPECT_TRUE(rgb.contains("name") && rgb.contains("file"));

  // characterize: every key of the --json paragraph, both ways.
  const std::string ch = section(cli, "## characterize");
  const auto from = ch.find("`--json` keys:");
  ASSERT_NE(from, std::string::npos);
  std::set<std::string> keys;
  static const std::regex key(R"([a-z][a-z0-9_]*(?:<λ>nm)?)");
  for (const auto& s : code_spans(ch.substr(from + 14))) {
    std::stringstream parts(s);
    for (std::string k; std::getline(parts, k, ',');) {
      k.erase(std::remove_if(k.begin(), k.end(), [](char c) { return c == '{' || c == '}' || c == '\n'; }), k.end());
      k.erase(0, k.find_first_not_of(' '));
      if (k.find(" (") != std::string::npos) k = k.substr(0, k.find(" ("));
      if (std::regex_match(k, key)) keys.insert(k == "qe_<λ>nm" ? "qe_525nm" : k);
    }
  }
  // characterize at its smallest ROI (16x16 px; the same EMVA plan and keys) takes about 0.2 s of CPU.
  r = run_cli("characterize --backend cpu --preset onsemi-ar0331 --roi 16 --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output.substr(r.output.find('{')));
  std::set<std::string> actual;
  for (const auto& [k, v] : j.items()) actual.insert(k);
  // The nested keys named beside them: each quantity's and the conditions'.
  for (const auto& [k, v] : j.items())
    if (v.is_object())
      for (const auto& [k2, v2] : v.items()) actual.insert(k2);
  for (const auto& k : keys) EXPECT_TRUE(actual.count(k)) << "docs/cli.md names characterize's JSON key " << k << ", which it lacks";
  for (const auto& [k, v] : j.items()) EXPECT_TRUE(keys.count(k)) << "characterize --json writes " << k << ", which docs/cli.md does not name";
}

namespace {

// The `photosite/<key>` spans of a text (a channel's unit and <placeholders> left out).
std::set<std::string> named_keys(const std::string& text) {
  std::set<std::string> k;
  for (const auto& s : code_spans(text))
    if (starts_with(s, "photosite/") && !starts_with(s, "photosite/unit/") && s.find_first_of("<> ") == std::string::npos)
      k.insert(s);
  return k;
}

// README.md and docs/*.md but docs/benchmarks.md, whose sessions' sections name the files and
// tests of their time on purpose. (night.md and realism.md keep records of earlier runs too, but
// the files and tests they name are kept current: checked since the thirty-seventh session.)
std::vector<std::string> docs_without_history() {
  std::vector<std::string> out;
  for (const auto& f : kDocsWithCommands)
    if (f != "docs/benchmarks.md") out.push_back(f);
  return out;
}

}  // namespace

// Every source file the docs name (`sensor/glare.cpp`, `scripts/rccb_kodak.py`,
// `include/photosite/scene/rig.h`) is in the repository: a file moved or removed must not be left
// named where a reader looks for it (docs_without_history).
TEST(Docs, SourceFilesTheDocsNameExist) {
  static const std::regex path(
      R"((?:^|[\s`(])((?:scripts|bench|tests|sensor|scene|core|kernels|gpu|include|python|cli|cmake)/[A-Za-z0-9_./-]*\.(?:py|sh|cpp|h|glsl|comp|inc|cmake|in))(?=[\s`),;:.]|$))");
  // A file named alone in a code span (`frame_buffers.h`, `bench.cpp`) is some file of that name
  // in the tree (build outputs, .git and the demo's out/ left out).
  static const std::regex bare(R"([A-Za-z0-9_]+\.(?:py|sh|cpp|h|glsl|comp|inc))");
  std::set<std::string> names;
  for (auto it = fs::recursive_directory_iterator(kRoot); it != fs::recursive_directory_iterator(); ++it) {
    const std::string n = it->path().filename().string();
    if (it->is_directory() && (starts_with(n, "build") || n == ".git" || n == "out" || n == ".venv")) it.disable_recursion_pending();
    else names.insert(n);
  }
  size_t named = 0, alone = 0;
  for (const std::string& file : docs_without_history()) {
    const std::string text = slurp(kRoot / file);
    for (auto it = std::sregex_iterator(text.begin(), text.end(), path); it != std::sregex_iterator(); ++it) {
      ++named;
      EXPECT_TRUE(fs::exists(kRoot / (*it)[1].str())) << file << " names " << (*it)[1] << ", which is not in the repository";
    }
    for (const auto& span : code_spans(text))
      if (std::regex_match(span, bare)) {
        ++alone;
        EXPECT_TRUE(names.count(span)) << file << " names `" << span << "`, which no file in the repository is called";
      }
  }
  EXPECT_GT(named, 50u);  // the docs' paths were found
  EXPECT_GT(alone, 20u);
}

// docs/architecture.md's layer table lists the public API's headers: every header at the top of
// include/photosite/ is named there (the folders sensor/, scene/, gpu/ are named as folders).
TEST(Docs, ArchitectureNamesEveryPublicHeader) {
  const std::string arch = slurp(kRoot / "docs/architecture.md");
  const auto row = arch.substr(arch.find("| `include/photosite/` |"));
  const std::string table_row = row.substr(0, row.find('\n'));
  size_t headers = 0;
  for (const auto& e : fs::directory_iterator(kRoot / "include/photosite"))
    if (e.path().extension() == ".h") {
      ++headers;
      EXPECT_NE(table_row.find("`" + e.path().filename().string() + "`"), std::string::npos)
          << "docs/architecture.md's include/photosite/ row does not name " << e.path().filename();
    }
  EXPECT_GT(headers, 15u);
}

// Every test the docs (docs_without_history) cite as evidence exists: a GoogleTest `Suite.Name` (or
// `Suite.*`, `Suite.Prefix*`) code span is a TEST/TEST_F/TEST_P in tests/, a pytest name
// `test_...` a `def` in tests/python. A renamed or removed test must not be left as the proof of a
// claim. Read from the sources, so a test compiled out here (no Vulkan) still counts.
TEST(Docs, TestsTheDocsCiteExist) {
  std::string cpp, py;
  for (const auto& e : fs::recursive_directory_iterator(kRoot / "tests")) {
    if (e.path().extension() == ".cpp") cpp += slurp(e.path());
    if (e.path().extension() == ".py") py += slurp(e.path());
  }
  static const std::regex gtest(R"(([A-Z][A-Za-z0-9]*)\.([A-Z][A-Za-z0-9]*)?(\*)?)");
  static const std::regex pytest(R"(\btest_[a-z0-9_]+\b(?!\.py))");
  size_t cited = 0;
  for (const std::string& file : docs_without_history()) {
    const std::string text = slurp(kRoot / file);
    for (const auto& span : code_spans(text)) {
      std::smatch m;
      if (!std::regex_match(span, m, gtest) || (!m[2].matched && !m[3].matched)) continue;
      ++cited;
      // "TEST(Suite, Name)" or, for a pattern, "TEST(Suite, Prefix" (TEST_F and TEST_P too; the
      // sources write them so, one space after the comma).
      const std::string def = "(" + m[1].str() + ", " + m[2].str() + (m[3].matched ? "" : ")");
      bool found = false;
      for (const char* macro : {"TEST", "TEST_F", "TEST_P"}) found |= cpp.find(macro + def) != std::string::npos;
      EXPECT_TRUE(found) << file << " cites `" << span << "`, which no test in tests/ defines";
    }
    for (auto it = std::sregex_iterator(text.begin(), text.end(), pytest); it != std::sregex_iterator(); ++it) {
      const std::string name = (*it)[0];
      if (name == "test_api" || name == "test_docs" || name == "test_torch") continue;  // the files, named without .py
      ++cited;
      EXPECT_NE(py.find("def " + name + "("), std::string::npos) << file << " cites " << name << ", which no test in tests/python defines";
    }
  }
  EXPECT_GT(cited, 80u);  // the citations were found
}

// docs/emva1288.md's Results block is what `characterize --preset NAME --backend cpu` prints
// today, character for character, for each preset it shows: the measurement is deterministic
// (fixed seeds; the device's map is generated from its id, so a fresh store gives the same map),
// so a changed camera model, fit or table layout must re-run the block, not leave an old one as
// today's. The "created the fixed-pattern map" note (stderr, the store's path) is left out.
TEST(Docs, EmvaResultsBlockIsWhatCharacterizePrints) {
  const std::string results = section(slurp(kRoot / "docs/emva1288.md"), "## Results (this build; AMD EPYC, 2 hardware threads)");
  const auto b = results.find("\n```\n"), e = results.find("\n```\n", b + 1);
  ASSERT_TRUE(b != std::string::npos && e != std::string::npos);
  const std::string block = results.substr(b + 5, e - b - 4);  // its lines, each ending in '\n'
  TempDir tmp;
  size_t shown = 0;
  for (size_t at = 0; at < block.size();) {
    size_t end = block.find("\n\n", at);
    if (end == std::string::npos) end = block.size() - 1;
    const std::string doc = block.substr(at, end + 1 - at);
    at = end + 2;
    static const std::regex first(R"(^EMVA 1288 R4\.0 photon transfer: (\S+) \(device)");
    std::smatch m;
    ASSERT_TRUE(std::regex_search(doc, m, first)) << doc;
    const auto r = run_cli("characterize --preset " + m[1].str() + " --backend cpu --device-store " + tmp.file("store"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    std::string printed;
    for (const auto& l : lines_of(r.output))
      if (!starts_with(l, "photosite: ")) printed += l + "\n";
    EXPECT_EQ(printed, doc) << "docs/emva1288.md's block for " << m[1] << " is not what characterize prints";
    ++shown;
  }
  EXPECT_EQ(shown, 3u);
}

// chart's header is the one docs/cli.md's chart section names, both ways; demosaic's output keys
// are named in its section, and every key the section names is in its output or (read from a
// photosite raw mosaic) in its input.
TEST(Docs, ChartAndDemosaicHeadersAreDocumented) {
  TempDir tmp;
  ASSERT_EQ(run_cli("chart --width 64 --height 48 --out " + tmp.file("c.exr")).exit_code, 0);
  auto r = run_cli("expose --backend cpu --preset onsemi-ar0132at-rccc --layers raw --radiance " + tmp.file("c.exr") +
                   " --out " + tmp.file("raw.exr"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = run_cli("demosaic --backend cpu --white-level 3000 --in " + tmp.file("raw.exr") + " --out " + tmp.file("d.exr"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto c = photosite::read_exr(tmp.file("c.exr"));
  const auto raw = photosite::read_exr_attributes(tmp.file("raw.exr"));
  const auto d = photosite::read_exr(tmp.file("d.exr"));
  const std::string cli = slurp(kRoot / "docs/cli.md");

  EXPECT_EQ(named_keys(section(cli, "## chart")), photosite_keys(c.attributes));
  EXPECT_EQ(keys_of(c.channels), (std::set<std::string>{"R", "G", "B"}));
  for (const auto& [n, _] : c.channels) EXPECT_TRUE(c.attributes.count("photosite/unit/" + n)) << n;

  const auto named = named_keys(section(cli, "## demosaic"));
  for (const auto& k : photosite_keys(d.attributes)) EXPECT_TRUE(named.count(k)) << k << " is written but not in docs/cli.md's demosaic";
  for (const auto& k : named)
    EXPECT_TRUE(d.attributes.count(k) || raw.count(k)) << "docs/cli.md's demosaic names " << k << ", in neither its input nor its output";
  for (const auto& [n, _] : d.channels) EXPECT_TRUE(d.attributes.count("photosite/unit/" + n)) << n;
}

// batch's default layers are the set docs/cli.md gives ("for batch it is `sensor,raw,...`"): a
// batch run with no --layers writes the channels night writes with --layers set to that list, and
// records the list in its resume manifest.
TEST(Docs, BatchDefaultLayersAreTheDocumentedOnes) {
  const std::string cli = slurp(kRoot / "docs/cli.md");
  const auto at = cli.find("for batch it is `");
  ASSERT_NE(at, std::string::npos);
  const auto b = cli.find('`', at) + 1;
  const std::string layers = cli.substr(b, cli.find('`', b) - b);
  TempDir tmp;
  const std::string sample = kRoot.string() + "/samples/kitti/";
  {
    std::ofstream m(tmp.file("m.txt"));
    m << sample << "image_2/000000_10.png " << sample << "semantic/000000_10.png\n";
  }
  auto r = run_cli("batch --backend cpu --quiet --manifest " + tmp.file("m.txt") + " --out " + tmp.file("out"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = run_cli("night --backend cpu --layers " + layers + " --image " + sample + "image_2/000000_10.png --labels " + sample +
              "semantic/000000_10.png --out " + tmp.file("n.exr"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::string exr;
  for (const auto& e : fs::recursive_directory_iterator(tmp.path() / "out"))
    if (e.path().extension() == ".exr") exr = e.path().string();
  ASSERT_FALSE(exr.empty());
  EXPECT_EQ(keys_of(photosite::read_exr(exr).channels), keys_of(photosite::read_exr(tmp.file("n.exr")).channels)) << layers;
  EXPECT_NE(slurp(tmp.path() / "out/.photosite-batch/shard-0-of-1.jsonl").find("\"layers\":\"" + layers + "\""), std::string::npos);
}

// batch's resume manifest (OUT/.photosite-batch/shard-I-of-N.jsonl) has the keys docs/cli.md's
// "Resume manifest keys" paragraph names, both ways: the parameter record's (with the four written
// only when set: --sequence, its odometry, a KITTI drive's calibration (a second run) and a lamp
// type other than LED), the "writing" record's,
// the finished record's and its files' (with an item's Cityscapes camera file, whose checksum is
// recorded, and its vehicle and timestamp files, which --sequence reads), the odometry sources'
// of a Cityscapes frame and of a KITTI frame with OXTS and calibration files, and a failed
// sequence frame's record.
TEST(Docs, BatchResumeManifestKeysAreTheDocumentedOnes) {
  const std::string cli = slurp(kRoot / "docs/cli.md");
  const auto at = cli.find("**Resume manifest keys**");
  ASSERT_NE(at, std::string::npos);
  const std::string para = cli.substr(at, cli.find("\n\n", at) - at);
  std::set<std::string> documented;
  static const std::regex ident(R"([a-z][a-z0-9_]*)"), quoted(R"re("([a-z][a-z0-9_]*)")re");
  for (const auto& s : code_spans(para)) {
    if (std::regex_match(s, ident)) documented.insert(s);
    for (std::sregex_iterator m(s.begin(), s.end(), quoted), end; m != end; ++m) documented.insert((*m)[1]);
  }
  // A one-frame Cityscapes layout with the frame's camera file (the bundled KITTI frame as its image).
  TempDir tmp;
  const fs::path root = tmp.path() / "cs", sample = kRoot / "samples/kitti";
  for (const char* d : {"leftImg8bit/val/city", "gtFine/val/city", "camera/val/city", "vehicle/val/city", "timestamp/val/city"})
    fs::create_directories(root / d);
  fs::copy_file(sample / "image_2/000000_10.png", root / "leftImg8bit/val/city/city_000000_000019_leftImg8bit.png");
  fs::copy_file(sample / "semantic/000000_10.png", root / "gtFine/val/city/city_000000_000019_gtFine_labelIds.png");
  std::ofstream(root / "camera/val/city/city_000000_000019_camera.json")
      << R"({"extrinsic": {"pitch": 0.05, "x": 1.7, "y": 0.1, "yaw": -0.02, "z": 1.2}, "intrinsic": {"fx": 700, "fy": 700, "u0": 621, "v0": 187}})";
  std::ofstream(root / "vehicle/val/city/city_000000_000019_vehicle.json") << R"({"speed": 5.0, "yawRate": 0.01})";
  std::ofstream(root / "timestamp/val/city/city_000000_000019_timestamp.txt") << "0\n";
  const auto r = run_cli("batch --backend cpu --quiet --dataset cityscapes --root " + root.string() + " --out " +
                         tmp.file("out") + " --layers depth --sequence --streetlamp-type hps");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::set<std::string> written;
  // A record's keys, its objects' (the parameters, the odometry sources) and its arrays' objects' (files).
  auto collect = [&](const nlohmann::json& j) {
    for (const auto& [k, v] : j.items()) {
      written.insert(k);
      if (v.is_object())
        for (const auto& [k2, v2] : v.items()) written.insert(k2);
      if (v.is_array())
        for (const auto& e : v)
          if (e.is_object())
            for (const auto& [k2, v2] : e.items()) written.insert(k2);
    }
  };
  std::istringstream lines(slurp(tmp.path() / "out/.photosite-batch/shard-0-of-1.jsonl"));
  int records = 0;
  for (std::string l; std::getline(lines, l); ++records) collect(nlohmann::json::parse(l));
  EXPECT_EQ(records, 3);  // the parameters, "writing", the finished item
  // A one-frame KITTI drive with its OXTS record and calibration files (calib/<sub>/: the camera
  // at the OXTS unit, looking ahead), whose parameter record adds camera_mount.
  const fs::path kitti = tmp.path() / "kitti";
  for (const char* d : {"image_2/drive", "semantic/drive", "oxts/drive/data", "calib/drive"}) fs::create_directories(kitti / d);
  fs::copy_file(sample / "image_2/000000_10.png", kitti / "image_2/drive/0000000000.png");
  fs::copy_file(sample / "semantic/000000_10.png", kitti / "semantic/drive/0000000000.png");
  std::string oxts;
  for (int k = 0; k < 30; ++k) oxts += k < 29 ? "0 " : "0\n";
  std::ofstream(kitti / "oxts/drive/data/0000000000.txt") << oxts;
  std::ofstream(kitti / "oxts/drive/timestamps.txt") << "2011-09-26 13:02:25.964389445\n";
  std::ofstream(kitti / "calib/drive/calib_imu_to_velo.txt") << "R: 1 0 0 0 1 0 0 0 1\nT: 0 0 0\n";
  std::ofstream(kitti / "calib/drive/calib_velo_to_cam.txt") << "R: 0 -1 0 0 0 -1 1 0 0\nT: 0 0 0\n";
  std::ofstream(kitti / "calib/drive/calib_cam_to_cam.txt")
      << "R_rect_00: 1 0 0 0 1 0 0 0 1\nP_rect_02: 700 0 621 0 0 700 187 0 0 0 1 0\n";
  const auto rk = run_cli("batch --backend cpu --quiet --dataset kitti --root " + kitti.string() + " --out " +
                          tmp.file("kout") + " --layers depth --sequence");
  ASSERT_EQ(rk.exit_code, 0) << rk.output;
  // Then its frame's OXTS line broken: the frame fails, and its record is cancelled ("failed").
  std::ofstream(kitti / "oxts/drive/data/0000000000.txt") << "0 0\n";
  const auto rf = run_cli("batch --backend cpu --quiet --dataset kitti --root " + kitti.string() + " --out " +
                          tmp.file("kout") + " --layers depth --sequence");
  ASSERT_EQ(rf.exit_code, 2) << rf.output;
  std::istringstream klines(slurp(tmp.path() / "kout/.photosite-batch/shard-0-of-1.jsonl"));
  for (std::string l; std::getline(klines, l);) collect(nlohmann::json::parse(l));  // its frame's odometry sources too
  // A two-line manifest sequence with its own odometry fields: its items' records add odometry,
  // and (a sequence of two frames) sequence_frames_xxh3_64.
  {
    fs::copy_file(sample / "image_2/000000_10.png", tmp.path() / "second.png");  // an image is listed once
    std::ofstream m(tmp.path() / "m.txt");
    for (const auto& [image, t] : {std::pair{sample / "image_2/000000_10.png", "1"}, std::pair{tmp.path() / "second.png", "1.5"}})
      m << image.string() << " " << (sample / "semantic/000000_10.png").string() << " sequence=s time_s=" << t
        << " speed_m_s=5 yaw_rate_rad_s=0\n";
  }
  const auto rm = run_cli("batch --backend cpu --quiet --manifest " + (tmp.path() / "m.txt").string() + " --out " +
                          tmp.file("mout") + " --layers depth --sequence");
  ASSERT_EQ(rm.exit_code, 0) << rm.output;
  std::istringstream mlines(slurp(tmp.path() / "mout/.photosite-batch/shard-0-of-1.jsonl"));
  for (std::string l; std::getline(mlines, l);) {
    const auto j = nlohmann::json::parse(l);
    if (j.contains("key"))
      for (const auto& [k, v] : j.items()) written.insert(k);
  }
  for (const auto& k : documented) EXPECT_TRUE(written.count(k)) << "docs/cli.md names the resume manifest key " << k << ", which batch does not write";
  for (const auto& k : written) EXPECT_TRUE(documented.count(k)) << "batch's resume manifest has the key " << k << ", which docs/cli.md does not name";
}

// Every EXPECT_NEAR / ASSERT_NEAR in tests/*.cpp whose tolerance has a numeric literal in it
// (0.05, 5 * se, 0x1p-24) has a comment on its line or within the 3 lines above it (above the
// first of a run of consecutive EXPECT_/ASSERT_ lines): the developers' guide asks that every
// tolerance be derived, with the formula in a comment (docs/testing.md). A tolerance held in a
// named constant (kNearestTol) has its comment where the constant is defined. The test checks that
// a comment is there, not that it is right: docs/testing.md describes how the tolerances were
// read by hand.
namespace {
struct NearSite {
  int line;
  std::string tolerance;
};
// The NEARs of `text` whose tolerance has a literal and no comment near it; `checked` counts the
// NEARs read.
std::vector<NearSite> uncommented_literal_nears(const std::string& text, int* checked) {
  const std::vector<std::string> lines = lines_of(text);
  static const std::regex macro(R"(\b(EXPECT|ASSERT)_NEAR\s*\()");
  static const std::regex assertion(R"(^\s*(EXPECT|ASSERT)_)");
  static const std::regex literal(R"((^|[^A-Za-z0-9_.])[0-9])");
  std::vector<NearSite> out;
  for (size_t i = 0; i < lines.size(); ++i) {
    std::smatch m;
    if (!std::regex_search(lines[i], m, macro)) continue;
    // The macro's arguments, up to its closing parenthesis (over at most 8 lines).
    std::string rest = lines[i].substr(m.position(0) + m.length(0));
    for (size_t j = i + 1; j < std::min(lines.size(), i + 8); ++j) rest += "\n" + lines[j];
    std::vector<std::string> args(1);
    int depth = 0;
    for (char c : rest) {
      if (c == '(' || c == '[' || c == '{') ++depth;
      if (c == ')' || c == ']' || c == '}') {
        if (depth == 0) break;
        --depth;
      }
      if (c == ',' && depth == 0) args.emplace_back();
      else args.back() += c;
    }
    if (args.size() < 3) continue;
    ++*checked;
    if (!std::regex_search(args[2], literal)) continue;
    size_t first = i;  // the first line of the run of assertions this one ends
    while (first > 0 && std::regex_search(lines[first - 1], assertion)) --first;
    bool commented = lines[i].find("//") != std::string::npos;
    for (size_t k = first >= 3 ? first - 3 : 0; k < first; ++k) commented |= lines[k].find("//") != std::string::npos;
    if (!commented) out.push_back({static_cast<int>(i) + 1, args[2]});
  }
  return out;
}
}  // namespace

TEST(Docs, LiteralNearTolerancesHaveAComment) {
  // The scanner on a text made for it (the macro's name split so that this file's own scan does
  // not read these lines): a bare literal is caught, a commented one and a run under a comment
  // are not, a named tolerance is not counted.
  const std::string near = std::string("EXPECT_") + "NEAR(";
  const std::string sample = "  " + near + "a, 1.0, 0.05);\n"                // line 1: bare
                             "  // 5 SE of the mean\n"                        // line 2
                             "  " + near + "b, 1.0, 5 * se);\n"              // line 3: commented
                             "  " + near + "c, 1.0, 5 * se);\n"              // line 4: same run
                             "  x = 1;\n  y = 2;\n  z = 3;\n  w = 4;\n"        // lines 5-8
                             "  " + near + "d, f(1, 2), 2 * 0x1p-24);\n"     // line 9: 4 lines from the comment
                             "  " + near + "e, 1.0, kTol);\n";               // line 10: named
  int sample_checked = 0;
  const std::vector<NearSite> caught = uncommented_literal_nears(sample, &sample_checked);
  EXPECT_EQ(sample_checked, 5);
  ASSERT_EQ(caught.size(), 2u);
  EXPECT_EQ(caught[0].line, 1);
  EXPECT_EQ(caught[1].line, 9);
  EXPECT_EQ(caught[1].tolerance, " 2 * 0x1p-24");
  // The suite.
  int checked = 0;
  for (const auto& e : fs::directory_iterator(kRoot / "tests")) {
    if (e.path().extension() != ".cpp") continue;
    for (const NearSite& s : uncommented_literal_nears(slurp(e.path()), &checked))
      ADD_FAILURE() << "tests/" << e.path().filename().string() << ":" << s.line << ": the NEAR's tolerance"
                    << s.tolerance << " has no comment within 3 lines above it (derive it: docs/testing.md)";
  }
  EXPECT_GT(checked, 150);  // the suite's NEARs were found (202 on 2026-12-02)
}
