#pragma once
// Runs from files: --config reads an app's options from a TOML file (options on the command line override it), and
// every run writes its effective options, defaults included, to config.toml beside its summary, so that
// `app --config that/config.toml` repeats the run.
#include <CLI/CLI.hpp>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <map>
#include <memory>
#include <regex>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "mps/io/io.hpp"
#include "mps/version.hpp"

// The part of TOML the apps write, read strictly: one `key = value` per line (a number, true or false, a "string"
// or 'string', or a one-line [array] of them), comments and blank lines. Anything else is refused with its line:
// CLI11's own reader kept the first of a repeated key, skipped malformed lines and took an unterminated string
// literally (docs/config-files.md).
class StrictConfig : public CLI::ConfigBase {
 public:
  explicit StrictConfig(CLI::App& app) : app_(&app) {}

  std::vector<CLI::ConfigItem> from_config(std::istream& input) const override {
    std::string text{std::istreambuf_iterator<char>(input), std::istreambuf_iterator<char>()};
    if (text.rfind("\xEF\xBB\xBF", 0) == 0) text.erase(0, 3);  // a byte-order mark some editors write
    std::vector<CLI::ConfigItem> read;
    std::map<std::string, int> first_line;
    std::istringstream lines(text);
    int number = 0;
    for (std::string line; std::getline(lines, line);) {
      ++number;
      const Line at{this, number};
      if (!line.empty() && line.back() == '\r') line.pop_back();
      for (std::size_t k = 0; k < line.size(); ++k) {
        const auto c = static_cast<unsigned char>(line[k]);
        if ((c < 0x20 && c != '\t') || c == 0x7f) {
          char code[8];
          std::snprintf(code, sizeof code, "0x%02X", c);
          at.fail("column " + std::to_string(k + 1) + " holds the control character " + code +
                  (c == 0 ? " (NUL)" : "") + "; the file must be plain text");
        }
      }
      std::size_t i = skip_space(line, 0);
      if (i == line.size() || line[i] == '#') continue;
      if (line[i] == '[')
        at.fail("sections ('" + line.substr(i) + "') are not read; every option is a top-level 'key = value' line");
      const std::size_t key_start = i;
      while (i < line.size() && (std::isalnum(static_cast<unsigned char>(line[i])) || line[i] == '-' || line[i] == '_'))
        ++i;
      const std::string key = line.substr(key_start, i - key_start);
      i = skip_space(line, i);
      if (key.empty() || i == line.size() || line[i] != '=')
        at.fail("expected 'key = value', got '" + line.substr(key_start) + "'");
      i = skip_space(line, i + 1);
      CLI::ConfigItem item;
      item.name = key;
      if (i < line.size() && line[i] == '[') {
        i = skip_space(line, i + 1);
        while (i < line.size() && line[i] != ']') {
          item.inputs.push_back(at.scalar(key, line, i));
          i = skip_space(line, i);
          if (i < line.size() && line[i] == ',') i = skip_space(line, i + 1);
          else if (i == line.size() || line[i] != ']') at.fail("the array of '" + key + "' is not closed with ']'");
        }
        if (i == line.size()) at.fail("the array of '" + key + "' is not closed with ']' on its line");
        ++i;
      } else {
        item.inputs.push_back(at.scalar(key, line, i));
      }
      i = skip_space(line, i);
      if (i < line.size() && line[i] != '#')
        at.fail("unexpected text after the value of '" + key + "': '" + line.substr(i) + "'");
      if (const auto seen = first_line.find(key); seen != first_line.end())
        at.fail("'" + key + "' is set again (first on line " + std::to_string(seen->second) + "); keep one");
      first_line.emplace(key, number);
      const CLI::Option* option = app_->get_option_no_throw("--" + key);
      if (option == nullptr || key == "config")
        at.fail("'" + key + "' is not an option of this app (--help lists them, without their leading --)");
      // A flag counts its occurrences, so CLI11 took "2" as on.
      if (option->get_expected_min() == 0 &&
          (item.inputs.size() != 1 || (item.inputs[0] != "true" && item.inputs[0] != "false")))
        at.fail("'" + key + "' is a switch: its value is true or false");
      read.push_back(std::move(item));
    }
    return read;
  }

 private:
  struct Line {
    const StrictConfig* config;
    int number;

    [[noreturn]] void fail(const std::string& what) const {
      throw CLI::ConfigError("config file " + config->file() + ", line " + std::to_string(number) + ": " + what);
    }

    // A string, a number, true or false, from line[i]; i moves past it.
    std::string scalar(const std::string& key, const std::string& line, std::size_t& i) const {
      if (i == line.size() || line[i] == '#') fail("'" + key + "' has no value");
      const char quote = line[i];
      if (quote == '"' || quote == '\'') {
        std::string value;
        for (++i; i < line.size() && line[i] != quote; ++i) {
          if (quote == '"' && line[i] == '\\') {
            if (++i == line.size()) break;
            const char e = line[i];
            if (e == '"' || e == '\\') value += e;
            else if (e == 't') value += '\t';
            else if (e == 'n') value += '\n';
            else fail("the string of '" + key + "' holds the escape '\\" + std::string(1, e) +
                      "'; write \\\\ for a backslash");
          } else {
            value += line[i];
          }
        }
        if (i == line.size()) fail("the string of '" + key + "' is not closed with " + std::string(1, quote));
        ++i;
        return value;
      }
      const std::size_t start = i;
      while (i < line.size() && line[i] != ',' && line[i] != ']' && line[i] != '#' &&
             !std::isspace(static_cast<unsigned char>(line[i])))
        ++i;
      const std::string word = line.substr(start, i - start);
      static const std::regex number_or_switch(
          "true|false|[+-]?([0-9]+(\\.[0-9]*)?|\\.[0-9]+)([eE][+-]?[0-9]+)?|[+-]?(inf|nan)");
      if (!std::regex_match(word, number_or_switch))
        fail("the value of '" + key + "' must be a number, true or false, a \"quoted string\" or an [array]; got '" +
             line.substr(start) + "'");
      return word;
    }
  };

  static std::size_t skip_space(const std::string& line, std::size_t i) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    return i;
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

// An option whose default depends on others (a spacing per scene) has no default string and is left out when not
// given, so that the replay derives it again.
inline void write_run_config(const CLI::App& app, const std::string& name, const std::filesystem::path& dir) {
  std::istringstream all(app.config_to_str(true, false));
  std::string text =
      "# " + name + ", SparseMPS " + mps::version + ": the run's options; repeat it with --config this-file\n";
  for (std::string line; std::getline(all, line);)
    if (line.size() < 3 || line.compare(line.size() - 3, 3, "=\"\"") != 0) text += line + "\n";
  mps::write_text(dir / "config.toml", text);
}
