#pragma once
// Checks on the apps' options with messages a person can act on, a refusal of runs too large to be meant, and the
// clearing of what a run writes so that a reused --out holds no stale files.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <exception>
#include <initializer_list>
#include <new>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>

#include <unistd.h>

#include "mps/io/io.hpp"

inline std::string short_number(double v) {
  char s[32];
  std::snprintf(s, sizeof s, "%g", v);
  return s;
}

// A finite number in [lo, hi] ((lo, hi] with open_lo): "--width: must be a finite number in (0, 1000], got 'abc'".
inline CLI::Validator number_in(double lo, double hi, bool open_lo = false) {
  const std::string range = (open_lo ? "(" : "[") + short_number(lo) + ", " + short_number(hi) + "]";
  return CLI::Validator(
      [=](std::string& s) -> std::string {
        char* end = nullptr;
        errno = 0;
        const double v = std::strtod(s.c_str(), &end);
        const bool ok = !s.empty() && end == s.c_str() + s.size() && std::isfinite(v) && errno != ERANGE &&
                        (open_lo ? v > lo : v >= lo) && v <= hi;
        return ok ? std::string() : "must be a finite number in " + range + ", got '" + s + "'";
      },
      "in " + range);
}
inline CLI::Validator positive_up_to(double hi) { return number_in(0.0, hi, true); }

// A whole number in [lo, hi] ("50" and "5e1" alike).
inline CLI::Validator whole_in(double lo, double hi) {
  const std::string range = "[" + short_number(lo) + ", " + short_number(hi) + "]";
  return CLI::Validator(
      [=](std::string& s) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(s.c_str(), &end);
        const bool ok = !s.empty() && end == s.c_str() + s.size() && v >= lo && v <= hi && v == std::floor(v);
        return ok ? std::string() : "must be a whole number in " + range + ", got '" + s + "'";
      },
      "in " + range);
}

// A value that is exactly true or false: CLI11 also took 2, on, yes and an empty value as true.
inline CLI::Validator true_or_false() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        return s == "true" || s == "false" ? std::string() : "must be true or false, got '" + s + "'";
      },
      "");
}

// Every switch (a flag) of the app refuses a value other than true or false (--wet-walls=2 counted as on). Call it
// after the options are added.
inline void check_switches(CLI::App& app) {
  for (CLI::Option* option : app.get_options())
    if (option->get_expected_min() == 0 && option->get_name() != "--help" && option->get_name() != "--version")
      option->check(true_or_false());
}

// CLI11_PARSE with the apps' own checks: switches take true or false (check_switches), also refusing '=' and nothing
// (--wet-walls=, which CLI11 took as on). `quiet`: parse errors are not printed (the other MPI ranks of the one that
// prints them). Returns the exit status when the run ends here.
inline std::optional<int> parse_options(CLI::App& app, int argc, char** argv, bool quiet = false) {
  check_switches(app);
  try {
    for (int k = 1; k < argc; ++k) {
      const std::string arg = argv[k];
      if (arg.size() < 4 || arg.rfind("--", 0) != 0 || arg.back() != '=') continue;
      const CLI::Option* option = app.get_option_no_throw(arg.substr(0, arg.size() - 1));
      if (option != nullptr && option->get_expected_min() == 0)
        throw CLI::ValidationError(arg.substr(0, arg.size() - 1), "must be true or false, got ''");
    }
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (!quiet) return app.exit(e);
    std::ostringstream ignored;
    return app.exit(e, ignored, ignored);
  }
  return std::nullopt;
}

// An input file that exists, made absolute so that config.toml replays the run from any folder. Use as a transform.
inline CLI::Validator existing_file_made_absolute() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        if (s.empty()) return "the path is empty; name an existing file";
        std::error_code ec;
        const auto status = std::filesystem::status(s, ec);
        if (!std::filesystem::exists(status)) return "no file '" + s + "' exists";
        if (!std::filesystem::is_regular_file(status)) return "'" + s + "' is not a regular file";
        const std::filesystem::path absolute = std::filesystem::absolute(s, ec);
        if (ec) return "cannot resolve '" + s + "': " + ec.message();
        s = absolute.lexically_normal().string();
        return {};
      },
      "FILE");
}

namespace detail {
// The nearest part of `path` that exists must be a directory, or nothing could be made below it.
inline std::string output_parent_problem(const std::filesystem::path& path) {
  std::error_code ec;
  for (std::filesystem::path up = std::filesystem::absolute(path, ec).parent_path(); !up.empty();
       up = up.parent_path()) {
    const auto status = std::filesystem::status(up, ec);
    if (std::filesystem::exists(status))
      return std::filesystem::is_directory(status) ? std::string() : up.string() + " is not a directory";
    if (up == up.parent_path()) break;
  }
  return {};
}
}  // namespace detail

// --out: a directory, made if missing; refused if the path or a part of it exists and is not a directory.
inline CLI::Validator output_directory() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        try {
          mps::require_directory_path(s);
        } catch (const std::invalid_argument& e) {
          return e.what();
        }
        const std::string parent = detail::output_parent_problem(s);
        return parent.empty() ? std::string() : "cannot make the folder " + s + ": " + parent;
      },
      "DIR");
}

// An output file: refused if it exists and is not a regular file (a device, a FIFO, a folder), or cannot be made.
inline CLI::Validator output_file() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        try {
          mps::require_file_path(s);
        } catch (const std::invalid_argument& e) {
          return e.what();
        }
        const std::string parent = detail::output_parent_problem(s);
        return parent.empty() ? std::string() : "cannot write " + s + ": " + parent;
      },
      "FILE");
}

// Runs beyond these are refused up front with the estimate: more particles than this machine's memory holds at the
// 2 KB a particle takes at least (or 2e7), or more than 1e8 steps.
inline void check_run_size(double particles, double steps, const std::string& fewer_particles,
                           const std::string& fewer_steps) {
  constexpr double kBytesPerParticle = 2000, kMaxSteps = 1e8;
  const double memory = static_cast<double>(sysconf(_SC_PHYS_PAGES)) * static_cast<double>(sysconf(_SC_PAGE_SIZE));
  const double max_particles = std::min(2e7, memory / kBytesPerParticle);
  if (!(particles <= max_particles))
    throw std::invalid_argument("this run would hold about " + short_number(particles) + " particles (at least " +
                                short_number(particles * kBytesPerParticle / 1e9) + " GB; this machine has " +
                                short_number(memory / 1e9) + " GB), more than the " + short_number(max_particles) +
                                " a run may hold here: " + fewer_particles);
  if (!(steps <= kMaxSteps))
    throw std::invalid_argument("this run would take about " + short_number(steps) + " steps, more than the " +
                                short_number(kMaxSteps) + " a run may take: " + fewer_steps);
}

// Removes what an earlier run into `dir` wrote (the names a run owns), then makes sure `dir` exists.
inline void clear_outputs(const std::filesystem::path& dir, std::initializer_list<const char*> owned) {
  mps::require_directory_path(dir);
  try {
    for (const char* name : owned) std::filesystem::remove_all(dir / name);
    std::filesystem::create_directories(dir);
  } catch (const std::filesystem::filesystem_error& e) {
    throw std::runtime_error("cannot use the output folder " + dir.string() + " (" + e.code().message() +
                             "); choose another --out");
  }
}

// What an app prints for an error that ended it: std::bad_alloc's own text says nothing a person can act on.
inline std::string error_message(const std::exception& e) {
  if (dynamic_cast<const std::bad_alloc*>(&e))
    return "out of memory: the run needs more memory than this machine has; use fewer particles";
  return e.what();
}
