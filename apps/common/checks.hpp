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
#include <stdexcept>
#include <string>

#include <unistd.h>

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
  for (const char* name : owned) std::filesystem::remove_all(dir / name);
  std::filesystem::create_directories(dir);
}

// What an app prints for an error that ended it: std::bad_alloc's own text says nothing a person can act on.
inline std::string error_message(const std::exception& e) {
  if (dynamic_cast<const std::bad_alloc*>(&e))
    return "out of memory: the run needs more memory than this machine has; use fewer particles";
  return e.what();
}
