#pragma once
// What an app prints while it runs: a compact table of its parameters at the start, and its progress. The full
// parameters are in summary.json and config.toml; the table shows the ones a person checks before waiting on a run.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <regex>
#include <string>
#include <utility>
#include <vector>
#include <nlohmann/json.hpp>

// Whether progress may redraw one line in place: stdout is a terminal (`is_tty`) and no MPI launcher started the
// process. Under mpirun a rank's stdout is a pseudo-terminal even when mpirun's own output goes to a log file, which
// then filled with carriage returns and escape sequences.
inline bool redraw_in_place(bool is_tty) {
  for (const char* launcher : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "MPI_LOCALNRANKS"})
    if (std::getenv(launcher) != nullptr) return false;
  return is_tty;
}

// Progress on stdout. On a terminal: one line rewritten in place (\r) with the simulated time against the end, the
// per cent done, the steps, the wall time and the time left at the pace so far. Otherwise (a log file, a pipe): a
// plain line every `interval` seconds of wall time and always a last one, so that a long run reports at a steady
// pace and a short one prints one line.
class Progress {
 public:
  using Clock = std::function<double()>;  // wall seconds from any origin

  // end: the simulated time the run stops at, in `unit` (the unit the app's own lines use, such as s or D/U).
  Progress(double end, std::string unit, double interval = 10.0)
      : Progress(end, std::move(unit), interval, redraw_in_place(isatty(fileno(stdout)) != 0), stdout, steady_seconds) {}
  Progress(double end, std::string unit, double interval, bool terminal, std::FILE* out, Clock clock)
      : end_(end), unit_(std::move(unit)), interval_(interval), terminal_(terminal), out_(out),
        clock_(std::move(clock)), start_(clock_()), next_(start_ + interval) {}

  // After each step: time in the unit given, steps taken so far.
  void update(double time, long steps) {
    if (!started_) {
      started_ = true;
      time0_ = time;
      wall0_ = clock_();
    }
    const double now = clock_();
    if (terminal_) {
      if (!drawn_ || now - drawn_at_ >= kRedraw) draw(time, steps, now, false);
    } else if (now >= next_) {
      draw(time, steps, now, false);
      while (next_ <= now) next_ += interval_;
    }
  }

  // Before the app prints a line of its own: takes the in-place line off the terminal (the next update redraws it).
  void clear() {
    if (terminal_ && drawn_) std::fputs("\r\033[K", out_);
    drawn_ = false;
  }

  // At the end of the run (or where the guard stopped it): the last line, with the wall time it took.
  void finish(double time, long steps) {
    if (finished_) return;
    finished_ = true;
    draw(time, steps, clock_(), true);
  }

  // Wall seconds as m:ss, or h:mm:ss from an hour.
  static std::string duration(double seconds) {
    const long s = std::lround(std::max(0.0, seconds));
    char text[32];
    if (s >= 3600)
      std::snprintf(text, sizeof text, "%ld:%02ld:%02ld", s / 3600, s / 60 % 60, s % 60);
    else
      std::snprintf(text, sizeof text, "%ld:%02ld", s / 60, s % 60);
    return text;
  }

 private:
  static constexpr double kRedraw = 0.25;  // a terminal line redrawn at most this often [s]

  static double steady_seconds() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  }

  void draw(double time, long steps, double now, bool last) {
    const double wall = now - start_;
    const double done = end_ > 0 ? std::clamp(time / end_, 0.0, 1.0) : 1.0;
    std::string clock;
    if (last) {
      clock = "done in " + duration(wall);
    } else if (time > time0_ && now > wall0_) {
      // The remaining simulated time at the pace since the first step (set-up before it is not counted).
      clock = "wall " + duration(wall) + "  ETA " + duration((end_ - time) * (now - wall0_) / (time - time0_));
    } else {
      clock = "wall " + duration(wall) + "  ETA --";
    }
    char line[256];
    std::snprintf(line, sizeof line, "t = %.4g / %.4g %s  %5.1f %%  step %ld  %s", time, end_, unit_.c_str(),
                  100 * done, steps, clock.c_str());
    if (terminal_)
      std::fprintf(out_, "\r%s\033[K%s", line, last ? "\n" : "");
    else
      std::fprintf(out_, "progress: %s\n", line);
    std::fflush(out_);
    drawn_ = terminal_ && !last;
    drawn_at_ = now;
  }

  double end_;
  std::string unit_;
  double interval_;
  bool terminal_;
  std::FILE* out_;
  Clock clock_;
  double start_, next_, time0_ = 0, wall0_ = 0, drawn_at_ = 0;
  bool started_ = false, drawn_ = false, finished_ = false;
};

