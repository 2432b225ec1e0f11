#pragma once
// Runs from files: --config reads an app's options from a TOML file (options on the command line override it), and
// every run writes its effective options, defaults included, to config.toml beside its summary, so that
// `app --config that/config.toml` repeats the run.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <sstream>
#include <string>

#include "mps/io.hpp"
#include "mps/version.hpp"

inline void add_config_option(CLI::App& app) {
  app.set_config("--config", "",
                 "read the options from a TOML file, such as the config.toml every run writes beside its summary "
                 "(options given on the command line override the file's)")
      ->group("General");
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
