#pragma once
// --probes FILE: the user's own probes, described in a TOML file (docs/probes.md) and sampled as the run goes into
// OUT/probes.csv by the library's probes (mps/io/probes.hpp). Every key is checked: a missing, unknown or ill-typed
// key, a point of the wrong dimension and a name taken twice are refused with the file's line and the key.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <toml++/toml.h>

#include "mps/core/kernel.hpp"
#include "mps/io/probes.hpp"
#include "mps/solids/fsi.hpp"
#include "mps/step/step.hpp"
#include "checks.hpp"
#include "run_config.hpp"
#include "run_json.hpp"

inline void add_probes_option(CLI::App& app, std::string& file) {
  app.add_option("--probes", file,
                 "sample the probes a TOML file describes (points, lines and planes of pressure, velocity, water "
                 "level or a wall group's force; docs/probes.md) into OUT/probes.csv")
      ->check(config_file_path())
      ->transform(existing_file_made_absolute())
      ->group("Output");
}

namespace probe_file_detail {

// `file` names the file as the messages do: "probe file P" or "scene file P".
[[noreturn]] inline void fail(const std::string& file, const toml::node& at, const std::string& what) {
  throw std::invalid_argument(file + ", line " + std::to_string(at.source().begin.line) + ": " +
                              what);
}

// The TOML file at `path`, its syntax errors named with the line and column.
inline toml::table parse(const std::string& file, const std::filesystem::path& path) {
  try {
    return toml::parse_file(path.string());
  } catch (const toml::parse_error& e) {
    throw std::invalid_argument(file + ", line " + std::to_string(e.source().begin.line) + ", column " +
                                std::to_string(e.source().begin.column) + ": " + std::string(e.description()));
  }
}

inline double number(const std::string& file, const toml::node& node, const std::string& key) {
  if (const auto* i = node.as_integer()) return static_cast<double>(i->get());
  if (const auto* f = node.as_floating_point()) return f->get();
  fail(file, node, "'" + key + "' must be a number");
}

template <int D>
mps::Vec<D> point(const std::string& file, const toml::node& node, const std::string& key) {
  const toml::array* a = node.as_array();
  if (a == nullptr || a->size() != D)
    fail(file, node, "'" + key + "' must be a point of " + std::to_string(D) + " numbers [m], as [" +
                         (D == 2 ? "x, y" : "x, y, z") + "]");
  mps::Vec<D> r{};
  for (std::size_t d = 0; d < D; ++d) r[d] = number(file, *a->get(d), key);
  return r;
}

inline int count(const std::string& file, const toml::node& node, const std::string& key) {
  const auto* i = node.as_integer();
  if (i == nullptr || i->get() < 1 || i->get() > 100000)
    fail(file, node, "'" + key + "' must be a whole number of points from 1 to 100000");
  return static_cast<int>(i->get());
}

// A table's keys, each checked against the keys allowed there.
class Keys {
 public:
  Keys(const std::string& file, const toml::table& table, const std::string& where, std::set<std::string> allowed)
      : file_(file), table_(table) {
    for (auto&& [key, value] : table)
      if (allowed.count(std::string(key.str())) == 0) {
        std::string list;
        for (const std::string& k : allowed) list += (list.empty() ? "" : ", ") + k;
        fail(file, value, "'" + std::string(key.str()) + "' is no key of " + where + " (" + list + ")");
      }
  }
  [[nodiscard]] const toml::node* find(const std::string& key) const { return table_.get(key); }
  [[nodiscard]] const toml::node& need(const std::string& key, const std::string& where) const {
    const toml::node* node = table_.get(key);
    if (node == nullptr) fail(file_, table_, where + " needs '" + key + "'");
    return *node;
  }
  [[nodiscard]] std::string text(const std::string& key, const std::string& where, const std::string& otherwise) const {
    const toml::node* node = table_.get(key);
    if (node == nullptr) {
      if (otherwise.empty()) fail(file_, table_, where + " needs '" + key + "'");
      return otherwise;
    }
    if (!node->is_string()) fail(file_, *node, "'" + key + "' must be a \"quoted string\"");
    return node->as_string()->get();
  }
  [[nodiscard]] double number_or(const std::string& key, double otherwise) const {
    const toml::node* node = table_.get(key);
    return node == nullptr ? otherwise : number(file_, *node, key);
  }

