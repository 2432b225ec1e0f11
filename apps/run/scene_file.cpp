#include "scene_file.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <stdexcept>

#include <toml++/toml.h>

#include "mps/boundaries/geometry.hpp"
#include "mps/io/io.hpp"
#include "mps/solids/fsi.hpp"
#include "mps/step/components.hpp"
#include "probe_file.hpp"

namespace scene_file {

namespace {

using probe_file_detail::fail;
using probe_file_detail::Keys;
using probe_file_detail::number;

std::string label(const std::filesystem::path& file) { return "scene file " + file.string(); }

toml::table parse(const std::filesystem::path& path) { return probe_file_detail::parse(label(path), path); }

std::string text(double v) {
  char s[32];
  std::snprintf(s, sizeof s, "%.6g", v);
  return s;
}

// The table under `key`, or nullptr; anything else there is refused.
const toml::table* table_at(const std::string& file, const Keys& keys, const std::string& key) {
  const toml::node* node = keys.find(key);
  if (node == nullptr) return nullptr;
  if (!node->is_table()) fail(file, *node, "'" + key + "' must be a table, as [" + key + "] or " + key + " = {...}");
  return node->as_table();
}

template <int D>
mps::Vec<D> vector_of(const std::string& file, const toml::node& node, const std::string& key, const char* unit) {
  const toml::array* a = node.as_array();
  if (a == nullptr || a->size() != D)
    fail(file, node, "'" + key + "' must be " + std::to_string(D) + " numbers [" + unit + "], as [" +
                         (D == 2 ? "x, y" : "x, y, z") + "]");
  mps::Vec<D> r{};
  for (std::size_t d = 0; d < D; ++d) {
    r[d] = number(file, *a->get(d), key);
    if (!std::isfinite(r[d])) fail(file, *a->get(d), "'" + key + "' must be finite");
  }
  return r;
}

double number_in(const std::string& file, const Keys& keys, const std::string& key, double otherwise, double lo,
                 double hi, const std::string& range) {
  const toml::node* node = keys.find(key);
  if (node == nullptr) return otherwise;
  const double v = number(file, *node, key);
  if (!(v >= lo && v <= hi)) fail(file, *node, "'" + key + "' must be " + range + ", got " + text(v));
  return v;
}

int whole_in(const std::string& file, const Keys& keys, const std::string& key, int otherwise, int lo, int hi) {
  const toml::node* node = keys.find(key);
  if (node == nullptr) return otherwise;
  const auto* i = node->as_integer();
  if (i == nullptr || i->get() < lo || i->get() > hi)
    fail(file, *node, "'" + key + "' must be a whole number from " + std::to_string(lo) + " to " + std::to_string(hi));
  return static_cast<int>(i->get());
}

bool switch_at(const std::string& file, const Keys& keys, const std::string& key) {
  const toml::node* node = keys.find(key);
  if (node == nullptr) return false;
  if (!node->is_boolean()) fail(file, *node, "'" + key + "' must be true or false");
  return node->as_boolean()->get();
}

// A box: min and max corners, at least one spacing apart on every axis.
template <int D>
Block<D> box_of(const std::string& file, const toml::table& table, const Keys& keys, const std::string& where,
                double l0) {
  Block<D> b;
  b.line = static_cast<int>(table.source().begin.line);
  b.lo = vector_of<D>(file, keys.need("min", where), "min", "m");
  b.hi = vector_of<D>(file, keys.need("max", where), "max", "m");
  for (std::size_t a = 0; a < D; ++a)
    if (!(b.hi[a] - b.lo[a] >= l0 * (1 - 1e-9)))
      fail(file, *keys.find("max"), where + ": 'max' must lie at least a spacing (" + text(l0) + " m) beyond 'min' on "
                                    "every axis");
  return b;
}

// Face names, as a list: x_low, x_high, y_low, y_high (and z_low, z_high in 3-D).
template <int D>
unsigned faces_of(const std::string& file, const toml::node& node) {
  static const std::map<std::string, unsigned> names = {{"x_low", mps::x_low}, {"x_high", mps::x_high},
                                                        {"y_low", mps::y_low}, {"y_high", mps::y_high},
                                                        {"z_low", mps::z_low}, {"z_high", mps::z_high}};
  const std::string valid = D == 2 ? "x_low, x_high, y_low, y_high" : "x_low, x_high, y_low, y_high, z_low, z_high";
  const toml::array* a = node.as_array();
  if (a == nullptr) fail(file, node, "'walls' must be a list of faces, as [\"x_low\", \"x_high\"] (" + valid + ")");
  unsigned faces = 0;
  for (const toml::node& face : *a) {
    const auto* s = face.as_string();
    const auto found = s != nullptr ? names.find(s->get()) : names.end();
    if (found == names.end() || (D == 2 && found->second >= mps::z_low))
      fail(file, face, "'walls' lists faces, each one of " + valid);
    if ((faces & found->second) != 0) fail(file, face, "the face " + s->get() + " is listed twice");
    faces |= found->second;
  }
  return faces;
}

// The faces' names, for the summary.
template <int D>
std::vector<std::string> face_names(unsigned faces) {
  static const char* names[] = {"x_low", "x_high", "y_low", "y_high", "z_low", "z_high"};
  std::vector<std::string> out;
  for (int f = 0; f < 2 * D; ++f)
    if ((faces & (1u << f)) != 0) out.emplace_back(names[f]);
  return out;
}

// The first axis on which block b reaches through one of `faces` of box (their walls), or -1.
template <int D>
int axis_through_walls(const Block<D>& b, const Block<D>& box, unsigned faces, double l0) {
  for (std::size_t a = 0; a < D; ++a) {
    const bool low = (faces & (1u << (2 * a))) != 0, high = (faces & (2u << (2 * a))) != 0;
    if ((low && b.lo[a] < box.lo[a] - 1e-9 * l0) || (high && b.hi[a] > box.hi[a] + 1e-9 * l0))
      return static_cast<int>(a);
  }
  return -1;
}

template <int D>
bool overlap(const Block<D>& a, const Block<D>& b, double l0) {
  for (std::size_t d = 0; d < D; ++d)
    if (std::min(a.hi[d], b.hi[d]) - std::max(a.lo[d], b.lo[d]) <= 1e-9 * l0) return false;
  return true;
}

template <int D>
nlohmann::json box_json(const Block<D>& b) {
  return {{"min_m", std::vector<double>(b.lo.begin(), b.lo.end())},
          {"max_m", std::vector<double>(b.hi.begin(), b.hi.end())}};
}

// [physics], [numerics] and [solver]: SimulationConfig's fields by their schema names (docs/step.md), each in its
// range; `gravity` is g along -y (2-D) or -z (3-D); `pressure_treatment` takes mps::set_pressure_treatment's names.
const std::set<std::string>& physics_names() {
  static const std::set<std::string> names = {"rho", "nu", "fx", "fy", "fz"};
  return names;
}
const std::set<std::string>& solver_names() {
  static const std::set<std::string> names = {"solver", "warm_start", "viscosity_solver"};
  return names;
}
// Whether SimulationConfig's field `name` belongs in [section] (physics, numerics or solver).
bool in_section(const std::string& section, const std::string& name) {
  if (section == "physics") return physics_names().count(name) != 0;
  if (section == "solver") return solver_names().count(name) != 0;
  return name != "l0" && name != "dt_option" && physics_names().count(name) == 0 && solver_names().count(name) == 0;
}

template <int D>
void read_config_section(const std::string& file, const toml::table& section, const std::string& name,
                         mps::SimulationConfig& c) {
  for (auto&& [key_name, node] : section) {
    const std::string key(key_name.str());
    if (name == "physics" && key == "gravity") {
      const double g = number(file, node, key);
      if (!std::isfinite(g)) fail(file, node, "'gravity' must be finite [m/s^2]");
      (D == 2 ? c.fy : c.fz) = -g;
      continue;
    }
    if (name == "numerics" && key == "pressure_treatment") {
      if (!node.is_string()) fail(file, node, "'pressure_treatment' must be a \"quoted string\", as \"hs+ecs\"");
      try {
        mps::set_pressure_treatment(c, node.as_string()->get());
      } catch (const std::invalid_argument& e) {
        fail(file, node, e.what());
      }
      continue;
    }
    bool found = false;
    mps::for_each_parameter([&](const auto& p) {
      using T = std::remove_cvref_t<decltype(c.*(p.member))>;
      if (found || key != p.name || !in_section(name, key)) return;
      found = true;
      const std::string unit = *p.unit != '\0' ? std::string(" [") + p.unit + "]" : std::string();
      if constexpr (std::is_same_v<T, double> || std::is_same_v<T, int>) {
        double v = 0;
        if constexpr (std::is_same_v<T, int>) {
          if (!node.is_integer()) fail(file, node, "'" + key + "' must be a whole number");
          v = static_cast<double>(node.as_integer()->get());
        } else {
          v = number(file, node, key);
        }
        if (!mps::in_range(v, p.min, p.max, p.min_open, p.max_open))
          fail(file, node, "'" + key + "' must be " + mps::range_text(p.min, p.max, p.min_open, p.max_open) + unit +
                               ", got " + text(v) + " (" + p.doc + ")");
        c.*(p.member) = static_cast<T>(v);
      } else if constexpr (std::is_same_v<T, bool>) {
        if (!node.is_boolean()) fail(file, node, "'" + key + "' must be true or false (" + p.doc + ")");
        c.*(p.member) = node.as_boolean()->get();
      } else {
        if (!node.is_string()) fail(file, node, "'" + key + "' must be a \"quoted string\" (" + p.doc + ")");
        const std::string value = node.as_string()->get();
        try {
          if constexpr (std::is_same_v<T, std::string>) c.*(p.member) = value;
          else if constexpr (std::is_same_v<T, mps::Weight>) c.*(p.member) = mps::parse_weight(value);
          else c.*(p.member) = mps::gradient_variant_from_name(value);
        } catch (const std::invalid_argument& e) {
          fail(file, node, e.what());
        }
      }
    });
    if (found) continue;
    std::string known;
    mps::for_each_parameter([&](const auto& p) {
      if (in_section(name, p.name)) known += (known.empty() ? "" : ", ") + std::string(p.name);
    });
    if (name == "physics") known += ", gravity";
    if (name == "numerics") known += ", pressure_treatment";
    bool elsewhere = key == "gravity" || key == "pressure_treatment";
    mps::for_each_parameter([&](const auto& p) { elsewhere = elsewhere || key == p.name; });
    const std::string home = key == "l0"                                        ? "the top level, as 'spacing'"
                             : in_section("physics", key) || key == "gravity" ? "[physics]"
                             : in_section("solver", key)                      ? "[solver]"
                                                                              : "[numerics]";
    fail(file, node,
         "'" + key + "' is no key of [" + name + "]" +
             (elsewhere ? " (it belongs to " + home + ")" : "; it takes " + known));
  }
}

// [annulus.inner], [annulus.outer] or [annulus.flights]: the wall's rotation rates (both 0 when it is absent).
AnnulusWall annulus_wall(const std::string& file, const Keys& keys, const std::string& key) {
  AnnulusWall w;
  const toml::table* t = table_at(file, keys, key);
  if (t == nullptr) return w;
  const Keys k(file, *t, "[annulus." + key + "]", {"omega", "turns"});
  w.omega = number_in(file, k, "omega", 0, -1e6, 1e6, "in [-1e6, 1e6] rad/s");
  w.turns = number_in(file, k, "turns", w.omega, -1e6, 1e6, "in [-1e6, 1e6] rad/s");
  return w;
}

template <int D>
Annulus read_annulus(const std::string& file, const toml::table& t, double l0) {
  const Keys k(file, t, "[annulus]",
               {"inner_radius", "outer_radius", "wall_layers", "dummy_layers", "span", "centre_angle", "height",
                "mirror", "inner", "outer", "flights"});
  Annulus a;
  if (k.find("inner_radius") == nullptr || k.find("outer_radius") == nullptr)
    fail(file, t, "[annulus] needs 'inner_radius' and 'outer_radius' [m]");
  a.r_inner = number_in(file, k, "inner_radius", 0, 1e-12, 1e6, "positive (at most 1e6 m)");
  a.r_outer = number_in(file, k, "outer_radius", 0, 1e-12, 1e6, "positive (at most 1e6 m)");
  const double gap = (a.r_outer - a.r_inner) / l0;
  a.rings = static_cast<int>(std::lround(std::clamp(gap, 0.0, 1e8)));
  if (!(a.rings >= 4 && std::abs(gap - a.rings) <= 1e-6 * gap))
    fail(file, *k.find("outer_radius"),
         "the gap outer_radius - inner_radius must be a whole number of spacings, at least 4 (it is " + text(gap) +
             " spacings of " + text(l0) + " m)");
  a.wall_layers = whole_in(file, k, "wall_layers", 1, 1, 10);
  a.dummy_layers = whole_in(file, k, "dummy_layers", 4, 0, 10);
  const int layers = a.wall_layers + a.dummy_layers;
  if (a.r_inner - layers * l0 < 0.5 * l0)
    fail(file, *k.find("inner_radius"),
         "the inner wall's " + std::to_string(layers) + " rings would reach past the centre: 'inner_radius' must be "
         "at least " + text((layers + 0.5) * l0) + " m at this spacing");
  const double two_pi = 2 * std::numbers::pi;
  a.span = number_in(file, k, "span", two_pi, 1e-9, two_pi, "in (0, 2 pi] rad");
  if (!a.full()) {
    // Three particles on the inner ring at least, and the flights apart where they are closest, by the centre.
    const double innermost = a.r_inner - (layers - 0.5) * l0, widest = two_pi - 2 * (layers + 0.5) * l0 / innermost;
    if (!(a.span * a.r_inner >= 3 * l0 && a.span <= widest))
      fail(file, *k.find("span"),
           "a sector's 'span' must be from " + text(3 * l0 / a.r_inner) + " rad (three spacings of the inner "
           "wall) to " + text(widest) + " rad (its flights apart by the centre), or 2 pi for a whole annulus");
  }
  a.centre = number_in(file, k, "centre_angle", std::numbers::pi / 2, -two_pi, two_pi, "in [-2 pi, 2 pi] rad");
  if (const toml::node* mirror = k.find("mirror")) {
    if (!mirror->is_boolean()) fail(file, *mirror, "'mirror' must be true or false");
    a.mirror = mirror->as_boolean()->get();
  }
  a.inner = annulus_wall(file, k, "inner");
  a.outer = annulus_wall(file, k, "outer");
  a.flights = annulus_wall(file, k, "flights");
  if (a.full() && k.find("flights") != nullptr)
    fail(file, *k.find("flights"), "flights close a sector: give the annulus a 'span' below 2 pi");
  if constexpr (D == 3) {
    if (k.find("height") == nullptr)
      fail(file, t, "a 3-D [annulus] needs 'height' [m]: its rings are extruded along z over 0 < z < height, periodic");
    a.height = number_in(file, k, "height", 0, 1e-12, 1e6, "positive (at most 1e6 m)");
    a.layers_z = static_cast<int>(std::lround(std::min(a.height / l0, 1e8)));
    if (!(a.layers_z >= 1 && std::abs(a.height / l0 - a.layers_z) <= 1e-6 * a.layers_z))
      fail(file, *k.find("height"), "'height' must be a whole number of spacings (it is " + text(a.height / l0) + ")");
  } else if (k.find("height") != nullptr) {
    fail(file, *k.find("height"), "'height' extrudes an annulus in 3-D; this scene has dimensions = 2");
  }
  return a;
}

nlohmann::json annulus_json(const Annulus& a) {
  const auto wall = [](const AnnulusWall& w) {
    return nlohmann::json{{"omega_rad_per_s", w.omega}, {"turns_rad_per_s", w.turns}};
  };
  nlohmann::json j = {{"inner_radius_m", a.r_inner}, {"outer_radius_m", a.r_outer}, {"ring_count", a.rings},
                      {"wall_layers", a.wall_layers}, {"dummy_layers", a.dummy_layers}, {"span_rad", a.span},
                      {"centre_angle_rad", a.centre}, {"mirror", a.mirror}, {"inner", wall(a.inner)},
                      {"outer", wall(a.outer)}};
  if (!a.full()) j["flights"] = wall(a.flights);
  if (a.layers_z > 0) j["height_m"] = a.height;
  return j;
}

}  // namespace

bool Annulus::full() const { return span >= 2 * std::numbers::pi; }

int dimensions_of(const std::filesystem::path& path) {
  const toml::table root = parse(path);
  const toml::node* node = root.get("dimensions");
  if (node == nullptr)
    throw std::invalid_argument(label(path) + ": it needs 'dimensions = 2' or 'dimensions = 3' at its top");
  const auto* d = node->as_integer();
  if (d == nullptr || (d->get() != 2 && d->get() != 3)) fail(label(path), *node, "'dimensions' must be 2 or 3");
  return static_cast<int>(d->get());
}

// A fluid's physics and numerics (SimulationConfig's defaults, then the file's [physics], [numerics] and [solver]) and
// the components it adds ([components]), into `s` and the summary's `json`.
template <int D>
void read_fluid_numerics(const std::string& file, const Keys& top, Scene<D>& s, nlohmann::json& json) {
  for (const char* section : {"physics", "numerics", "solver"})
    if (const toml::table* t = table_at(file, top, section)) read_config_section<D>(file, *t, section, s.config);
  if (!(s.config.dt_max > 0))
    throw std::invalid_argument(file + ": [numerics] needs 'dt_max' [s], the step when neither the CFL (cfl) nor the "
                                "viscous limit binds; about cfl l0 / sqrt(2 g H) for water H deep");
  try {
    s.config.validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(file + ": " + e.what());
  }
  json["simulation_config"] = mps::config_json(s.config);

  if (const toml::table* c = table_at(file, top, "components")) {
    const Keys k(file, *c, "[components]",
                 {"free_surface", "collision", "asymmetry_surface", "wet_walls", "remove_escaped", "wall_backstop"});
    if (k.find("free_surface") != nullptr) {
      if (!k.find("free_surface")->is_boolean())
        fail(file, *k.find("free_surface"), "'free_surface' must be true or false");
      s.free_surface = k.find("free_surface")->as_boolean()->get();
    }
    if (const toml::table* t = table_at(file, k, "collision")) {
      const Keys ck(file, *t, "collision", {"distance", "restitution"});
      if (ck.find("distance") == nullptr) fail(file, *t, "collision needs 'distance' [l0]");
      s.collision = number_in(file, ck, "distance", 0, 1e-6, 0.999, "in (0, 1) l0");
      s.restitution = number_in(file, ck, "restitution", 0.2, 0, 1, "in [0, 1]");
    }
    if (const toml::table* t = table_at(file, k, "asymmetry_surface")) {
      const Keys ak(file, *t, "asymmetry_surface", {"fraction", "interior_density"});
      if (ak.find("fraction") == nullptr) fail(file, *t, "asymmetry_surface needs 'fraction'");
      s.asymmetry = number_in(file, ak, "fraction", 0, 1e-6, 10, "in (0, 10]");
      s.asymmetry_interior_density = number_in(file, ak, "interior_density", 0, 0, 10, "in [0, 10] n0 (0: no limit)");
    }
    s.wet_walls = switch_at(file, k, "wet_walls");
    s.remove_escaped = switch_at(file, k, "remove_escaped");
    // true, or a table with the slack: fluid less than it past a face is left alone (the 2-D dam break's l0/2)
    if (const toml::node* b = k.find("wall_backstop"); b != nullptr && !b->is_boolean()) {
      if (!b->is_table()) fail(file, *b, "'wall_backstop' must be true, false or a table {slack = S} (S in l0)");
      const Keys bk(file, *b->as_table(), "wall_backstop", {"slack"});
      s.wall_backstop = true;
      s.wall_backstop_slack = number_in(file, bk, "slack", 0, 0, 10, "in [0, 10] l0");
    } else {
      s.wall_backstop = switch_at(file, k, "wall_backstop");
    }
    if ((s.remove_escaped || s.wall_backstop) && !s.has_tank)
      fail(file, *c, "remove_escaped and wall_backstop act on the tank's walls; this scene has no [tank]");
  }
  json["components"] = {{"free_surface", s.free_surface}, {"collision_l0", s.collision}, {"restitution", s.restitution},
                        {"asymmetry", s.asymmetry},
                        {"asymmetry_interior_density_over_n0", s.asymmetry_interior_density},
                        {"wet_walls", s.wet_walls}, {"remove_escaped", s.remove_escaped},
                        {"wall_backstop", s.wall_backstop}, {"wall_backstop_slack_l0", s.wall_backstop_slack}};
}

template <int D>
Scene<D> read_scene(const std::filesystem::path& path) {
  const toml::table root = parse(path);
  const std::string file = label(path);
  const Keys top(file, root, "a scene file",
                 {"title", "dimensions", "spacing", "tank", "fluid", "wall", "obstacle", "inlet", "elastic",
                  "annulus", "domain", "physics", "numerics", "solver", "components", "run", "output", "probe"});
  Scene<D> s;
  s.file = path;
  s.title = top.text("title", "a scene file", path.stem().string());
  {
    const toml::node& spacing = top.need("spacing", "a scene file");
    s.l0 = number(file, spacing, "spacing");
    if (!(s.l0 > 0 && s.l0 <= 1e3)) fail(file, spacing, "'spacing' (l0) must be positive and at most 1000 m");
  }
  const double l0 = s.l0;
  nlohmann::json json = {{"title", s.title}, {"dimensions", D}, {"spacing_m", l0}};
  // An elastic body without fluid is stepped on its own: nothing of a fluid's scene applies to it.
  s.solid_alone = top.find("annulus") == nullptr && top.find("fluid") == nullptr && top.find("elastic") != nullptr;
  if (s.solid_alone)
    for (const std::string other : {"tank", "wall", "obstacle", "inlet", "domain", "numerics", "solver", "components"})
      if (const toml::node* n = top.find(other))
        fail(file, *n, "a scene of an elastic body alone (no [[fluid]]) has no '" + other + "': its numerics are the "
                       "[[elastic]] table's, its physics [physics] gravity");

  if (const toml::table* tank = table_at(file, top, "tank")) {
    const Keys k(file, *tank, "[tank]", {"min", "max", "walls", "wall_layers", "dummy_layers"});
    s.has_tank = true;
    s.tank = box_of<D>(file, *tank, k, "[tank]", l0);
    const unsigned top_face = D == 2 ? unsigned{mps::top} : unsigned{mps::z_high};
    s.tank_walls = k.find("walls") != nullptr ? faces_of<D>(file, *k.find("walls"))
                                              : ((D == 2 ? 15u : 63u) & ~top_face);
    s.wall_layers = whole_in(file, k, "wall_layers", 1, 1, 10);
    s.dummy_layers = whole_in(file, k, "dummy_layers", 4, 0, 10);
    json["tank"] = box_json(s.tank);
    json["tank"]["walls"] = face_names<D>(s.tank_walls);
    json["tank"]["wall_layers"] = s.wall_layers;
    json["tank"]["dummy_layers"] = s.dummy_layers;
  }

  if (const toml::table* annulus = table_at(file, top, "annulus")) {
    for (const std::string other : {"tank", "fluid", "wall", "obstacle", "inlet", "elastic"}) {
      const std::string table = other == "tank" || other == "inlet" ? "[" + other + "]" : "[[" + other + "]]";
      if (top.find(other) != nullptr)
        fail(file, *annulus, "an [annulus] is a scene of its own, with its fluid and walls: this file has a " + table +
                                 " too");
    }
    s.has_annulus = true;
    s.annulus = read_annulus<D>(file, *annulus, l0);
    json["annulus"] = annulus_json(s.annulus);
  }

  const toml::node* fluid = top.find("fluid");
  if (!s.has_annulus && !s.solid_alone &&
      (fluid == nullptr || !fluid->is_array_of_tables() || fluid->as_array()->empty()))
    fail(file, fluid != nullptr ? *fluid : static_cast<const toml::node&>(root),
         "a scene lists its water as [[fluid]] tables, each with min and max corners (or is an [annulus], or an "
         "[[elastic]] body alone)");
  const toml::array none;
  for (const toml::node& node : s.has_annulus || s.solid_alone ? none : *fluid->as_array()) {
    const toml::table& t = *node.as_table();
    const Keys k(file, t, "a [[fluid]]", {"min", "max", "velocity"});
    Block<D> b = box_of<D>(file, t, k, "a [[fluid]]", l0);
    if (const toml::node* v = k.find("velocity")) b.velocity = vector_of<D>(file, *v, "velocity", "m/s");
    if (const int a = s.has_tank ? axis_through_walls(b, s.tank, s.tank_walls, l0) : -1; a >= 0)
      fail(file, t, "this [[fluid]] block reaches through a wall of the tank (line " + std::to_string(s.tank.line) +
                        ") on axis " + "xyz"[a] + ": keep it inside the tank's min and max");
    for (const Block<D>& other : s.fluid)
      if (overlap(b, other, l0))
        fail(file, t, "this [[fluid]] block overlaps the one on line " + std::to_string(other.line) +
                          ": two particles would sit in one place");
    s.fluid.push_back(b);
    json["fluid"].push_back(box_json(b));
    json["fluid"].back()["velocity_m_per_s"] = std::vector<double>(b.velocity.begin(), b.velocity.end());
  }

  if (const toml::node* list = top.find("wall")) {
    if (!list->is_array_of_tables()) fail(file, *list, "walls are listed as [[wall]] tables");
    for (const toml::node& node : *list->as_array()) {
      const toml::table& t = *node.as_table();
      const Keys k(file, t, "a [[wall]]",
                   {"min", "max", "walls", "group", "wall_layers", "dummy_layers", "no_slip", "velocity", "part"});
      Wall<D> w;
      w.box = box_of<D>(file, t, k, "a [[wall]]", l0);
      w.walls = faces_of<D>(file, k.need("walls", "a [[wall]]"));
      w.group = whole_in(file, k, "group", 0, 0, 1000000);
      w.wall_layers = whole_in(file, k, "wall_layers", 1, 1, 10);
      w.dummy_layers = whole_in(file, k, "dummy_layers", 4, 0, 10);
      w.no_slip = switch_at(file, k, "no_slip");
      if (const toml::node* v = k.find("velocity")) w.velocity = vector_of<D>(file, *v, "velocity", "m/s");
      if (w.no_slip && std::popcount(w.walls) != 1)
        fail(file, t, "a no-slip [[wall]] lies on one face (its mirror plane): list one in 'walls'");
      if (w.no_slip && w.group == 0)
        fail(file, t,
             "a no-slip [[wall]] needs a 'group' of its own (1, 2, ...): the mirror finds its particles by it");
      if (k.find("velocity") != nullptr && !w.no_slip)
        fail(file, *k.find("velocity"), "'velocity' is a no-slip wall's sliding velocity: set no_slip = true");
      for (const Block<D>& b : s.fluid)
        if (axis_through_walls(b, w.box, w.walls, l0) >= 0)
          fail(file, t, "this [[wall]] cuts through the [[fluid]] block on line " + std::to_string(b.line));
      if (const toml::table* part = table_at(file, k, "part")) {
        const Keys pk(file, *part, "a wall's part", {"axis", "below", "group", "velocity"});
        if (!w.no_slip) fail(file, *part, "a 'part' slides beside the rest of a no-slip wall: set no_slip = true");
        if (pk.find("below") == nullptr || pk.find("group") == nullptr)
          fail(file, *part, "a wall's part needs 'below' [m] (its particles below it along 'axis') and a 'group'");
        w.part_axis = whole_in(file, pk, "axis", 0, 0, D - 1);
        w.part_below = number_in(file, pk, "below", 0, -1e6, 1e6, "in [-1e6, 1e6] m");
        w.part_group = whole_in(file, pk, "group", 0, 1, 1000000);
        if (w.part_group == w.group) fail(file, *pk.find("group"), "a wall's part needs a group other than the wall's");
        if (const toml::node* v = pk.find("velocity")) w.part_velocity = vector_of<D>(file, *v, "velocity", "m/s");
      }
      s.walls.push_back(w);
      nlohmann::json j = box_json(w.box);
      j["walls"] = face_names<D>(w.walls);
      j["group_number"] = w.group;
      j["wall_layers"] = w.wall_layers;
      j["dummy_layers"] = w.dummy_layers;
      j["no_slip"] = w.no_slip;
      j["velocity_m_per_s"] = std::vector<double>(w.velocity.begin(), w.velocity.end());
      if (w.part_group > 0)
        j["part"] = {{"axis", std::string(1, "xyz"[w.part_axis])}, {"below_m", w.part_below},
                     {"group_number", w.part_group},
                     {"velocity_m_per_s", std::vector<double>(w.part_velocity.begin(), w.part_velocity.end())}};
      json["walls"].push_back(j);
    }
  }

  if (const toml::node* list = top.find("obstacle")) {
    if (!list->is_array_of_tables()) fail(file, *list, "obstacles are listed as [[obstacle]] tables");
    std::set<int> moving_groups;
    for (const toml::node& node : *list->as_array()) {
      const toml::table& t = *node.as_table();
      const Keys k(file, t, "an [[obstacle]]", {"min", "max", "walls", "group", "motion"});
      Obstacle<D> o;
      o.box = box_of<D>(file, t, k, "an [[obstacle]]", l0);
      // By default a wall layer under every face but those lying on the tank's faces (a block on the floor).
      if (const toml::node* walls = k.find("walls")) {
        o.walls = faces_of<D>(file, *walls);
      } else {
        for (std::size_t a = 0; a < D; ++a) {
          if (!(s.has_tank && std::abs(o.box.lo[a] - s.tank.lo[a]) <= 1e-9 * l0)) o.walls |= 1u << (2 * a);
          if (!(s.has_tank && std::abs(o.box.hi[a] - s.tank.hi[a]) <= 1e-9 * l0)) o.walls |= 2u << (2 * a);
        }
      }
      o.group = whole_in(file, k, "group", 0, 0, 1000000);
      for (const Block<D>& b : s.fluid)
        if (overlap(o.box, b, l0))
          fail(file, t, "this [[obstacle]] overlaps the [[fluid]] block on line " + std::to_string(b.line) +
                            ": make the block stop at the obstacle's faces");
      for (const Obstacle<D>& other : s.obstacles)
        if (overlap(o.box, other.box, l0))
          fail(file, t, "this [[obstacle]] overlaps the one on line " + std::to_string(other.box.line) +
                            ": two particles would sit in one place");
      if (const int a = s.has_tank ? axis_through_walls(o.box, s.tank, s.tank_walls, l0) : -1; a >= 0)
        fail(file, t, "this [[obstacle]] reaches into a wall of the tank (line " + std::to_string(s.tank.line) +
                          ") on axis " + "xyz"[a] + ": keep it inside the tank's min and max");
      if (const toml::table* motion = table_at(file, k, "motion")) {
        const Keys m(file, *motion, "an obstacle's motion", {"axis", "amplitude", "period"});
        o.axis = whole_in(file, m, "axis", -1, 0, D - 1);
        if (o.axis < 0)
          fail(file, *motion,
               "an obstacle's motion needs 'axis' (0: x, 1: y" + std::string(D == 3 ? ", 2: z" : "") + ")");
        if (m.find("amplitude") == nullptr || m.find("period") == nullptr)
          fail(file, *motion, "an obstacle's motion needs 'amplitude' [m] and 'period' [s]");
        o.amplitude = number_in(file, m, "amplitude", 0, 1e-12, 1e3, "positive (at most 1000 m)");
        o.period = number_in(file, m, "period", 0, 1e-9, 1e6, "positive (at most 1e6 s)");
        if (o.group == 0 || moving_groups.count(o.group) != 0)
          fail(file, t, "a moving obstacle needs a 'group' of its own (1, 2, ...): its particles are found by it");
        moving_groups.insert(o.group);
      }
      for (const Obstacle<D>& other : s.obstacles)
        if (o.amplitude > 0 && other.group == o.group)
          fail(file, t, "a moving obstacle needs a 'group' of its own; line " + std::to_string(other.box.line) +
                            " has group " + std::to_string(o.group) + " too");
      s.obstacles.push_back(o);
      nlohmann::json j = box_json(o.box);
      j["walls"] = face_names<D>(o.walls);
      j["group_number"] = o.group;
      if (o.amplitude > 0)
        j["motion"] = {{"axis", std::string(1, "xyz"[o.axis])}, {"amplitude_m", o.amplitude}, {"period_s", o.period}};
      json["obstacles"].push_back(j);
    }
  }

  if (const toml::table* inlet = table_at(file, top, "inlet")) {
    const Keys k(file, *inlet, "[inlet]", {"plate", "speed", "outlet", "ghost_rows", "buffer"});
    Inlet& in = s.inlet;
    in.line = static_cast<int>(inlet->source().begin.line);
    if (k.find("plate") == nullptr || k.find("speed") == nullptr || k.find("outlet") == nullptr)
      fail(file, *inlet, "[inlet] needs 'plate' (the group of its [[wall]] on x_low), 'speed' [m/s] and 'outlet' [m]");
    in.plate = whole_in(file, k, "plate", 0, 1, 1000000);
    in.speed = number_in(file, k, "speed", 0, 1e-12, 1e3, "positive (at most 1000 m/s)");
    in.outlet = number_in(file, k, "outlet", 0, -1e6, 1e6, "in [-1e6, 1e6] m");
    in.ghost_rows = whole_in(file, k, "ghost_rows", 3, 1, 100);
    in.buffer = number_in(file, k, "buffer", 0, 0, 1e6, "at least 0 m (0: no buffer)");
    const auto plate =
        std::find_if(s.walls.begin(), s.walls.end(), [&](const Wall<D>& w) { return w.group == in.plate; });
    if (plate == s.walls.end() || plate->walls != mps::x_low || plate->no_slip)
      fail(file, *k.find("plate"),
           "the inlet's 'plate' must be the group of a [[wall]] on x_low alone, without no_slip (it pushes the fluid)");
    in.wall = static_cast<std::size_t>(plate - s.walls.begin());
    if (!(in.outlet > plate->box.lo[0] + 4 * l0))
      fail(file, *k.find("outlet"),
           "the outlet must lie downstream of the plate, at x > " + text(plate->box.lo[0] + 4 * l0));
    if (in.buffer > 0 && !(in.buffer >= 4.1 * l0))
      fail(file, *k.find("buffer"),
           "an outflow buffer must be at least 4.1 spacings thick (" + text(4.1 * l0) +
               " m), the fluid before it needs full kernels; 0: no buffer");
    s.has_inlet = true;
    json["inlet"] = {{"plate_group_number", in.plate}, {"speed_m_per_s", in.speed}, {"outlet_m", in.outlet},
                     {"ghost_row_count", in.ghost_rows}, {"buffer_m", in.buffer}};
  }

  if (const toml::node* list = top.find("elastic")) {
    if (!list->is_array_of_tables()) fail(file, *list, "elastic bodies are listed as [[elastic]] tables");
    if (D == 3) fail(file, *list, "elastic bodies are 2-D (the library's solids): this scene has dimensions = 3");
    if (s.solid_alone && list->as_array()->size() != 1)
      fail(file, *list, "a scene without fluid steps one elastic body alone; this file has " +
                            std::to_string(list->as_array()->size()));
    for (const toml::node& node : *list->as_array()) {
      const toml::table& t = *node.as_table();
      const Keys k(file, t, "an [[elastic]]",
                   {"min", "max", "walls", "clamp", "group", "mount", "density", "youngs_modulus", "poisson_ratio",
                    "model", "relaxation", "cfl", "hourglass", "clamp_cylinder", "first_mode_tip_velocity"});
      Elastic<D> e;
      e.box = box_of<D>(file, t, k, "an [[elastic]]", l0);
      for (std::size_t a = 0; a < D; ++a) {
        const double n = (e.box.hi[a] - e.box.lo[a]) / l0;
        if (std::abs(n - std::round(n)) > 1e-6 * n || std::round(n) < 3)
          fail(file, *k.find("max"), "an elastic body's edges must be whole numbers of spacings, at least 3 (axis " +
                                         std::string(1, "xyz"[a]) + ": " + text(n) + " spacings)");
      }
      // Alone, a body meets no fluid: no faces to meet it, no mount among its walls, no load to relax. Among fluid it
      // is held by what the fluid's particles are (a wall, a mount), which has no cylinder.
      for (const char* key : {"walls", "mount", "relaxation"})
        if (s.solid_alone && k.find(key) != nullptr)
          fail(file, *k.find(key), std::string("'") + key + "' is for a body among fluid; this one is alone");
      for (const char* key : {"clamp_cylinder", "first_mode_tip_velocity"})
        if (!s.solid_alone && k.find(key) != nullptr)
          fail(file, *k.find(key), std::string("'") + key + "' is for a body alone (no [[fluid]] in the file)");
      if (!s.solid_alone) e.walls = faces_of<D>(file, k.need("walls", "an [[elastic]]"));
      {
        const toml::node& clamp = k.need("clamp", "an [[elastic]]");
        if (!clamp.is_string()) fail(file, clamp, "'clamp' names the face the body is held at, as \"y_low\"");
        const std::vector<std::string> names = face_names<D>(D == 2 ? 15u : 63u);
        const auto found = std::find(names.begin(), names.end(), clamp.as_string()->get());
        if (found == names.end()) fail(file, clamp, "'clamp' must be one of x_low, x_high, y_low, y_high");
        e.clamp = 1u << static_cast<unsigned>(found - names.begin());
      }
      if (const toml::table* cylinder = table_at(file, k, "clamp_cylinder")) {
        const Keys ck(file, *cylinder, "clamp_cylinder", {"centre", "radius"});
        const mps::Vec<D> centre = vector_of<D>(file, ck.need("centre", "clamp_cylinder"), "centre", "m");
        e.cylinder_centre = {centre[0], centre[1]};
        e.cylinder_radius = number_in(file, ck, "radius", 0, 1e-9, 1e6, "positive [m]");
        if (e.clamp != mps::x_low)
          fail(file, *cylinder, "a body is held in a cylinder at its x_low face: set clamp = \"x_low\"");
        const double reach = centre[0] + e.cylinder_radius;  // the cylinder's right-most point
        if (!(reach >= e.box.lo[0] - 1e-9 * l0 && reach < e.box.hi[0]))
          fail(file, *cylinder, "the cylinder must reach the body's x_low face (" + text(e.box.lo[0]) + " m) and not "
                                "past its other end: its centre x plus radius is " + text(reach) + " m");
        if (!(e.box.lo[1] + 0.5 * l0 > centre[1] - e.cylinder_radius &&
              e.box.hi[1] - 0.5 * l0 < centre[1] + e.cylinder_radius))
          fail(file, *cylinder, "every row of the body must meet the cylinder: keep the body's y within the "
                                "cylinder's, centre y +- radius");
      }
      if (k.find("first_mode_tip_velocity") != nullptr)
        e.first_mode_tip_velocity = number_in(file, k, "first_mode_tip_velocity", 0, -1e3, 1e3, "in [-1000, 1000] m/s");
      e.group = whole_in(file, k, "group", 1, 1, 1000000);
      if (const toml::table* mount = table_at(file, k, "mount")) {
        const Keys mk(file, *mount, "an elastic body's mount", {"to", "walls"});
        const int face = std::countr_zero(e.clamp);
        const std::size_t axis = static_cast<std::size_t>(face / 2);
        const bool high = face % 2 == 1;
        const double edge = high ? e.box.hi[axis] : e.box.lo[axis];
        e.has_mount = true;
        e.mount_to = number(file, mk.need("to", "a mount"), "to");
        if (!(high ? e.mount_to >= edge + (Elastic<D>::clamp_layers + 1) * l0
                   : e.mount_to <= edge - (Elastic<D>::clamp_layers + 1) * l0))
          fail(file, mk.need("to", "a mount"),
               "a mount reaches from the clamp face beyond the clamp's " + std::to_string(Elastic<D>::clamp_layers) +
                   " spacings: 'to' must be " + (high ? "above " : "below ") +
                   text(edge + (high ? 1 : -1) * (Elastic<D>::clamp_layers + 1) * l0) + " m");
        if (const toml::node* walls = mk.find("walls")) e.mount_walls = faces_of<D>(file, *walls);
        if ((e.mount_walls & (3u << (2 * axis))) != 0)
          fail(file, *mk.find("walls"), "a mount's walls are faces along its length, not across it");
      }
      e.material.density = number_in(file, k, "density", 1000, 1e-6, 1e6, "in (0, 1e6] kg/m^3");
      e.material.youngs_modulus = number_in(file, k, "youngs_modulus", 2e6, 1e-6, 1e15, "in (0, 1e15] Pa");
      e.material.poisson_ratio = number_in(file, k, "poisson_ratio", 0.3975, -0.999, 0.499, "in (-1, 0.5)");
      if (const toml::node* model = k.find("model")) {
        if (!model->is_string()) fail(file, *model, "'model' must be \"linear\" or \"svk\"");
        try {
          e.material.model = mps::parse_elastic_model(model->as_string()->get());
        } catch (const std::invalid_argument& error) {
          fail(file, *model, error.what());
        }
      }
      e.relaxation = number_in(file, k, "relaxation", 1, 1e-6, 1, "in (0, 1] (1: the load taken whole)");
      e.cfl = number_in(file, k, "cfl", 0.3, 1e-6, 1, "in (0, 1]: c_p dt / l0 of the solid");
      e.hourglass = number_in(file, k, "hourglass", 30, 0, 1e4, "in [0, 1e4] (0: off)");
      for (const Block<D>& b : s.fluid)
        if (overlap(e.box, b, l0))
          fail(file, t, "this [[elastic]] body overlaps the [[fluid]] block on line " + std::to_string(b.line));
      const auto taken = [&](int g) {
        const auto wall = [&](const Wall<D>& w) { return w.group == g || w.part_group == g; };
        const auto obstacle = [&](const Obstacle<D>& o) { return o.group == g; };
        const auto body = [&](const Elastic<D>& o) { return o.group == g; };
        return std::any_of(s.walls.begin(), s.walls.end(), wall) ||
               std::any_of(s.obstacles.begin(), s.obstacles.end(), obstacle) ||
               std::any_of(s.elastic.begin(), s.elastic.end(), body);
      };
      if (taken(e.group))
        fail(file, t, "an elastic body needs a 'group' of its own (its particles are found by it); " +
                          std::to_string(e.group) + " is taken");
      s.elastic.push_back(e);
      nlohmann::json j = box_json(e.box);
      if (!s.solid_alone) j["walls"] = face_names<D>(e.walls);
      j["clamp"] = face_names<D>(e.clamp).front();
      if (e.cylinder_radius > 0)
        j["clamp_cylinder"] = {{"centre_m", {e.cylinder_centre[0], e.cylinder_centre[1]}},
                               {"radius_m", e.cylinder_radius}};
      if (s.solid_alone) j["first_mode_tip_velocity_m_per_s"] = e.first_mode_tip_velocity;
      j["group_number"] = e.group;
      if (e.has_mount) j["mount"] = {{"to_m", e.mount_to}, {"walls", face_names<D>(e.mount_walls)}};
      j["density_kg_per_m3"] = e.material.density;
      j["youngs_modulus_pa"] = e.material.youngs_modulus;
      j["poisson"] = e.material.poisson_ratio;
      j["model"] = std::string(mps::to_string(e.material.model));
      if (!s.solid_alone) j["relaxation"] = e.relaxation;
      j["cfl"] = e.cfl;
      j["hourglass"] = e.hourglass;
      json["elastic"].push_back(j);
    }
  }

  // The physics and numerics: a fluid's, or a body's alone (its own in its [[elastic]] table, and gravity).
  s.config.l0 = l0;
  s.config.dt_option = "dt_max or cfl in [numerics] of " + path.filename().string();
  if (!s.solid_alone) {
    read_fluid_numerics(file, top, s, json);
  } else {
    if (const toml::table* t = table_at(file, top, "physics")) {
      const Keys k(file, *t, "[physics] of a body alone", {"gravity"});
      read_config_section<D>(file, *t, "physics", s.config);
    }
    json["gravity_m_per_s2"] = {s.config.fx, s.config.fy};
  }

  {
    const toml::table* run = table_at(file, top, "run");
    if (run == nullptr) throw std::invalid_argument(file + ": it needs [run] with 'end_time' [s]");
    const Keys k(file, *run, "[run]", {"end_time"});
    if (k.find("end_time") == nullptr) fail(file, *run, "[run] needs 'end_time' [s]");
    s.end_time = number_in(file, k, "end_time", 0, 1e-12, 1e6, "positive (at most 1e6 s)");
  }
  s.out = std::filesystem::path("runs") / path.stem();  // as every app's --out: under the current folder
  if (const toml::table* output = table_at(file, top, "output")) {
    const Keys k(file, *output, "[output]", {"out", "frames", "probe_interval"});
    if (k.find("out") != nullptr) {
      const std::filesystem::path out = k.text("out", "[output]", "");
      s.out = out.is_relative() ? (path.parent_path() / out).lexically_normal() : out;
    }
    s.frames = whole_in(file, k, "frames", 20, 0, 100000);
    s.probe_interval = number_in(file, k, "probe_interval", 0, 0, 1e6, "at least 0 s (0: every step)");
  }
  s.has_probes = top.find("probe") != nullptr;

  // Before any particle is made: a spacing too fine for the boxes would fill the memory. The lattice over the box
  // holding every block, with ten layers around it, bounds the count.
  {
    double bound = 1;
    if (s.has_annulus) {
      const Annulus& a = s.annulus;
      const double reach = a.r_outer / l0 + a.wall_layers + a.dummy_layers + 1;
      bound = std::numbers::pi * reach * reach * std::max(1, a.layers_z);
    } else {
      Block<D> all = s.solid_alone ? s.elastic.front().box : s.fluid.front();
      const auto hold = [&](const Block<D>& b) {
        for (std::size_t a = 0; a < D; ++a) {
          all.lo[a] = std::min(all.lo[a], b.lo[a]);
          all.hi[a] = std::max(all.hi[a], b.hi[a]);
        }
      };
      if (s.has_tank) hold(s.tank);
      for (const Block<D>& b : s.fluid) hold(b);
      for (const Wall<D>& w : s.walls) hold(w.box);
      for (const Obstacle<D>& o : s.obstacles) hold(o.box);
      for (const Elastic<D>& e : s.elastic) hold(e.box);
      for (std::size_t a = 0; a < D; ++a) bound *= (all.hi[a] - all.lo[a]) / l0 + 20;
    }
    if (!(bound <= 2e7))
      fail(file, top.need("spacing", "a scene file"),
           "at spacing " + text(l0) + " m the scene's boxes hold up to " + text(bound) +
               " particles, more than the 2e7 a run may hold: raise the spacing");
  }

  json["end_time_s"] = s.end_time;
  json["frame_count"] = s.frames;
  json["probe_interval_s"] = s.probe_interval;
  if (s.solid_alone) {  // no particles of a fluid, no domain: the solid's own lattice
    s.parameters = std::move(json);
    return s;
  }

  // The domain: the file's, or the particles' box with 6 spacings around it and room above for half its height.
  const mps::BasicParticles<D> particles = make_particles(s);
  mps::Vec<D> lo, hi;
  lo.fill(std::numeric_limits<double>::infinity());
  hi.fill(-std::numeric_limits<double>::infinity());
  const auto r = particles.positions();
  for (std::size_t i = 0; i < particles.size(); ++i)
    for (std::size_t a = 0; a < D; ++a) lo[a] = std::min(lo[a], (*r[a])[i]), hi[a] = std::max(hi[a], (*r[a])[i]);
  if (const toml::table* domain = table_at(file, top, "domain")) {
    const Keys k(file, *domain, "[domain]", {"min", "max", "periodic"});
    const Block<D> b = box_of<D>(file, *domain, k, "[domain]", l0);
    if (const toml::node* periodic = k.find("periodic")) {
      const toml::array* axes = periodic->as_array();
      if (axes == nullptr) fail(file, *periodic, "'periodic' lists axes, as [\"x\"]");
      for (const toml::node& axis : *axes) {
        const auto* name = axis.as_string();
        const std::string valid = D == 2 ? "x, y" : "x, y, z";
        if (name == nullptr || name->get().size() != 1 || valid.find(name->get()) == std::string::npos)
          fail(file, axis, "'periodic' lists axes, each one of " + valid);
        const std::size_t a = static_cast<std::size_t>(name->get()[0] - 'x');
        if (a == 0) s.domain.periodic_x = true;
        if (a == 1) s.domain.periodic_y = true;
        if constexpr (D == 3) if (a == 2) s.domain.periodic_z = true;
      }
    }
    for (std::size_t a = 0; a < D; ++a)
      if (!(b.lo[a] < lo[a] && b.hi[a] > hi[a]))
        fail(file, *domain,
             std::string("the domain must hold every particle: on axis ") + "xyz"[a] + " they reach from " +
                                text(lo[a]) + " to " + text(hi[a]) + " m");
    for (std::size_t a = 0; a < D; ++a) lo[a] = b.lo[a], hi[a] = b.hi[a];
  } else if (s.has_annulus) {
    // A square a spacing beyond the outer wall's last ring; in 3-D the annulus's height, periodic.
    const Annulus& a = s.annulus;
    const double half = a.r_outer + (a.wall_layers + a.dummy_layers + 1) * l0;
    lo[0] = lo[1] = -half;
    hi[0] = hi[1] = half;
    if constexpr (D == 3) {
      lo[2] = 0;
      hi[2] = a.layers_z * l0;
      s.domain.periodic_z = true;
    }
  } else {
    const double margin = 6 * l0, room = 0.5 * (hi[D - 1] - lo[D - 1]);
    for (std::size_t a = 0; a < D; ++a) lo[a] -= margin, hi[a] += margin;
    hi[D - 1] += room;
  }
  s.domain.xmin = lo[0], s.domain.xmax = hi[0], s.domain.ymin = lo[1], s.domain.ymax = hi[1];
  if constexpr (D == 3) s.domain.zmin = lo[2], s.domain.zmax = hi[2];
  std::vector<std::string> periodic;
  for (std::size_t a = 0; a < D; ++a)
    if (s.domain.periodic()[a]) periodic.emplace_back(1, "xyz"[a]);
  json["domain"] = {{"min_m", std::vector<double>(lo.begin(), lo.end())},
                    {"max_m", std::vector<double>(hi.begin(), hi.end())}, {"periodic", periodic}};
  s.parameters = std::move(json);
  return s;
}

template <int D>
mps::BasicParticles<D> make_particles(const Scene<D>& s) {
  if (s.has_annulus) {
    const Annulus& a = s.annulus;
    mps::Particles rings;
    mps::fill_walled_annulus(rings, a.r_inner, a.rings, s.l0, a.wall_layers, a.dummy_layers, a.span, a.centre,
                             a.groups);
    if constexpr (D == 2) return rings;
    else return mps::extrude(rings, 0.0, s.l0, a.layers_z);
  }
  mps::BasicParticles<D> particles;
  const auto fill = [&](const Block<D>& b, mps::Kind kind) {
    if constexpr (D == 2) mps::fill_rectangle(particles, {b.lo[0], b.lo[1], b.hi[0], b.hi[1]}, s.l0, kind);
    else mps::fill_box(particles, {b.lo[0], b.lo[1], b.lo[2], b.hi[0], b.hi[1], b.hi[2]}, s.l0, kind);
  };
  for (const Block<D>& b : s.fluid) {
    const std::size_t first = particles.size();
    fill(b, mps::Kind::fluid);
    const auto v = particles.velocities();
    for (std::size_t i = first; i < particles.size(); ++i)
      for (std::size_t a = 0; a < D; ++a) (*v[a])[i] = b.velocity[a];
  }
  if (s.has_tank) {
    const Block<D>& t = s.tank;
    if constexpr (D == 2)
      mps::add_rectangle_walls(particles, {t.lo[0], t.lo[1], t.hi[0], t.hi[1]}, s.l0, s.tank_walls, s.wall_layers,
                               s.dummy_layers);
    else
      mps::add_box_walls(particles, {t.lo[0], t.lo[1], t.lo[2], t.hi[0], t.hi[1], t.hi[2]}, s.l0, s.tank_walls,
                         s.wall_layers, s.dummy_layers);
  }
  for (const Wall<D>& w : s.walls) {
    const Block<D>& b = w.box;
    const std::size_t first = particles.size();
    if constexpr (D == 2)
      mps::add_rectangle_walls(particles, {b.lo[0], b.lo[1], b.hi[0], b.hi[1]}, s.l0, w.walls, w.wall_layers,
                               w.dummy_layers, w.group);
    else
      mps::add_box_walls(particles, {b.lo[0], b.lo[1], b.lo[2], b.hi[0], b.hi[1], b.hi[2]}, s.l0, w.walls,
                         w.wall_layers, w.dummy_layers, w.group);
    if (w.part_group == 0) continue;
    const auto r = particles.positions();
    for (std::size_t i = first; i < particles.size(); ++i)
      if ((*r[w.part_axis])[i] < w.part_below) particles.group[i] = w.part_group;
  }
  // An obstacle: dummies, and wall particles within wall_layers spacings of its walled faces.
  const double reach = s.wall_layers * s.l0;
  for (const Obstacle<D>& o : s.obstacles) {
    const std::size_t first = particles.size();
    fill(o.box, mps::Kind::dummy);
    const auto r = particles.positions();
    for (std::size_t i = first; i < particles.size(); ++i) {
      particles.group[i] = o.group;
      for (std::size_t a = 0; a < D; ++a) {
        const double x = (*r[a])[i];
        if (((o.walls & (1u << (2 * a))) != 0 && x - o.box.lo[a] < reach) ||
            ((o.walls & (2u << (2 * a))) != 0 && o.box.hi[a] - x < reach))
          particles.kind[i] = mps::Kind::wall;
      }
    }
  }
  if constexpr (D == 2) {
    for (const Elastic<D>& e : s.elastic) {
      const int nx = static_cast<int>(std::lround((e.box.hi[0] - e.box.lo[0]) / s.l0));
      const int ny = static_cast<int>(std::lround((e.box.hi[1] - e.box.lo[1]) / s.l0));
      if (e.has_mount) {
        // The lattice continued past the clamp face, row by row outwards, while a row's centre lies before `to`.
        const int face = std::countr_zero(e.clamp);
        const std::size_t axis = static_cast<std::size_t>(face / 2);
        const int n = axis == 0 ? nx : ny, across = axis == 0 ? ny : nx;
        const bool high = face % 2 == 1;
        for (int k = high ? n : -1;; k += high ? 1 : -1) {
          const double lead =
              high ? (e.box.lo[axis] + n * s.l0) + (k - n + 0.5) * s.l0 : e.box.lo[axis] + (k + 0.5) * s.l0;
          if (high ? !(lead < e.mount_to) : !(lead > e.mount_to)) break;
          for (int q = 0; q < across; ++q) {
            const unsigned low_face = axis == 0 ? mps::y_low : mps::x_low;
            const unsigned high_face = axis == 0 ? mps::y_high : mps::x_high;
            const bool wall =
                ((e.mount_walls & low_face) != 0 && q == 0) || ((e.mount_walls & high_face) != 0 && q == across - 1);
            const double along = e.box.lo[axis] + (k + 0.5) * s.l0, other = e.box.lo[1 - axis] + (q + 0.5) * s.l0;
            particles.add(axis == 0 ? along : other, axis == 0 ? other : along,
                          wall ? mps::Kind::wall : mps::Kind::dummy, 0);
          }
        }
      }
      // The body's moving particles (its clamped ones lie inside what holds it, whose particles are the fluid's).
      const mps::ElasticBody body = elastic_body(e, s.l0);
      for (std::size_t k = 0; k < body.size(); ++k) {
        if (body.clamped[k]) continue;
        const long i = std::lround((body.x[k] - e.box.lo[0]) / s.l0 - 0.5);
        const long j = std::lround((body.y[k] - e.box.lo[1]) / s.l0 - 0.5);
        const bool face = ((e.walls & mps::x_low) != 0 && i == 0) || ((e.walls & mps::x_high) != 0 && i == nx - 1) ||
                          ((e.walls & mps::y_low) != 0 && j == 0) || ((e.walls & mps::y_high) != 0 && j == ny - 1);
        particles.add(body.x[k], body.y[k], face ? mps::Kind::wall : mps::Kind::dummy, e.group);
      }
    }
  }
  if (s.has_inlet) {
    // The ghost pool, parked one spacing behind the plate's last layer: ghost_rows to a spacing of its height, so
    // that no two coincide, on every layer of its depth in 3-D. Outflow and inflow balance on average; the pool
    // covers three columns at once.
    const Wall<D>& plate = s.walls[s.inlet.wall];
    const Block<D>& b = plate.box;
    const double parking = b.lo[0] - (plate.wall_layers + plate.dummy_layers + 0.5) * s.l0;
    const int pool = s.inlet.ghost_rows * static_cast<int>(std::lround((b.hi[1] - b.lo[1]) / s.l0));
    const int layers = D == 2 ? 1 : static_cast<int>(std::lround((b.hi[D - 1] - b.lo[D - 1]) / s.l0));
    for (int k = 0; k < pool; ++k)
      for (int m = 0; m < layers; ++m) {
        mps::Vec<D> r{};
        r[0] = parking;
        r[1] = b.lo[1] + (k + 0.5) * (b.hi[1] - b.lo[1]) / pool;
        if constexpr (D == 3) r[2] = b.lo[2] + (m + 0.5) * s.l0;
        particles.add(r, mps::Kind::ghost, 0);
      }
  }
  return particles;
}

template <int D>
std::unique_ptr<mps::BasicSimulation<D>> make_simulation(const Scene<D>& s,
                                                         std::shared_ptr<mps::BasicPushingPlate<D>>* plate_out) {
  mps::BasicParticles<D> particles = make_particles(s);
  // The annulus's walls turn about the z axis (each its own group); they start at their velocity.
  using Motion = std::conditional_t<D == 2, mps::RigidMotion, mps::RigidMotion3>;
  std::vector<Motion> motions;
  if (s.has_annulus) {
    const Annulus& a = s.annulus;
    const std::pair<int, AnnulusWall> walls[] = {
        {a.groups.inner, a.inner}, {a.groups.flights, a.flights}, {a.groups.outer, a.outer}};
    for (const auto& [group, w] : walls) {
      if (w.omega == 0 && w.turns == 0) continue;
      if constexpr (D == 2) {
        Motion& m = motions.emplace_back(particles, group, 0.0, 0.0, mps::steady_path(w.turns));
        if (w.omega != w.turns) m.velocity_from(mps::steady_path(w.omega));
      } else {
        Motion& m = motions.emplace_back(particles, group, mps::Vec<3>{0.0, 0.0, 0.0}, mps::Vec<3>{0.0, 0.0, 1.0},
                                         mps::steady_path3(w.turns));
        if (w.omega != w.turns) m.velocity_from(mps::steady_path3(w.omega));
      }
    }
    for (const Motion& m : motions) m(particles, 0.0);
  }
  auto sim = std::make_unique<mps::BasicSimulation<D>>(particles, s.domain, s.config);
  if (!motions.empty())
    sim->template add<mps::BasicBoundaryMotion<D>>([motions](mps::BasicParticles<D>& p, double t) {
      for (const Motion& m : motions) m(p, t);
    });
  std::shared_ptr<mps::BasicPushingPlate<D>> plate;
  double plate_x = 0;
  if (s.has_inlet) {
    plate = std::make_shared<mps::BasicPushingPlate<D>>(particles, s.inlet.plate, s.inlet.speed, s.l0, s.inlet.outlet);
    plate_x = s.walls[s.inlet.wall].box.lo[0];
    sim->template add<mps::BasicBoundaryMotion<D>>(
        [plate](mps::BasicParticles<D>& p, double t, std::size_t owned) { (*plate)(p, t, owned); });
  }
  if (plate_out != nullptr) *plate_out = plate;
  if (!s.free_surface) {
    // No free surface, but behind an inlet's plate (its dry wall ends) and, without a buffer, at its open outlet.
    const bool inlet = s.has_inlet, open_outlet = s.has_inlet && !(s.inlet.buffer > 0);
    const double outlet_zone = s.inlet.outlet - 4 * s.l0;
    sim->template add<mps::BasicSurfaceRegion<D>>(typename mps::BasicSurfaceRegion<D>::Region(
        [=](const mps::Vec<D>& r) { return (inlet && r[0] < plate_x) || (open_outlet && r[0] > outlet_zone); }));
  }
  if (s.has_annulus && s.annulus.mirror) {
    // The circular walls' mirror circles, turning at their walls' rates.
    mps::MirrorWall inner, outer;
    inner.group = s.annulus.groups.inner;
    inner.radius = s.annulus.r_inner;
    inner.omega = s.annulus.inner.omega;
    outer.group = s.annulus.groups.outer;
    outer.radius = s.annulus.r_outer;
    outer.fluid_inside = true;
    outer.omega = s.annulus.outer.omega;
    sim->template add<mps::BasicMirrorNoSlip<D>>(inner);
    sim->template add<mps::BasicMirrorNoSlip<D>>(outer);
  }
  if (s.has_inlet && s.inlet.buffer > 0) {
    mps::BasicOutflowBuffer<D> buffer;
    buffer.point[0] = s.inlet.outlet;
    buffer.thickness = s.inlet.buffer;
    sim->template add<mps::BasicOpenOutlet<D>>(buffer);
  }
  for (const Wall<D>& w : s.walls) {
    if (!w.no_slip) continue;
    // The mirror plane is the wall's face, its normal into the box.
    const int face = std::countr_zero(w.walls);
    const std::size_t axis = static_cast<std::size_t>(face / 2);
    const bool low = face % 2 == 0;
    if constexpr (D == 2) {
      mps::MirrorWall m;
      m.px = axis == 0 ? (low ? w.box.lo[0] : w.box.hi[0]) : 0.0;
      m.py = axis == 1 ? (low ? w.box.lo[1] : w.box.hi[1]) : 0.0;
      m.nx = axis == 0 ? (low ? 1.0 : -1.0) : 0.0;
      m.ny = axis == 1 ? (low ? 1.0 : -1.0) : 0.0;
      m.u = w.velocity[0];
      m.v = w.velocity[1];
      m.group = w.group;
      sim->template add<mps::MirrorNoSlip>(m);
      if (w.part_group > 0) {
        m.u = w.part_velocity[0];
        m.v = w.part_velocity[1];
        m.group = w.part_group;
        sim->template add<mps::MirrorNoSlip>(m);
      }
    } else {
      mps::MirrorPlane<3> m;
      m.point[axis] = low ? w.box.lo[axis] : w.box.hi[axis];
      m.normal[axis] = low ? 1.0 : -1.0;
      m.velocity = w.velocity;
      m.group = w.group;
      sim->template add<mps::MirrorPlaneNoSlip3>(m);
      if (w.part_group > 0) {
        m.velocity = w.part_velocity;
        m.group = w.part_group;
        sim->template add<mps::MirrorPlaneNoSlip3>(m);
      }
    }
  }
  for (const Obstacle<D>& o : s.obstacles) {
    if (!(o.amplitude > 0)) continue;
    // Each of its particles at its start + amplitude sin(omega t) along the axis, moving at the derivative.
    std::vector<double> start(particles.size(), 0.0);
    const auto r0 = particles.positions();
    for (std::size_t i = 0; i < particles.size(); ++i)
      start[static_cast<std::size_t>(particles.id[i])] = (*r0[o.axis])[i];
    const double omega = 2 * std::numbers::pi / o.period;
    sim->template add<mps::BasicBoundaryMotion<D>>(
        [start = std::move(start), o, omega](mps::BasicParticles<D>& p, double t) {
          const auto r = p.positions();
          const auto v = p.velocities();
          for (std::size_t i = 0; i < p.size(); ++i) {
            if (p.group[i] != o.group || p.kind[i] == mps::Kind::fluid) continue;
            (*r[o.axis])[i] = start[static_cast<std::size_t>(p.id[i])] + o.amplitude * std::sin(omega * t);
            (*v[o.axis])[i] = o.amplitude * omega * std::cos(omega * t);
          }
        });
  }
  if (s.collision > 0) sim->template add<mps::BasicParticleCollision<D>>(s.collision, s.restitution);
  if (s.asymmetry > 0) sim->template add<mps::BasicAsymmetrySurface<D>>(s.asymmetry, s.asymmetry_interior_density);
  if (s.wet_walls) sim->template add<mps::BasicWetWalls<D>>();
  const Block<D> tank = s.tank;
  if (s.remove_escaped) {
    // Fluid over a wall's top, or up to the domain's ceiling, leaves the scene; fluid below the walls' top stays.
    const double ceiling = s.domain.upper()[D - 1] - 2 * s.l0;
    const typename mps::BasicRemoveEscaped<D>::Region inside = [=](const mps::Vec<D>& r) {
      if (!(r[D - 1] < ceiling)) return false;
      if (r[D - 1] < tank.hi[D - 1]) return true;
      for (std::size_t a = 0; a + 1 < D; ++a)
        if (!(r[a] > tank.lo[a] && r[a] < tank.hi[a])) return false;
      return true;
    };
    sim->template add<mps::BasicRemoveEscaped<D>>(inside);
  }
  if (s.wall_backstop) {
    std::vector<typename mps::BasicWallBackstop<D>::AxisBox> boxes;
    for (const Obstacle<D>& o : s.obstacles)
      if (!(o.amplitude > 0)) boxes.push_back({o.box.lo, o.box.hi});  // a moving box is not where it started
    sim->template add<mps::BasicWallBackstop<D>>(typename mps::BasicWallBackstop<D>::AxisBox{tank.lo, tank.hi},
                                                 std::move(boxes), s.wall_backstop_slack * s.config.l0);
  }
  if constexpr (D == 2) {
    for (const Elastic<D>& e : s.elastic) {
      // Its moving particles follow the fluid's in the body's order, from the first of its group.
      int first_id = -1;
      for (std::size_t i = 0; i < particles.size() && first_id < 0; ++i)
        if (particles.group[i] == e.group && particles.kind[i] != mps::Kind::fluid) first_id = particles.id[i];
      const double x0 = e.box.lo[0], y0 = e.box.lo[1];
      const double w = static_cast<double>(std::lround((e.box.hi[0] - x0) / s.l0)) * s.l0;
      const double h = static_cast<double>(std::lround((e.box.hi[1] - y0) / s.l0)) * s.l0;
      sim->template add<mps::ElasticStructure>(
          mps::ElasticSolid(elastic_body(e, s.l0), elastic_config(s, e)), e.group, first_id,
          [=](double X, double Y) { return X > x0 && X < x0 + w && Y > y0 && Y < y0 + h; }, e.relaxation);
    }
  }
  return sim;
}

mps::ElasticBody elastic_body(const Elastic<2>& e, double l0) {
  const auto cells = [&](std::size_t a) { return static_cast<int>(std::lround((e.box.hi[a] - e.box.lo[a]) / l0)); };
  const mps::BodyLattice lattice{e.box.lo[0], e.box.lo[1], cells(0), cells(1), l0};
  if (e.cylinder_radius > 0)
    return mps::cylinder_clamped_box_body(lattice, e.cylinder_centre[0], e.cylinder_centre[1], e.cylinder_radius,
                                          Elastic<2>::clamp_layers);
  return mps::clamped_box_body(lattice, e.clamp, Elastic<2>::clamp_layers);
}

mps::ElasticConfig elastic_config(const Scene<2>& s, const Elastic<2>& e) {
  mps::ElasticConfig c;
  c.material = e.material;
  c.cfl = e.cfl;
  c.cfl_option = "cfl of the [[elastic]] body in " + s.file.filename().string();
  c.hourglass = e.hourglass;
  c.gravity_x = s.config.fx;
  c.gravity_y = s.config.fy;
  return c;
}

mps::ElasticSolid make_solid(const Scene<2>& s) {
  const Elastic<2>& e = s.elastic.front();
  mps::ElasticSolid solid(elastic_body(e, s.l0), elastic_config(s, e));
  if (e.first_mode_tip_velocity != 0) {
    // Across the body, growing from its clamp face to its free end as the first bending mode.
    const int face = std::countr_zero(e.clamp);
    const std::size_t along = static_cast<std::size_t>(face / 2);
    const bool high = face % 2 == 1;
    const double length = e.box.hi[along] - e.box.lo[along];
    std::vector<double> velocity[2] = {std::vector<double>(solid.size(), 0.0), std::vector<double>(solid.size(), 0.0)};
    for (std::size_t i = 0; i < solid.moving(); ++i) {
      const double r = along == 0 ? solid.reference_x()[i] : solid.reference_y()[i];
      const double from_clamp = high ? e.box.hi[along] - r : r - e.box.lo[along];
      velocity[1 - along][i] = e.first_mode_tip_velocity * mps::cantilever_first_mode(from_clamp, length);
    }
    solid.set_velocity(velocity[0], velocity[1]);
  }
  return solid;
}

mps::ProbeSeries read_solid_probes(const Scene<2>& s, const mps::ElasticSolid& solid) {
  mps::ProbeSeries series(s.probe_interval);
  if (!s.has_probes) return series;
  const toml::table root = parse(s.file);
  add_solid_probes(label(s.file), root.get("probe"), series, solid, s.elastic.front().group);
  return series;
}

template <int D>
mps::BasicProbeSeries<D> read_probes(const Scene<D>& s, mps::BasicSimulation<D>& sim) {
  mps::BasicProbeSeries<D> series(s.probe_interval);
  if (!s.has_probes) return series;
  const toml::table root = parse(s.file);
  add_probes<D>(label(s.file), root.get("probe"), series, sim);
  return series;
}

bool is_acoustic(const std::filesystem::path& path) { return parse(path).contains("acoustic"); }

AcousticScene read_acoustic_scene(const std::filesystem::path& path, double end_time) {
  const toml::table root = parse(path);
  const std::string file = label(path);
  const Keys top(file, root, "an acoustic scene file",
                 {"title", "dimensions", "spacing", "acoustic", "pulse", "run", "output"});
  if (dimensions_of(path) != 2) fail(file, *top.find("dimensions"), "the acoustic solver is 2-D: set dimensions = 2");
  AcousticScene s;
  s.file = path;
  s.title = top.text("title", "a scene file", path.stem().string());
  acoustic::AcousticRun& run = s.run;
  mps::AcousticConfig& c = run.config;
  {
    const toml::node& spacing = top.need("spacing", "a scene file");
    c.l0 = number(file, spacing, "spacing");
    if (!(c.l0 > 0 && c.l0 <= 1e3)) fail(file, spacing, "'spacing' (l0) must be positive and at most 1000 m");
  }
  const toml::table* field = table_at(file, top, "acoustic");
  const Keys k(file, *field, "[acoustic]",
               {"min", "max", "boundary", "c0", "rho0", "mean_flow", "cfl", "gradient", "weight", "radius",
                "guard_factor", "repeat_frequency"});
  const Block<2> box = box_of<2>(file, *field, k, "[acoustic]", c.l0);
  c.box = {box.lo[0], box.lo[1], box.hi[0], box.hi[1]};
  const auto name_of = [&](const std::string& key, const std::string& otherwise, auto parse_name) {
    const std::string name = k.text(key, "[acoustic]", otherwise);
    try {
      return parse_name(name);
    } catch (const std::invalid_argument& e) {
      fail(file, *k.find(key), e.what());
    }
  };
  c.boundary = name_of("boundary", "mur", mps::parse_acoustic_boundary);
  c.gradient = name_of("gradient", "mps", mps::parse_acoustic_gradient);
  c.weight = name_of("weight", "classic", mps::parse_weight);
  c.c0 = number_in(file, k, "c0", c.c0, 1e-9, 1e5, "in (0, 1e5] m/s");
  c.rho0 = number_in(file, k, "rho0", c.rho0, 1e-9, 1e5, "in (0, 1e5] kg/m^3");
  c.cfl = number_in(file, k, "cfl", c.cfl, 1e-9, 100, "in (0, 100]");
  c.radius = number_in(file, k, "radius", c.radius, 1.5, 10, "in [1.5, 10] l0");
  c.guard_energy_factor = number_in(file, k, "guard_factor", c.guard_energy_factor, 1, 1e6, "in [1, 1e6]");
  if (const toml::node* flow = k.find("mean_flow")) {
    const mps::Vec<2> u = vector_of<2>(file, *flow, "mean_flow", "m/s");
    c.u0x = u[0];
    c.u0y = u[1];
    if (!(std::hypot(u[0], u[1]) < c.c0)) fail(file, *flow, "the mean flow must be below the speed of sound c0");
    if (c.boundary == mps::AcousticBoundary::hard && (u[0] != 0 || u[1] != 0))
      fail(file, *flow, "hard walls with a mean flow have no exact solution here (images need u0 = 0): use "
                        "boundary = \"mur\"");
  }
  try {
    c.validate();
  } catch (const std::invalid_argument& e) {
    fail(file, *field, e.what());
  }
  if (k.find("repeat_frequency") != nullptr) {
    run.repeated = true;
    run.frequency = number_in(file, k, "repeat_frequency", 0, 1e-9, 1e6, "in (0, 1e6] Hz");
  }

  const toml::node* pulses = top.find("pulse");
  if (pulses == nullptr || !pulses->is_array_of_tables() || pulses->as_array()->empty())
    fail(file, pulses != nullptr ? *pulses : static_cast<const toml::node&>(root),
         "an acoustic scene starts from [[pulse]] tables, each with a centre, an amplitude and a half_width");
  const double quarter = 0.25 * std::min(c.box.x1 - c.box.x0, c.box.y1 - c.box.y0);
  nlohmann::json pulse_json = nlohmann::json::array();
  for (const toml::node& node : *pulses->as_array()) {
    const toml::table& t = *node.as_table();
    const Keys pk(file, t, "a [[pulse]]", {"centre", "amplitude", "half_width"});
    const mps::Vec<2> centre = vector_of<2>(file, pk.need("centre", "a [[pulse]]"), "centre", "m");
    if (!(centre[0] > c.box.x0 && centre[0] < c.box.x1 && centre[1] > c.box.y0 && centre[1] < c.box.y1))
      fail(file, *pk.find("centre"), "a pulse's centre must lie inside the box");
    if (pk.find("amplitude") == nullptr || pk.find("half_width") == nullptr)
      fail(file, t, "a [[pulse]] needs 'amplitude' [Pa] and 'half_width' [m]");
    const double amplitude = number_in(file, pk, "amplitude", 0, 1e-100, 1e100, "in (0, 1e100] Pa");
    const double half_width = number_in(file, pk, "half_width", 0, 1e-12, quarter,
                                        "in (0, " + text(quarter) + "] m, a quarter of the box's smaller side");
    run.sources.push_back({centre[0], centre[1], amplitude, half_width, 0.0});
    pulse_json.push_back({{"centre_m", {centre[0], centre[1]}}, {"amplitude_pa", amplitude}, {"b_m", half_width}});
  }

  {
    const toml::table* t = table_at(file, top, "run");
    if (t == nullptr) throw std::invalid_argument(file + ": it needs [run] with 'end_time' [s]");
    const Keys rk(file, *t, "[run]", {"end_time"});
    if (rk.find("end_time") == nullptr) fail(file, *t, "[run] needs 'end_time' [s]");
    run.t_end = end_time > 0 ? end_time : number_in(file, rk, "end_time", 0, 1e-12, 1e4, "positive (at most 1e4 s)");
    if (!(run.t_end >= c.dt()))
      fail(file, *t, "the end time is shorter than one step (dt = cfl l0 / c0 = " + text(c.dt()) + " s)");
  }
  run.dir = std::filesystem::path("runs") / path.stem();
  const auto times = [&](const Keys& ok, const std::string& key) {
    std::vector<double> v;
    const toml::node* node = ok.find(key);
    if (node == nullptr) return v;
    if (!node->is_array()) fail(file, *node, "'" + key + "' lists times [s], as [0.05, 0.1]");
    for (const toml::node& t : *node->as_array()) {
      const double time = number(file, t, key);
      if (!(time >= 0 && time <= 1e4)) fail(file, t, "'" + key + "' lists times in [0, 1e4] s");
      v.push_back(time);
    }
    return v;
  };
  if (const toml::table* output = table_at(file, top, "output")) {
    const Keys ok(file, *output, "[output]", {"out", "samples", "maps", "frames", "tolerance"});
    if (ok.find("out") != nullptr) {
      const std::filesystem::path out = ok.text("out", "[output]", "");
      run.dir = out.is_relative() ? (path.parent_path() / out).lexically_normal() : out;
    }
    run.samples = times(ok, "samples");
    run.maps = times(ok, "maps");
    run.frames = whole_in(file, ok, "frames", -1, 0, 100000);
    run.tolerance = number_in(file, ok, "tolerance", run.tolerance, 1e-15, 1e-2, "in [1e-15, 1e-2] of the amplitude");
  }
  // Those past the end are dropped; the end is always sampled.
  const auto past = [&](double t) { return t > run.t_end + 1e-12; };
  std::erase_if(run.samples, past);
  std::erase_if(run.maps, past);
  std::sort(run.samples.begin(), run.samples.end());
  std::sort(run.maps.begin(), run.maps.end());
  if (std::none_of(run.samples.begin(), run.samples.end(), [&](double t) { return std::abs(t - run.t_end) < 1e-12; }))
    run.samples.push_back(run.t_end);
  s.parameters = {{"title", s.title}, {"dimensions", 2}, {"spacing_m", c.l0},
                  {"box_m", {c.box.x0, c.box.y0, c.box.x1, c.box.y1}}, {"boundary", mps::to_string(c.boundary)},
                  {"c0_m_per_s", c.c0}, {"rho0_kg_per_m3", c.rho0}, {"mean_flow_m_per_s", {c.u0x, c.u0y}},
                  {"cfl", c.cfl}, {"dt_s", c.dt()}, {"gradient", mps::to_string(c.gradient)},
                  {"weight", mps::to_string(c.weight)}, {"radius_l0", c.radius},
                  {"guard_factor", c.guard_energy_factor}, {"pulses", pulse_json},
                  {"repeat_frequency_hz", run.repeated ? nlohmann::json(run.frequency) : nlohmann::json(nullptr)},
                  {"end_time_s", run.t_end}, {"samples_s", run.samples}, {"maps_s", run.maps},
                  {"frame_count", run.frames}, {"tolerance_over_eps", run.tolerance}};
  return s;
}

template Scene<2> read_scene<2>(const std::filesystem::path&);
template Scene<3> read_scene<3>(const std::filesystem::path&);
template mps::BasicParticles<2> make_particles<2>(const Scene<2>&);
template mps::BasicParticles<3> make_particles<3>(const Scene<3>&);
template std::unique_ptr<mps::BasicSimulation<2>> make_simulation<2>(const Scene<2>&,
                                                                     std::shared_ptr<mps::BasicPushingPlate<2>>*);
template std::unique_ptr<mps::BasicSimulation<3>> make_simulation<3>(const Scene<3>&,
                                                                     std::shared_ptr<mps::BasicPushingPlate<3>>*);
template mps::BasicProbeSeries<2> read_probes<2>(const Scene<2>&, mps::BasicSimulation<2>&);
template mps::BasicProbeSeries<3> read_probes<3>(const Scene<3>&, mps::BasicSimulation<3>&);

}  // namespace scene_file