// A summary key's name and unit for people: "nu_m2_per_s" -> ("nu", "m^2/s"), "end_time_D_over_U" -> ("end time",
// "D/U"), "station_D" -> ("station", "D"), "gamma" -> ("gamma", ""). The suffixes are the summaries' naming rule
// (docs/config-files.md).
inline std::pair<std::string, std::string> name_and_unit(const std::string& key) {
  static const std::vector<std::pair<std::string, std::string>> si = {
      {"_m_per_s2", "m/s^2"}, {"_m2_per_s", "m^2/s"}, {"_kg_per_m3", "kg/m^3"}, {"_rad_per_s", "rad/s"},
      {"_m_per_s", "m/s"},    {"_j_per_m", "J/m"},    {"_n_per_m", "N/m"},       {"_per_s", "1/s"},
      {"_m2", "m^2"},         {"_hz", "Hz"},          {"_rad", "rad"},           {"_pa", "Pa"},
      {"_m", "m"},            {"_s", "s"},            {"_l0", "l0"},             {"_D", "D"},
      {"_H", "H"}};
  auto spaced = [](std::string s) {
    std::replace(s.begin(), s.end(), '_', ' ');
    return s;
  };
  static const std::regex over("^(.+?)_((D|H|l0)_over_.+|over_.+)$");
  std::smatch m;
  if (std::regex_match(key, m, over)) {
    std::string unit = m[2].str();
    if (unit.rfind("over_", 0) == 0) unit = unit.substr(5);
    const std::size_t at = unit.find("_over_");
    if (at != std::string::npos) unit.replace(at, 6, "/");
    return {spaced(m[1].str()), spaced(unit)};
  }
  for (const auto& [suffix, unit] : si)
    if (key.size() > suffix.size() && key.compare(key.size() - suffix.size(), suffix.size(), suffix) == 0)
      return {spaced(key.substr(0, key.size() - suffix.size())), unit};
  return {spaced(key), ""};
}

// The value as the table shows it: numbers by %g, lists joined by commas.
inline std::string table_value(const nlohmann::json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_boolean()) return v.get<bool>() ? "yes" : "no";
  if (v.is_number()) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", v.get<double>());
    return text;
  }
  if (v.is_array()) {
    std::string s;
    for (const auto& item : v) s += (s.empty() ? "" : ", ") + table_value(item);
    return s;
  }
  return v.dump();
}

// The parameter table an app prints at its start: a title, then one line per group ("scene", "numerics", ...) of
// "name = value unit" cells taken from the summary's parameters by key ("radii/density_l0" for a nested one), in
// cells of a fixed width so that the lines align. Keys the run does not have are left out.
inline std::string parameter_table(const std::string& title, const nlohmann::json& params,
                                   const std::vector<std::pair<std::string, std::vector<std::string>>>& groups,
                                   std::size_t width = 100) {
  constexpr std::size_t kLabel = 11, kCell = 22;
  std::string text = title + "\n";
  for (const auto& [label, keys] : groups) {
    std::vector<std::string> cells;
    for (const std::string& path : keys) {
      const nlohmann::json* v = &params;
      std::string key;
      for (std::size_t at = 0; v != nullptr;) {
        const std::size_t slash = path.find('/', at);
        key = path.substr(at, slash == std::string::npos ? std::string::npos : slash - at);
        v = v->is_object() && v->contains(key) ? &v->at(key) : nullptr;
        if (slash == std::string::npos) break;
        at = slash + 1;
      }
      if (v == nullptr || v->is_null() || (v->is_array() && v->empty())) continue;
      const auto [name, unit] = name_and_unit(key);
      cells.push_back(name + " = " + table_value(*v) + (unit.empty() ? "" : " " + unit));
    }
    if (cells.empty()) continue;
    std::string line = "  " + label + std::string(kLabel - std::min(kLabel - 1, label.size()), ' ');
    const std::size_t indent = line.size();
    bool first = true;
    for (const std::string& cell : cells) {
      const std::size_t padded = (cell.size() + 2 + kCell - 1) / kCell * kCell;  // whole cells, two spaces apart
      if (!first && line.size() + cell.size() > width) {
        text += line.substr(0, line.find_last_not_of(' ') + 1) + "\n";
        line = std::string(indent, ' ');
      }
      line += cell + std::string(padded - cell.size(), ' ');
      first = false;
    }
    text += line.substr(0, line.find_last_not_of(' ') + 1) + "\n";
  }
  return text;
}