 private:
  const std::string& file_;
  const toml::table& table_;
};

// The points of a probe: exactly one of points = [[...], ...], line = {from, to, count}, plane = {origin, edge1,
// edge2, count = [n1, n2]}.
template <int D>
std::vector<mps::Vec<D>> probe_points(const std::string& file, const toml::table& probe, const std::string& where) {
  const toml::node* points = probe.get("points");
  const toml::node* line = probe.get("line");
  const toml::node* plane = probe.get("plane");
  if ((points != nullptr) + (line != nullptr) + (plane != nullptr) != 1)
    fail(file, probe, where + " needs exactly one of 'points', 'line' and 'plane'");
  if (points != nullptr) {
    const toml::array* a = points->as_array();
    if (a == nullptr || a->empty()) fail(file, *points, "'points' must be an array of points, as [[x, y], ...]");
    std::vector<mps::Vec<D>> r;
    for (const toml::node& p : *a) r.push_back(point<D>(file, p, "points"));
    return r;
  }
  if (line != nullptr) {
    const toml::table* t = line->as_table();
    if (t == nullptr) fail(file, *line, "'line' must be a table, as {from = [...], to = [...], count = 11}");
    const Keys k(file, *t, "a line", {"from", "to", "count"});
    return mps::line_points<D>(point<D>(file, k.need("from", "a line"), "from"),
                               point<D>(file, k.need("to", "a line"), "to"), count(file, k.need("count", "a line"), "count"));
  }
  const toml::table* t = plane->as_table();
  if (t == nullptr) fail(file, *plane, "'plane' must be a table, as {origin, edge1, edge2, count = [n1, n2]}");
  const Keys k(file, *t, "a plane", {"origin", "edge1", "edge2", "count"});
  const toml::node& counts = k.need("count", "a plane");
  const toml::array* n = counts.as_array();
  if (n == nullptr || n->size() != 2) fail(file, counts, "a plane's 'count' must be [n1, n2]");
  return mps::plane_points<D>(point<D>(file, k.need("origin", "a plane"), "origin"),
                              point<D>(file, k.need("edge1", "a plane"), "edge1"),
                              point<D>(file, k.need("edge2", "a plane"), "edge2"), count(file, *n->get(0), "count"),
                              count(file, *n->get(1), "count"));
}

}  // namespace probe_file_detail

// Adds the [[probe]] tables `list` holds (a probe file's or a scene file's, `file`) to `series`, for `sim` (its
// spacing, kernel weight and dimension). A force probe adds a WallForce for its group to `sim` (2-D, a run that solves
// the whole pressure); a displacement probe reads the elastic body (mps::ElasticStructure) of its group, which `sim`
// must hold. Throws std::invalid_argument naming the line.
template <int D>
void add_probes(const std::string& file, const toml::node* list, mps::BasicProbeSeries<D>& series,
                mps::BasicSimulation<D>& sim) {
  using namespace probe_file_detail;
  const toml::array* probes = list != nullptr ? list->as_array() : nullptr;
  if (probes == nullptr || probes->empty() || !probes->is_array_of_tables())
    throw std::invalid_argument(file + (list != nullptr ? ", line " + std::to_string(list->source().begin.line) : "") +
                                ": probes are listed as [[probe]] tables");
  const double l0 = sim.config().l0;
  for (const toml::node& node : *probes) {
    const toml::table& t = *node.as_table();
    const std::string where = "a [[probe]]";
    const Keys k(file, t, where,
                 {"name", "quantity", "method", "points", "line", "plane", "kernel_radius", "normal_axis", "reach",
                  "half_size", "lower", "upper", "group"});
    const std::string name = k.text("name", where, "");
    const std::string quantity = k.text("quantity", where, "");
    try {
      if (quantity == "force") {
        if constexpr (D == 2) {
          const toml::node& group = k.need("group", where);
          if (!group.is_integer()) fail(file, group, "'group' must be a whole number (the wall particles' group)");
          if (sim.config().hydrostatic_split)
            fail(file, t, "probe '" + name + "': a wall's force needs the whole pressure, and this app splits off "
                          "its hydrostatic part; the fsi app solves the whole pressure");
          auto& force = sim.template add<mps::WallForce>(static_cast<int>(group.as_integer()->get()));
          series.add(mps::force_probe(name, force));
          continue;
        } else {
          fail(file, t, "probe '" + name + "': force probes are 2-D (mps::WallForce)");
        }
      }
      if (quantity == "displacement") {
        if constexpr (D == 2) {
          const toml::node& group = k.need("group", where);
          if (!group.is_integer()) fail(file, group, "'group' must be a whole number (the elastic body's group)");
          const auto* body = sim.template find<mps::ElasticStructure>(
              [&](const mps::ElasticStructure& e) { return e.group() == group.as_integer()->get(); });
          if (body == nullptr)
            fail(file, group, "probe '" + name + "': no elastic body has group " +
                                  std::to_string(group.as_integer()->get()) + " (an [[elastic]] of a scene file)");
          series.add(mps::displacement_probe(name, probe_points<2>(file, t, where), *body));
          continue;
        } else {
          fail(file, t, "probe '" + name + "': displacement probes are 2-D (the library's elastic solids)");
        }
      }
      std::vector<mps::Vec<D>> points = probe_points<D>(file, t, where);
      if (quantity == "pressure" || quantity == "velocity") {
        const std::string method = k.text("method", where, "kernel");
        if (method == "patch" && quantity == "pressure") {
          mps::BasicSensorPatch<D> patch;
          const toml::node& axis = k.need("normal_axis", "a patch");
          if (!axis.is_integer()) fail(file, axis, "'normal_axis' must be 0 (x), 1 (y) or 2 (z)");
          patch.normal_axis = static_cast<int>(axis.as_integer()->get());
          patch.reach = number(file, k.need("reach", "a patch"), "reach");
          patch.radius = k.number_or("half_size", 0.0);
          if (const toml::node* lower = k.find("lower")) patch.lower = point<D>(file, *lower, "lower");
          if (const toml::node* upper = k.find("upper")) patch.upper = point<D>(file, *upper, "upper");
          series.add(mps::patch_probe<D>(name, std::move(points), patch));
        } else if (method == "kernel") {
          const mps::Kernel kernel = mps::make_kernel(k.number_or("kernel_radius", 2.1), l0, sim.config().weight, D);
          series.add(quantity == "pressure" ? mps::pressure_probe<D>(name, std::move(points), kernel)
                                            : mps::velocity_probe<D>(name, std::move(points), kernel));
        } else {
          fail(file, *k.find("method"), "probe '" + name + "': the " + quantity + "'s method is " +
                                            (quantity == "pressure" ? "kernel or patch" : "kernel"));
        }
      } else if (quantity == "level") {
        const std::string method = k.text("method", where, "surface");
        if (method != "surface" && method != "wire")
          fail(file, *k.find("method"), "probe '" + name + "': a level's method is surface or wire");
        series.add(mps::level_probe<D>(name, std::move(points), l0,
                                       method == "wire" ? mps::LevelMethod::wire : mps::LevelMethod::surface));
      } else {
        fail(file, *k.find("quantity"), "probe '" + name + "': quantity '" + quantity +
                                            "' is none of pressure, velocity, level, force, displacement");
      }
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      if (what.rfind(file + ", line ", 0) == 0) throw;
      fail(file, t, what);  // the library's refusal (a name taken, a bad radius), at the probe's line
    }
  }
}

