#pragma once
// Runs from files: --config reads an app's options from a TOML file (options on the command line override it), and
// every run writes its effective options, defaults included, to config.toml beside its summary, so that
// `app --config that/config.toml` repeats the run.
#include <CLI/CLI.hpp>
#include <cctype>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <map>
#include <memory>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>
#include <toml++/toml.h>

#include "mps/io/io.hpp"
#include "mps/version.hpp"

// The options whose values are paths: in a config file they are relative to the file's folder.
inline const std::set<std::string>& path_options() {
  static const std::set<std::string> names = {"out",   "data",           "particles", "restart",
                                              "write-particles", "probes", "scene-file"};
  return names;
}

// An option's section in config.toml: its --help group, in lower case ("Numerics" -> [numerics]).
inline std::string section_of(const CLI::Option& option) {
  std::string name = option.get_group();
  for (char& c : name) c = c == ' ' ? '-' : static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return name;
}

// Config files are TOML, read by toml++ (Debian's libtomlplusplus): one [section] per --help group ([scene],
// [numerics], [solver], [run], [output], [general]), or every key at the top level as the files written before the
// sections. A syntax error, a key that is no option, an option in another group's section, a key set twice and a
// switch that is not true or false are refused, naming the line (docs/config-files.md).
class StrictConfig : public CLI::ConfigBase {
 public:
  explicit StrictConfig(CLI::App& app) : app_(&app) {}

  std::vector<CLI::ConfigItem> from_config(std::istream& input) const override {
    const std::string text{std::istreambuf_iterator<char>(input), std::istreambuf_iterator<char>()};
    toml::table table;
    try {
      table = toml::parse(text, file());
    } catch (const toml::parse_error& e) {
      throw CLI::ConfigError("config file " + file() + ", line " + std::to_string(e.source().begin.line) +
                             ", column " + std::to_string(e.source().begin.column) + ": " +
                             std::string(e.description()));
    }
    std::vector<CLI::ConfigItem> read;
    std::map<std::string, int> first_line;
    std::set<std::string> groups;
    for (const CLI::Option* option : app_->get_options()) groups.insert(section_of(*option));
    for (auto&& [key, node] : table) {
      if (const toml::table* section = node.as_table()) {
        if (groups.count(std::string(key.str())) == 0) {
          std::string known;
          for (const std::string& g : groups) known += (known.empty() ? "[" : ", [") + g + "]";
          fail(node, "[" + std::string(key.str()) + "] is no group of this app's options (" + known + ")");
        }
        for (auto&& [inner, value] : *section)
          add(read, first_line, std::string(key.str()), std::string(inner.str()), value);
      } else {
        add(read, first_line, "", std::string(key.str()), node);
      }
    }
    return read;
  }

 private:
  [[noreturn]] void fail(const toml::node& at, const std::string& what) const {
    throw CLI::ConfigError("config file " + file() + ", line " + std::to_string(at.source().begin.line) + ": " + what);
  }

  // One value as CLI11 reads it from the command line: a number to its last bit, true or false, a string (a path
  // relative to the file's folder).
  std::string scalar(const std::string& key, const toml::node& value) const {
    if (const auto* s = value.as_string()) {
      std::string text = s->get();
      if (path_options().count(key) != 0 && !text.empty() && std::filesystem::path(text).is_relative()) {
        const std::filesystem::path folder = std::filesystem::path(file()).parent_path();
        text = (folder / text).lexically_normal().string();
      }
      return text;
    }
    if (const auto* i = value.as_integer()) return std::to_string(i->get());
    if (const auto* f = value.as_floating_point()) {  // the shortest text that gives the same bits back
      char number[32];
      const auto written = std::to_chars(number, number + sizeof number, f->get(), std::chars_format::general);
      return std::string(number, written.ptr);
    }
    if (const auto* b = value.as_boolean()) return b->get() ? "true" : "false";
    fail(value, "the value of '" + key + "' must be a number, true or false, a \"quoted string\" or an [array] of them");
  }

