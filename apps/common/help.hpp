#pragma once
// --help in option groups (General, Scene, Numerics, Solver, Run, Output), each option shown as --name=DEFAULT [unit]
// (or --name TYPE [unit] where the default depends on other options), its description and its range. An option's
// unit is the trailing [unit] of its description, so that the description says it once.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstddef>
#include <memory>
#include <regex>
#include <string>
#include <utility>
#include <vector>

#include "mps/version.hpp"
#include "run_config.hpp"

class GroupedHelp : public CLI::Formatter {
 public:
  GroupedHelp() { column_width(kColumn); }

  // One blank line between groups: CLI11 puts one after each group and one before it.
  std::string make_group(std::string group, bool is_positional, std::vector<const CLI::Option*> opts) const override {
    std::string text = group + ":\n";
    for (const CLI::Option* opt : opts) text += make_option(opt, is_positional);
    return text;
  }
  std::string make_usage(const CLI::App* app, std::string name) const override {
    return CLI::Formatter::make_usage(app, std::move(name)) + "\n";
  }

  std::string make_option_opts(const CLI::Option* opt) const override {
    if (opt->get_type_size() == 0) return "";  // a flag
    const auto [description, unit] = split_unit(opt->get_description());
    std::string text;
    if (!opt->get_default_str().empty())
      text = "=" + opt->get_default_str();
    else
      text = " " + type_of(opt) + (opt->get_expected_max() > 1 ? ",..." : "");
    return text + (unit.empty() ? "" : " [" + unit + "]");
  }

  std::string make_option_desc(const CLI::Option* opt) const override {
    std::string text = split_unit(opt->get_description()).first;
    // The range from the option's check ("in (0, 1000]"); a set of names is in the description already.
    const std::string type = opt->get_type_name();
    const std::size_t colon = type.find(':');
    if (colon != std::string::npos) {
      std::string range = type.substr(colon + 1);
      for (const char* word : {"INT ", "FLOAT ", "UINT "})
        if (range.rfind(word, 0) == 0) range = range.substr(std::string(word).size());
      std::replace(range.begin(), range.end(), ' ', '\x01');  // a range is not broken across lines
      if (range.rfind("in\x01", 0) == 0) text += "; " + range;  // a set of names or FILE says nothing more
    }
    text = wrap(text, kWidth - kColumn);
    std::replace(text.begin(), text.end(), '\x01', ' ');
    return text;
  }

  // "channel width D [m]" -> ("channel width D", "m"); a bracket that does not start with a letter is not a unit.
  static std::pair<std::string, std::string> split_unit(const std::string& description) {
    static const std::regex trailing("^(.*?) ?\\[([A-Za-z][A-Za-z0-9^/ ]*)\\]$");
    std::smatch m;
    if (std::regex_match(description, m, trailing)) return {m[1].str(), m[2].str()};
    return {description, ""};
  }

 private:
  static constexpr std::size_t kColumn = 36, kWidth = 112;

  // Words to lines of at most `width` characters (CLI11 indents each line after a newline to the column).
  static std::string wrap(const std::string& text, std::size_t width) {
    std::string out, line;
    std::size_t at = 0;
    while (at < text.size()) {
      std::size_t end = text.find(' ', at);
      if (end == std::string::npos) end = text.size();
      const std::string word = text.substr(at, end - at);
      if (!line.empty() && line.size() + 1 + word.size() > width) {
        out += line + "\n";
        line.clear();
      }
      line += (line.empty() ? "" : " ") + word;
      at = end + 1;
    }
    return out + line;
  }

  // FLOAT, INT, TEXT, or the check's own word where it names a kind of text (FILE, DIR).
  static std::string type_of(const CLI::Option* opt) {
    const std::string type = opt->get_type_name();
    const std::size_t colon = type.find(':');
    const std::string check = colon == std::string::npos ? "" : type.substr(colon + 1);
    if (!check.empty() && std::all_of(check.begin(), check.end(), [](char c) { return c >= 'A' && c <= 'Z'; }))
      return check;
    return type.substr(0, colon);
  }
};

// --dim in an app whose scenes are 2-D only: 2 is taken, 3 is refused with `why` (what is 2-D, and where 3-D is), so
// that a user asking for 3-D learns what exists instead of meeting "argument not expected".
inline void add_two_d_only_option(CLI::App& app, const std::string& why) {
  app.add_option("--dim")
      ->description("the dimension: 2 only (" + why + ")")
      ->default_str("2")
      ->check(CLI::Validator(
          [why](std::string& value) { return value == "2" ? std::string() : "this app is 2-D only: " + why; }, "2"))
      ->group("Scene");
}

// What every app offers first: grouped --help, --version and --config, in the group "General".
inline void add_general_options(CLI::App& app) {
  app.formatter(std::make_shared<GroupedHelp>());
  app.get_help_ptr()->group("General");
  app.set_version_flag("--version", std::string("SparseMPS ") + mps::version)->group("General");
  add_config_option(app);
}