// The [[probe]] tables `list` holds for an elastic body stepped alone (`solid`, whose scene gives it `group`): each a
// displacement of that body. Throws std::invalid_argument naming the line.
inline void add_solid_probes(const std::string& file, const toml::node* list, mps::ProbeSeries& series,
                             const mps::ElasticSolid& solid, int group) {
  using namespace probe_file_detail;
  const toml::array* probes = list != nullptr ? list->as_array() : nullptr;
  if (probes == nullptr || probes->empty() || !probes->is_array_of_tables())
    throw std::invalid_argument(file + (list != nullptr ? ", line " + std::to_string(list->source().begin.line) : "") +
                                ": probes are listed as [[probe]] tables");
  for (const toml::node& node : *probes) {
    const toml::table& t = *node.as_table();
    const std::string where = "a [[probe]]";
    const Keys k(file, t, where, {"name", "quantity", "points", "line", "plane", "group"});
    const std::string name = k.text("name", where, "");
    if (k.text("quantity", where, "") != "displacement")
      fail(file, *k.find("quantity"), "probe '" + name + "': an elastic body alone has displacement probes only");
    const toml::node& of = k.need("group", where);
    if (!of.is_integer() || of.as_integer()->get() != group)
      fail(file, of, "probe '" + name + "': the body's group is " + std::to_string(group));
    try {
      series.add(mps::displacement_probe(name, probe_points<2>(file, t, where), solid));
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      if (what.rfind(file + ", line ", 0) == 0) throw;
      fail(file, t, what);
    }
  }
}

// The probes `path` describes for `sim`. Throws std::invalid_argument naming the line.
template <int D>
mps::BasicProbeSeries<D> read_probe_file(const std::filesystem::path& path, mps::BasicSimulation<D>& sim) {
  using namespace probe_file_detail;
  const std::string file = "probe file " + path.string();
  const toml::table root = parse(file, path);
  const Keys top(file, root, "a probe file", {"interval", "probe"});
  mps::BasicProbeSeries<D> series(top.number_or("interval", 0.0));
  add_probes<D>(file, top.find("probe"), series, sim);
  return series;
}

// --probes: the file's probes, sampled by `series` after every step (on ranks by rank 0's, `root`: it samples the
// gathered particles). Before the run starts or restarts, so that a restart takes the probes' samples back.
template <int D>
void attach_probes(FrameSeries& series, const std::string& file, mps::BasicSimulation<D>& sim, bool root = true) {
  if (file.empty()) return;
  mps::BasicProbeSeries<D> probes = read_probe_file<D>(file, sim);
  if (root) series.set_probes(std::move(probes));
}