  void add(std::vector<CLI::ConfigItem>& read, std::map<std::string, int>& first_line, const std::string& section,
           const std::string& key, const toml::node& value) const {
    const int line = static_cast<int>(value.source().begin.line);
    const CLI::Option* option = app_->get_option_no_throw("--" + key);
    if (option == nullptr) option = app_->get_option_no_throw(key);  // a positional (sparsemps-run's scene file)
    if (option == nullptr || key == "config")
      fail(value, "'" + key + "' is not an option of this app (--help lists them, without their leading --)");
    if (!section.empty() && section_of(*option) != section)
      fail(value, "'" + key + "' is an option of [" + section_of(*option) + "], not of [" + section + "]");
    if (const auto seen = first_line.find(key); seen != first_line.end())
      fail(value, "'" + key + "' is set again (first on line " + std::to_string(seen->second) + "); keep one");
    first_line.emplace(key, line);
    CLI::ConfigItem item;
    item.name = key;
    if (const toml::array* array = value.as_array()) {
      for (const toml::node& element : *array) item.inputs.push_back(scalar(key, element));
    } else {
      item.inputs.push_back(scalar(key, value));
    }
    // A flag counts its occurrences, so CLI11 took "2" as on.
    if (option->get_expected_min() == 0 && (!value.is_boolean()))
      fail(value, "'" + key + "' is a switch: its value is true or false");
    read.push_back(std::move(item));
  }

  [[nodiscard]] std::string file() const {
    const CLI::Option* option = app_->get_config_ptr();
    return option != nullptr && !option->results().empty() ? option->results().front() : std::string("(unnamed)");
  }

  CLI::App* app_;
};

// --config FILE: a regular file of at most 1 MB, checked before it is opened (a FIFO would block the open, /dev/zero
// never end; an app's config.toml is under 2 kB).
inline CLI::Validator config_file_path() {
  return CLI::Validator(
      [](std::string& path) -> std::string {
        if (path.empty()) return "the path is empty; name a config file";
        std::error_code ec;
        const auto status = std::filesystem::status(path, ec);
        if (!std::filesystem::exists(status)) return "no file '" + path + "' exists";
        if (!std::filesystem::is_regular_file(status)) return "'" + path + "' is not a regular file";
        const auto bytes = std::filesystem::file_size(path, ec);
        if (ec || bytes > (1u << 20))
          return "'" + path + "' holds " + std::to_string(bytes) + " bytes; a config file is a few kB (is it the right file?)";
        return {};
      },
      "FILE");
}

inline void add_config_option(CLI::App& app) {
  app.set_config("--config", "",
                 "read the options from a TOML file, such as the config.toml every run writes beside its summary "
                 "(options given on the command line override the file's)")
      ->check(config_file_path())
      ->group("General");
  app.config_formatter(std::make_shared<StrictConfig>(app));
  app.allow_config_extras(CLI::config_extras_mode::error);  // a misspelt key is an error, not a silent default
}

// config.toml: every option of the run, defaults included, in a [section] per --help group with each option's unit
// as a comment, paths relative to the file's folder. An option whose default depends on others (a spacing per scene)
// has no default string and is left out when not given, so that the replay derives it again.
inline void write_run_config(const CLI::App& app, const std::string& name, const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  std::map<std::string, std::string> values;  // key -> value as CLI11 writes it
  std::istringstream all(app.config_to_str(true, false));
  for (std::string line; std::getline(all, line);) {
    const std::size_t eq = line.find('=');
    if (eq == std::string::npos || line.compare(eq, std::string::npos, "=\"\"") == 0) continue;
    values.emplace(line.substr(0, eq), line.substr(eq + 1));
  }
  static const std::regex unit_at_end(R"(\[([^\]]+)\]\s*$)");
  std::vector<std::string> order;
  std::map<std::string, std::string> sections;
  for (const CLI::Option* option : app.get_options()) {
    const std::string key = option->get_name(false, true).substr(option->get_name(false, true).find_first_not_of('-'));
    const auto found = values.find(key);
    if (found == values.end()) continue;
    std::string value = found->second;
    if (path_options().count(key) != 0 && value.size() >= 2 && value.front() == '"') {
      const fs::path path = nlohmann::json::parse(value).get<std::string>();
      value = nlohmann::json(fs::relative(fs::absolute(path), fs::absolute(dir)).string()).dump();
    }
    std::string line = key + " = " + value;
    std::smatch unit;
    const std::string description = option->get_description();
    if (std::regex_search(description, unit, unit_at_end)) line += "  # [" + unit[1].str() + "]";
    const std::string section = section_of(*option);
    if (sections.count(section) == 0) order.push_back(section);
    sections[section] += line + "\n";
  }
  std::string text = "# " + name + ", SparseMPS " + mps::version +
                     ": the run's options; repeat it with --config this-file (options on the command line override\n"
                     "# it; paths are relative to this file's folder)\n";
  for (const std::string& section : order) text += "\n[" + section + "]\n" + sections[section];
  mps::write_text(dir / "config.toml", text);
}
