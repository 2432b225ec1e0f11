// Particles, domain, configuration, the time loop and PPE assembly from particle arrays.
#include <pybind11/stl.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "convert.hpp"
#include "mps/boundaries/geometry.hpp"
#include "mps/io/io.hpp"
#include "mps/step/components.hpp"
#include "mps/step/step.hpp"

namespace sparsemps {
namespace {

using Config = mps::SimulationConfig;

std::string repr(double v) { return py::repr(py::float_(v)).cast<std::string>(); }

std::string short_number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", v);
  return text;
}

// ---------------------------------------------------------------------------------------------------------------
// Kinds and particles

mps::Kind kind_of(py::handle obj) {
  if (py::isinstance<mps::Kind>(obj)) return obj.cast<mps::Kind>();
  if (py::isinstance<py::str>(obj)) {
    const auto name = obj.cast<std::string>();
    for (const mps::Kind k : {mps::Kind::fluid, mps::Kind::wall, mps::Kind::dummy, mps::Kind::ghost})
      if (name == mps::to_string(k)) return k;
    throw py::value_error("unknown particle kind '" + name + "'; valid: fluid, wall, dummy, ghost");
  }
  if (PyIndex_Check(obj.ptr()) && !PyBool_Check(obj.ptr())) {
    const auto v = obj.cast<long long>();
    if (v < 0 || v > 3) throw py::value_error("particle kind " + std::to_string(v) + " is not 0-3 (fluid, wall, dummy, ghost)");
    return static_cast<mps::Kind>(v);
  }
  throw py::type_error("a particle kind is a Kind, a name ('fluid', 'wall', 'dummy', 'ghost') or 0-3");
}

bool is_scalar_kind(py::handle obj) {
  return py::isinstance<mps::Kind>(obj) || py::isinstance<py::str>(obj) ||
         (PyIndex_Check(obj.ptr()) && !PyBool_Check(obj.ptr()) && !py::isinstance<py::array>(obj));
}

std::vector<mps::Kind> kinds_of(py::handle obj, std::size_t n) {
  if (is_scalar_kind(obj)) return std::vector<mps::Kind>(n, kind_of(obj));
  const std::vector<int> values = to_ints(obj, "kind", static_cast<py::ssize_t>(n));
  std::vector<mps::Kind> out(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (values[i] < 0 || values[i] > 3)
      throw py::value_error("kind[" + std::to_string(i) + "] = " + std::to_string(values[i]) +
                            " is not 0-3 (fluid, wall, dummy, ghost)");
    out[i] = static_cast<mps::Kind>(values[i]);
  }
  return out;
}

py::array_t<std::uint8_t> kinds_to_numpy(const std::vector<mps::Kind>& kinds) {
  py::array_t<std::uint8_t> out(static_cast<py::ssize_t>(kinds.size()));
  std::uint8_t* data = out.mutable_data();
  for (std::size_t i = 0; i < kinds.size(); ++i) data[i] = static_cast<std::uint8_t>(kinds[i]);
  return out;
}

unsigned sides_of(py::handle obj) {
  std::vector<std::string> names;
  if (py::isinstance<py::str>(obj)) {
    std::string text = obj.cast<std::string>();
    std::replace_if(text.begin(), text.end(), [](char c) { return c == '|' || c == ','; }, ' ');
    std::istringstream words(text);
    for (std::string w; words >> w;) names.push_back(w);
  } else {
    for (py::handle item : obj) names.push_back(py::str(item).cast<std::string>());
  }
  unsigned sides = 0;
  for (const std::string& name : names) {
    if (name == "left") sides |= mps::left;
    else if (name == "right") sides |= mps::right;
    else if (name == "bottom") sides |= mps::bottom;
    else if (name == "top") sides |= mps::top;
    else throw py::value_error("unknown side '" + name + "'; valid: left, right, bottom, top");
  }
  return sides;
}

std::string type_name(py::handle obj) { return py::str(py::type::of(obj).attr("__name__")).cast<std::string>(); }

// Four numbers from a tuple or list; `what` and `form` name it in the messages.
std::vector<double> four_numbers(py::handle obj, const std::string& what, const std::string& form) {
  std::vector<double> v;
  try {
    v = obj.cast<std::vector<double>>();
  } catch (const py::cast_error&) {
    throw py::type_error(what + " must be " + form + ", got " + type_name(obj));
  }
  if (v.size() != 4)
    throw py::value_error(what + " must be " + form + ", got " + std::to_string(v.size()) + " numbers");
  return v;
}

mps::Rect rect_of(py::handle obj, const char* what) {
  const std::vector<double> v = four_numbers(obj, what, "(x0, y0, x1, y1)");
  for (const double c : v)
    if (!std::isfinite(c)) throw py::value_error(std::string(what) + " holds " + repr(c) + "; give finite coordinates");
  return {v[0], v[1], v[2], v[3]};
}

// As the apps refuse a run too large (apps/common/checks.hpp), before anything is allocated: more particles than 2e7
// or than this machine's memory holds at the 2 KB a particle takes at least in a simulation.
void check_particle_count(double added, std::size_t existing, const std::string& what) {
  constexpr double kBytesPerParticle = 2000;
  const double memory = static_cast<double>(sysconf(_SC_PHYS_PAGES)) * static_cast<double>(sysconf(_SC_PAGE_SIZE));
  const double limit = std::min(2e7, memory / kBytesPerParticle);
  const double total = added + static_cast<double>(existing);
  if (!(total <= limit)) {
    char text[400];
    std::snprintf(text, sizeof text,
                  "%s would make about %.3g particles (%.3g GB at 2 KB each; this machine has %.3g GB), more than "
                  "the %.3g a scene may hold here; use a larger l0 or a smaller rectangle",
                  what.c_str(), total, total * kBytesPerParticle / 1e9, memory / 1e9, limit);
    throw py::value_error(text);
  }
}

// Lattice cells along a length, as mps::geometry counts them (rounded), in floating point so that nothing overflows.
double cells(double length, double l0) { return std::max(0.0, std::round(length / l0)); }

// A per-particle double array: a copy out, and a checked copy in.
void def_array(py::class_<mps::Particles>& c, const char* name, std::vector<double> mps::Particles::*member,
               const char* doc) {
  c.def_property(
      name, [member](const mps::Particles& p) { return to_numpy(p.*member); },
      [member, name](mps::Particles& p, py::handle values) {
        p.*member = to_finite_doubles(values, name, static_cast<py::ssize_t>(p.size()));
      },
      doc);
}

mps::Domain domain_of(py::handle obj) {
  if (py::isinstance<mps::Domain>(obj)) return obj.cast<mps::Domain>();
  const std::vector<double> v =
      four_numbers(obj, "the domain", "a sparsemps.Domain or a 4-tuple (xmin, xmax, ymin, ymax)");
  const mps::Domain d{v[0], v[1], v[2], v[3]};
  d.validate();
  return d;
}

// ---------------------------------------------------------------------------------------------------------------
// SimulationConfig as a table of fields, so that keyword construction, attributes and to_dict() share one list and a
// misspelt key is an error naming it.

double as_number(py::handle v, const std::string& name) {
  if (PyBool_Check(v.ptr()) || py::isinstance<py::str>(v) || !PyNumber_Check(v.ptr()))
    throw py::type_error("SimulationConfig." + name + " takes a number, got " +
                         py::str(py::type::of(v).attr("__name__")).cast<std::string>());
  try {
    return v.cast<double>();
  } catch (const py::cast_error&) {
    throw py::type_error("SimulationConfig." + name + " takes a real number");
  }
}

bool as_bool(py::handle v, const std::string& name) {
  const bool numpy_bool = py::isinstance(v, py::module_::import("numpy").attr("bool_"));
  if (!PyBool_Check(v.ptr()) && !numpy_bool)
    throw py::type_error("SimulationConfig." + name + " takes True or False, got " +
                         py::str(py::type::of(v).attr("__name__")).cast<std::string>());
  return v.cast<bool>();
}

int as_int(py::handle v, const std::string& name) {
  if (PyBool_Check(v.ptr()) || !PyIndex_Check(v.ptr()))
    throw py::type_error("SimulationConfig." + name + " takes an integer, got " +
                         py::str(py::type::of(v).attr("__name__")).cast<std::string>());
  const auto value = v.cast<long long>();
  if (value < std::numeric_limits<int>::min() || value > std::numeric_limits<int>::max())
    throw py::value_error("SimulationConfig." + name + " = " + std::to_string(value) + " is beyond 32 bits");
  return static_cast<int>(value);
}

std::string as_string(py::handle v, const std::string& name) {
  if (!py::isinstance<py::str>(v))
    throw py::type_error("SimulationConfig." + name + " takes a string, got " +
                         py::str(py::type::of(v).attr("__name__")).cast<std::string>());
  return v.cast<std::string>();
}

struct Field {
  std::string name;
  std::function<py::object(const Config&)> get;
  std::function<void(Config&, py::handle)> set;
  std::string doc;
};

// A Python value as a field of type T (the schema's types), and back.
template <class T>
py::object python_value(const T& v) {
  if constexpr (std::is_same_v<T, mps::Weight> || std::is_same_v<T, mps::GradientVariant>)
    return py::str(std::string(mps::to_string(v)));
  else return py::cast(v);
}
template <class T>
T field_value(py::handle v, const char* name) {
  if constexpr (std::is_same_v<T, double>) return as_number(v, name);
  else if constexpr (std::is_same_v<T, int>) return as_int(v, name);
  else if constexpr (std::is_same_v<T, bool>) return as_bool(v, name);
  else if constexpr (std::is_same_v<T, std::string>) return as_string(v, name);
  else if constexpr (std::is_same_v<T, mps::Weight>) return mps::parse_weight(as_string(v, name));
  else return mps::gradient_variant_from_name(as_string(v, name));
}

// mps::SimulationConfig's fields as its schema lists them (mps::for_each_parameter, lib/mps/step/config.hpp).
const std::vector<Field>& config_fields() {
  static const std::vector<Field> fields = [] {
    std::vector<Field> out;
    mps::for_each_parameter([&out]<class T>(const mps::Parameter<T>& p) {
      std::string doc = p.doc;
      if (*p.unit) doc += " [" + std::string(p.unit) + "]";
      out.push_back({p.name, [m = p.member](const Config& c) { return python_value(c.*m); },
                     [m = p.member, name = p.name](Config& c, py::handle v) { c.*m = field_value<T>(v, name); }, doc});
    });
    return out;
  }();
  return fields;
}

void set_fields(Config& c, const py::dict& values) {
  for (const auto& [key, value] : values) {
    const auto name = py::str(key).cast<std::string>();
    const auto& fields = config_fields();
    const auto it = std::find_if(fields.begin(), fields.end(), [&](const Field& f) { return f.name == name; });
    if (it == fields.end()) {
      std::string valid;
      for (const Field& f : fields) valid += (valid.empty() ? "" : ", ") + f.name;
      throw py::value_error("SimulationConfig has no field '" + name + "'; valid fields: " + valid);
    }
    it->set(c, value);
  }
}

// config: None, a SimulationConfig or a dict; `overrides` (keyword arguments) are applied on top.
Config config_of(py::handle config, const py::dict& overrides) {
  Config c;
  if (py::isinstance<Config>(config)) c = config.cast<Config>();
  else if (py::isinstance<py::dict>(config)) set_fields(c, config.cast<py::dict>());
  else if (!config.is_none()) throw py::type_error("config must be a SimulationConfig, a dict or None");
  set_fields(c, overrides);
  return c;
}

py::dict config_dict(const Config& c) {
  py::dict out;
  for (const Field& f : config_fields()) out[py::str(f.name)] = f.get(c);
  return out;
}

// ---------------------------------------------------------------------------------------------------------------
// The PPE with what the step knew when it assembled it.

struct Ppe {
  mps::PpeSystem system;
  std::vector<mps::Kind> kind;  // of the particles, in the step's order
  std::vector<char> surface, held;
  std::vector<double> n_star, div, source, held_value, offset;
};

// Copies the step's fields at the last hook before assembly (components run in the order added, so it sees the
// source and held values every earlier component set).
class Recorder : public mps::StepComponent {
 public:
  explicit Recorder(std::shared_ptr<Ppe> out) : out_(std::move(out)) {}
  void before_assembly(mps::StepContext& c) override {
    const mps::StepFields& f = c.fields;
    Ppe& o = *out_;
    o.kind = c.particles.kind;
    o.surface = f.surface;
    o.held = f.held.empty() ? f.surface : f.held;
    o.n_star = f.n_star;
    o.div = f.div;
    o.source = f.source;
    o.held_value = f.held_value;
    o.offset = f.pressure_offset;
  }

 protected:
  std::shared_ptr<Ppe> out_;
};

// The particles at r* with velocities u*, whatever the predictor made of them; wrapped onto periodic axes as the
// predictor wraps r*, so that r + dt u* given unwrapped lands where the step puts it.
class Injector final : public Recorder {
 public:
  Injector(std::shared_ptr<Ppe> out, const mps::Particles& star) : Recorder(std::move(out)), star_(star) {}
  void after_predictor(mps::StepContext& c) override {
    mps::Particles& p = c.particles;
    p.x = star_.x;
    p.y = star_.y;
    p.u = star_.u;
    p.v = star_.v;
    for (std::size_t i = 0; i < p.size(); ++i) c.sim.domain().wrap(p.x[i], p.y[i]);
  }
 private:
  const mps::Particles& star_;
};

py::object optional_doubles(const std::vector<double>& v) { return v.empty() ? py::object(py::none()) : to_numpy(v); }

const char* ppe_doc =
    "A pressure Poisson equation A x = b as a time step assembled it (mps::PpeSystem and the step's fields).\n\n"
    "A = -(discrete Laplacian) over the unknowns (wet fluid and wall particles off the free surface), symmetric\n"
    "positive definite; x is the pressure, or P - offset when the config splits off the hydrostatic pressure.\n"
    "Per-unknown arrays are in unknown order, per-particle arrays in the particles' order of that step.";

// The scene components that need no callback, with the ranges the apps accept.
void add_asymmetry_surface(mps::Simulation& sim, double fraction) {
  if (!(fraction > 0.0 && fraction <= 10.0))
    throw py::value_error("asymmetry fraction must be in (0, 10], got " + std::to_string(fraction));
  sim.add<mps::AsymmetrySurface>(fraction);
}

void add_particle_collision(mps::Simulation& sim, double distance, double restitution) {
  if (!(distance > 0.0 && distance < 1.0))
    throw py::value_error("collision distance must be in (0, 1) l0, got " + std::to_string(distance));
  if (!(restitution >= 0.0 && restitution <= 1.0))
    throw py::value_error("restitution must be in [0, 1], got " + std::to_string(restitution));
  sim.add<mps::ParticleCollision>(distance, restitution);
}

// ---------------------------------------------------------------------------------------------------------------
// The simulation, with a lock so that a step running without the GIL is never overlapped by another call.

struct Simulation {
  std::unique_ptr<mps::Simulation> sim;
  std::shared_ptr<Ppe> recorded = std::make_shared<Ppe>();
  mutable std::mutex mutex;

  // The recorder goes first among the scene's components: those offered here do not hook before_assembly, so it
  // still sees every field as the assembly does.
  Simulation(const mps::Particles& particles, const mps::Domain& domain, const Config& config)
      : sim(std::make_unique<mps::Simulation>(particles, domain, config)) {
    sim->add<Recorder>(recorded);
  }

  template <class F>
  auto locked(F&& f) const {
    const std::lock_guard<std::mutex> lock(mutex);
    return f();
  }

  mps::StepInfo step() {
    const py::gil_scoped_release release;
    const std::lock_guard<std::mutex> lock(mutex);
    return sim->step();
  }
};

// A run that cannot advance, or one too long to be meant (the apps' bound, apps/common/checks.hpp), is refused before
// the first step: end_time NaN or Inf ran until the guard tripped, end_time in the past or steps < 1 returned silently.
void check_run(const Simulation& s, std::optional<double> end_time, std::optional<long long> steps) {
  constexpr double kMaxSteps = 1e8;
  if (!end_time && !steps) throw py::value_error("run: give end_time, steps or both");
  if (steps && *steps < 1)
    throw py::value_error("run: steps = " + std::to_string(*steps) + " takes no step; give steps >= 1");
  double fewest_steps = steps ? static_cast<double>(*steps) : std::numeric_limits<double>::infinity();
  if (end_time) {
    const double now = s.locked([&] { return s.sim->time(); });
    if (!std::isfinite(*end_time))
      throw py::value_error("run: end_time = " + repr(*end_time) +
                            " is not a finite time; give the time to stop at [s]");
    if (!(*end_time - 1e-12 > now))  // the loop's own test for "reached"
      throw py::value_error("run: end_time = " + repr(*end_time) + " s is not beyond the current time " + repr(now) +
                            " s; give a later end_time");
    const double dt_max = s.sim->config().dt_max;
    fewest_steps = std::min(fewest_steps, std::ceil((*end_time - now) / dt_max));
    if (fewest_steps > kMaxSteps)
      throw py::value_error("run: end_time = " + repr(*end_time) + " s is at least " + short_number(fewest_steps) +
                            " steps of at most dt_max = " + repr(dt_max) + " s away, more than the 1e8 a run may " +
                            "take; give an earlier end_time or a larger dt_max");
  }
  if (fewest_steps > kMaxSteps)
    throw py::value_error("run: steps = " + std::to_string(*steps) + " is more than the 1e8 a run may take; " +
                          "run in parts or take fewer steps");
}

// PPE assembly: the step's own stages run on particles placed at r* with velocities u*, up to the solve.
Ppe assemble(const mps::Particles& star, double dt, py::handle domain_in, Config config, double asymmetry,
             bool wet_walls) {
  if (!(dt > 0.0 && std::isfinite(dt))) throw py::value_error("dt must be positive and finite");
  // dt exactly as given: no CFL or viscous limit (viscosity does not enter the PPE); no reordering, so unknowns are
  // numbered in the particles' order.
  config.dt_max = dt;
  config.cfl = std::numeric_limits<double>::max();
  config.nu = 0.0;
  config.implicit_viscosity = false;
  config.shifting = 0.0;
  config.reorder_every = 0;
  config.validate();
  mps::Domain domain;
  if (domain_in.is_none()) {
    // Any box holding the particles gives the same system: neighbour lists are sorted whatever the cells.
    const double margin = config.l0 * (2.0 + std::max({config.radius_density, config.radius_surface,
                                                       config.radius_gradient, config.radius_laplacian}));
    double x0 = 0, x1 = 0, y0 = 0, y1 = 0;
    bool first = true;
    for (std::size_t i = 0; i < star.size(); ++i) {
      if (star.kind[i] == mps::Kind::ghost || !std::isfinite(star.x[i]) || !std::isfinite(star.y[i])) continue;
      x0 = first ? star.x[i] : std::min(x0, star.x[i]);
      x1 = first ? star.x[i] : std::max(x1, star.x[i]);
      y0 = first ? star.y[i] : std::min(y0, star.y[i]);
      y1 = first ? star.y[i] : std::max(y1, star.y[i]);
      first = false;
    }
    domain = {x0 - margin, x1 + margin, y0 - margin, y1 + margin};
  } else {
    domain = domain_of(domain_in);
  }
  auto out = std::make_shared<Ppe>();
  mps::Simulation sim(star, domain, config);
  if (asymmetry != 0.0) add_asymmetry_surface(sim, asymmetry);  // which names a fraction out of range, NaN included
  if (wet_walls) sim.add<mps::WetWalls>();
  sim.add<Injector>(out, star);
  try {
    const py::gil_scoped_release release;
    sim.advance_to(mps::Stage::assembly);  // the step's own stages, stopped once the PPE is assembled
  } catch (const mps::SimulationError& e) {
    throw py::value_error(std::string("assemble_ppe: ") + e.what());
  }
  out->system = sim.last_ppe();
  return std::move(*out);
}

mps::Particles particles_from_arrays(py::handle x, py::handle y, py::handle u, py::handle v, py::handle kind) {
  mps::Particles p;
  const std::vector<double> xs = to_finite_doubles(x, "x");
  const auto n = static_cast<py::ssize_t>(xs.size());
  const std::vector<double> ys = to_finite_doubles(y, "y", n);
  const std::vector<mps::Kind> kinds = kinds_of(kind, xs.size());
  p.reserve(xs.size());
  for (std::size_t i = 0; i < xs.size(); ++i) p.add(xs[i], ys[i], kinds[i]);
  if (!u.is_none()) p.u = to_finite_doubles(u, "u", n);
  if (!v.is_none()) p.v = to_finite_doubles(v, "v", n);
  return p;
}

const char* assemble_doc =
    "The PPE a time step assembles for particles at r* with velocities u* (after the predictor); returns a Ppe.\n\n"
    "It runs mps::Simulation's own stages on the particles as given and stops at the solve: neighbours at r*,\n"
    "number density n* and div u*, free surface (n* < beta n0 and fewer than theta N0 neighbours), the mixed\n"
    "source (1 - gamma)(rho/dt) div u* - gamma (rho/dt^2)(n* - n0)/n0 (divergence only where the source kernel\n"
    "reaches the free surface), the hydrostatic split under a body force, the assembly. So the matrix and rhs are\n"
    "bitwise those Simulation.step() builds for the same particles.\n\n"
    "asymmetry, wet_walls: the free-surface components of Simulation.add_asymmetry_surface and add_wet_walls\n"
    "(0 / False: off).\n"
    "dt: the step [s]. domain: Domain or (xmin, xmax, ymin, ymax), needed for periodic axes, along which r* is\n"
    "wrapped as the predictor wraps it (default: a box around the particles). config / keyword fields: SimulationConfig fields (l0 required; the radii, weight, rho,\n"
    "gamma, beta, theta, fx, fy, hydrostatic_split, sound_speed, initial_reference_density matter).";

}  // namespace

void bind_scene(py::module_& m) {
  py::enum_<mps::Kind>(m, "Kind", "Particle kinds: fluid, wall (first boundary layer, a PPE unknown), dummy (outer "
                                  "layers), ghost (inactive). Kind arrays are uint8 with these values.")
      .value("fluid", mps::Kind::fluid)
      .value("wall", mps::Kind::wall)
      .value("dummy", mps::Kind::dummy)
      .value("ghost", mps::Kind::ghost);

  py::class_<mps::Domain>(m, "Domain",
                          "The region particles may occupy; a periodic axis wraps positions (mps::Domain).")
      .def(py::init([](double xmin, double xmax, double ymin, double ymax, bool px, bool py_) {
             mps::Domain d{xmin, xmax, ymin, ymax, px, py_};
             d.validate();
             return d;
           }),
           py::arg("xmin"), py::arg("xmax"), py::arg("ymin"), py::arg("ymax"), py::arg("periodic_x") = false,
           py::arg("periodic_y") = false)
      .def_readwrite("xmin", &mps::Domain::xmin)
      .def_readwrite("xmax", &mps::Domain::xmax)
      .def_readwrite("ymin", &mps::Domain::ymin)
      .def_readwrite("ymax", &mps::Domain::ymax)
      .def_readwrite("periodic_x", &mps::Domain::periodic_x)
      .def_readwrite("periodic_y", &mps::Domain::periodic_y)
      .def("contains", [](const mps::Domain& d, double x, double y) { return d.contains(x, y); }, py::arg("x"),
           py::arg("y"))
      .def("__repr__", [](const mps::Domain& d) {
        std::ostringstream s;
        s.precision(17);
        s << "Domain(" << d.xmin << ", " << d.xmax << ", " << d.ymin << ", " << d.ymax
          << ", periodic_x=" << (d.periodic_x ? "True" : "False") << ", periodic_y=" << (d.periodic_y ? "True" : "False")
          << ")";
        return s.str();
      });

  py::class_<mps::Particles> particles_class(
      m, "Particles",
      "Particle state as arrays (mps::Particles): x, y, u, v, p, kind, group, id. Reading an attribute gives a\n"
      "NumPy copy; assigning one takes an array of the same length (positions, velocities and pressures finite).\n"
      "id is each particle's index at creation and follows it through the reorderings a Simulation makes.");
  particles_class
      .def(py::init([](py::handle x, py::handle y, py::handle kind, py::handle u, py::handle v, py::handle p,
                       py::handle group) {
             if (x.is_none() && y.is_none()) return mps::Particles{};
             if (kind.is_none()) throw py::value_error("Particles(x, y, kind): kind is required with positions");
             mps::Particles out = particles_from_arrays(x, y, u, v, kind);
             const auto n = static_cast<py::ssize_t>(out.size());
             if (!p.is_none()) out.p = to_finite_doubles(p, "p", n);
             if (!group.is_none()) out.group = to_ints(group, "group", n);
             return out;
           }),
           py::arg("x") = py::none(), py::arg("y") = py::none(), py::arg("kind") = py::none(),
           py::arg("u") = py::none(), py::arg("v") = py::none(), py::arg("p") = py::none(),
           py::arg("group") = py::none(),
           "Empty, or from arrays: x, y and kind (an array of 0-3, or one Kind / name for all); u, v, p, group\n"
           "default to 0.")
      .def("__len__", &mps::Particles::size)
      .def("count", [](const mps::Particles& p, py::handle kind) { return p.count(kind_of(kind)); }, py::arg("kind"),
           "How many particles are of this kind.")
      .def(
          "fill_rectangle",
          [](mps::Particles& p, py::handle rect_in, double l0, py::handle kind, int group) -> mps::Particles& {
            const mps::Rect rect = rect_of(rect_in, "rect");
            if (l0 > 0.0 && std::isfinite(l0))  // else the library names l0
              check_particle_count(cells(rect.x1 - rect.x0, l0) * cells(rect.y1 - rect.y0, l0), p.size(),
                                   "fill_rectangle");
            mps::fill_rectangle(p, rect, l0, kind_of(kind), group);
            return p;
          },
          py::arg("rect"), py::arg("l0"), py::arg("kind") = "fluid", py::arg("group") = 0,
          py::return_value_policy::reference_internal,
          "Adds a square lattice of spacing l0 filling rect = (x0, y0, x1, y1), points at cell centres; returns self.")
      .def(
          "add_rectangle_walls",
          [](mps::Particles& p, py::handle inner, double l0, py::handle sides, int wall_layers, int dummy_layers,
             int group) -> mps::Particles& {
            const mps::Rect rect = rect_of(inner, "inner");
            if (l0 > 0.0 && std::isfinite(l0) && wall_layers >= 0 && dummy_layers >= 0) {  // else the library says why
              // The frame of layers around the rectangle, every side walled: an upper bound of what is added.
              const double nx = cells(rect.x1 - rect.x0, l0), ny = cells(rect.y1 - rect.y0, l0);
              const double layers = static_cast<double>(wall_layers) + dummy_layers;
              check_particle_count((nx + 2 * layers) * (ny + 2 * layers) - nx * ny, p.size(), "add_rectangle_walls");
            }
            mps::add_rectangle_walls(p, rect, l0, sides_of(sides), wall_layers, dummy_layers, group);
            return p;
          },
          py::arg("inner"), py::arg("l0"), py::arg("sides") = "left|right|bottom", py::arg("wall_layers") = 1,
          py::arg("dummy_layers") = 4, py::arg("group") = 0, py::return_value_policy::reference_internal,
          "Adds wall_layers of wall and dummy_layers of dummy particles outside inner = (x0, y0, x1, y1) on the\n"
          "given sides ('left|right|bottom' or a list of names; corners between walled sides included); returns self.")
      .def_property(
          "kind", [](const mps::Particles& p) { return kinds_to_numpy(p.kind); },
          [](mps::Particles& p, py::handle values) { p.kind = kinds_of(values, p.size()); },
          "uint8 array: 0 fluid, 1 wall, 2 dummy, 3 ghost")
      .def_property(
          "group", [](const mps::Particles& p) { return to_numpy(p.group); },
          [](mps::Particles& p, py::handle values) {
            p.group = to_ints(values, "group", static_cast<py::ssize_t>(p.size()));
          },
          "user tag, e.g. which wall moves with which motion")
      .def_property_readonly(
          "id", [](const mps::Particles& p) { return to_numpy(p.id); }, "index at creation")
      .def("__repr__", [](const mps::Particles& p) {
        return "Particles(" + std::to_string(p.size()) + ": " + std::to_string(p.count(mps::Kind::fluid)) +
               " fluid, " + std::to_string(p.count(mps::Kind::wall)) + " wall, " +
               std::to_string(p.count(mps::Kind::dummy)) + " dummy, " + std::to_string(p.count(mps::Kind::ghost)) +
               " ghost)";
      });
  def_array(particles_class, "x", &mps::Particles::x, "position x [m]");
  def_array(particles_class, "y", &mps::Particles::y, "position y [m]");
  def_array(particles_class, "u", &mps::Particles::u, "velocity x [m/s]");
  def_array(particles_class, "v", &mps::Particles::v, "velocity y [m/s]");
  def_array(particles_class, "p", &mps::Particles::p, "pressure [Pa]");

  std::string config_doc =
      "The physics and numerics of a run (mps::SimulationConfig; lib/mps/step/config.hpp and docs/step.md give each\n"
      "default's reason). SimulationConfig(**fields); a misspelt field is a ValueError naming it.\n\nFields:\n";
  for (const Field& f : config_fields()) config_doc += "  " + f.name + ": " + f.doc + "\n";
  py::class_<Config> config_class(m, "SimulationConfig", config_doc.c_str());
  config_class.def(py::init([](const py::kwargs& fields) { return config_of(py::none(), fields); }))
      .def("to_dict", &config_dict, "Every field with its value.")
      .def("validate", &Config::validate, "Raises ValueError naming a parameter out of its range.")
      .def("__repr__", [](const Config& c) {
        std::string out = "SimulationConfig(";
        bool first = true;
        for (const Field& f : config_fields()) {
          out += (first ? "" : ", ") + f.name + "=" + py::repr(f.get(c)).cast<std::string>();
          first = false;
        }
        return out + ")";
      });
  for (const Field& f : config_fields())
    config_class.def_property(
        f.name.c_str(), [get = f.get](const Config& c) { return get(c); },
        [set = f.set](Config& c, py::handle v) { set(c, v); }, f.doc.c_str());

  py::class_<mps::StepInfo>(m, "StepInfo", "What the last step did (mps::StepInfo).")
      .def_readonly("step", &mps::StepInfo::step, "steps completed")
      .def_readonly("time", &mps::StepInfo::time)
      .def_readonly("dt", &mps::StepInfo::dt)
      .def_readonly("dt_limit", &mps::StepInfo::dt_limit, "which bound set dt: dt_max, cfl or viscous")
      .def_readonly("solve", &mps::StepInfo::solve, "the pressure solve's SolveReport")
      .def_readonly("viscosity_iterations", &mps::StepInfo::viscosity_iterations)
      .def_readonly("unknowns", &mps::StepInfo::unknowns)
      .def_readonly("free_surface", &mps::StepInfo::free_surface, "particles flagged free surface")
      .def_readonly("floating_groups", &mps::StepInfo::floating_groups, "closed groups given the gauge")
      .def_readonly("max_speed", &mps::StepInfo::max_speed, "largest fluid speed [m/s]")
      .def("__repr__", [](const mps::StepInfo& s) {
        std::ostringstream out;
        out << "StepInfo(step=" << s.step << ", time=" << s.time << ", dt=" << s.dt << " (" << s.dt_limit
            << "), unknowns=" << s.unknowns << ", " << s.solve.backend << " iterations=" << s.solve.iterations
            << ", max_speed=" << s.max_speed << ")";
        return out.str();
      });

  py::class_<Ppe>(m, "Ppe", ppe_doc)
      .def_property_readonly(
          "matrix", [](const Ppe& p) { return to_scipy(p.system.matrix); }, "A as scipy.sparse.csr_matrix")
      .def_property_readonly(
          "rhs", [](const Ppe& p) { return to_numpy(p.system.rhs); }, "b: -(source) plus the held values' terms")
      .def_property_readonly(
          "unknown", [](const Ppe& p) { return to_numpy(p.system.unknown); }, "particle -> unknown, or -1")
      .def_property_readonly(
          "particle", [](const Ppe& p) { return to_numpy(p.system.particle); }, "unknown -> particle")
      .def_property_readonly(
          "floating_groups", [](const Ppe& p) { return p.system.floating.size(); },
          "closed groups of unknowns (no free surface) given the gauge (lib/mps/numerics/ppe.hpp)")
      .def_property_readonly(
          "free_surface", [](const Ppe& p) { return flags_to_numpy(p.surface); }, "per particle")
      .def_property_readonly(
          "held", [](const Ppe& p) { return flags_to_numpy(p.held); },
          "per particle: held at a given pressure, not unknowns (the free surface unless a boundary holds others)")
      .def_property_readonly(
          "number_density", [](const Ppe& p) { return to_numpy(p.n_star); }, "n* per particle")
      .def_property_readonly(
          "divergence", [](const Ppe& p) { return to_numpy(p.div); }, "div u* per particle")
      .def_property_readonly(
          "source", [](const Ppe& p) { return to_numpy(p.source); }, "per particle: lap P = source")
      .def_property_readonly(
          "offset", [](const Ppe& p) { return optional_doubles(p.offset); },
          "per particle: x solves for P - offset (the hydrostatic split), None when x is P")
      .def(
          "pressures",
          [](const Ppe& p, py::handle x, bool clamp_negative) {
            const std::vector<double> solution =
                to_finite_doubles(x, "x", static_cast<py::ssize_t>(p.system.size()));
            mps::Particles scratch;
            for (const mps::Kind k : p.kind) scratch.add(0.0, 0.0, k);
            p.system.scatter(solution, scratch, clamp_negative, p.offset);
            // As the step does: a held fluid particle shows the pressure it was held at.
            if (!p.held_value.empty())
              for (std::size_t i = 0; i < p.kind.size(); ++i)
                if (p.kind[i] == mps::Kind::fluid && p.surface[i])
                  scratch.p[i] = p.held_value[i] + (p.offset.empty() ? 0.0 : p.offset[i]);
            return to_numpy(scratch.p);
          },
          py::arg("x"), py::arg("clamp_negative") = false,
          "Particle pressures from a solution x, as the step scatters them: closed groups shifted to zero mean,\n"
          "the offset added back, held particles at their value, other non-unknowns and dummies 0.")
      .def("__repr__", [](const Ppe& p) {
        return "Ppe(" + std::to_string(p.system.size()) + " unknowns, " + std::to_string(p.system.matrix.nnz()) +
               " nonzeros, " + std::to_string(p.system.floating.size()) + " floating groups)";
      });

  m.def(
      "assemble_ppe",
      [](const mps::Particles& particles, double dt, py::handle domain, py::handle config, double asymmetry,
         bool wet_walls, const py::kwargs& fields) {
        return assemble(particles, dt, domain, config_of(config, fields), asymmetry, wet_walls);
      },
      py::arg("particles"), py::kw_only(), py::arg("dt"), py::arg("domain") = py::none(),
      py::arg("config") = py::none(), py::arg("asymmetry") = 0.0, py::arg("wet_walls") = false, assemble_doc);
  m.def(
      "assemble_ppe",
      [](py::handle x, py::handle y, py::handle u, py::handle v, py::handle kind, double dt, py::handle domain,
         py::handle config, double asymmetry, bool wet_walls, const py::kwargs& fields) {
        return assemble(particles_from_arrays(x, y, u, v, kind), dt, domain, config_of(config, fields), asymmetry,
                        wet_walls);
      },
      py::arg("x"), py::arg("y"), py::arg("u"), py::arg("v"), py::arg("kind"), py::kw_only(), py::arg("dt"),
      py::arg("domain") = py::none(), py::arg("config") = py::none(), py::arg("asymmetry") = 0.0,
      py::arg("wet_walls") = false,
      "Same, from arrays: positions x, y (r*), velocities u, v (u*) and kind (0 fluid, 1 wall, 2 dummy, 3 ghost).");

  m.def(
      "write_vtp",
      [](const std::string& path, const mps::Particles& particles, const py::dict& fields, double time,
         const py::dict& vectors) {
        const auto n = static_cast<py::ssize_t>(particles.size());
        std::deque<std::vector<double>> columns;  // the arrays the spans of `extra` view (a deque never moves them)
        mps::PointFields extra;
        for (const auto& [key, values] : fields) {
          const std::string name = py::str(key).cast<std::string>();
          extra.scalars[name] = columns.emplace_back(to_doubles(values, name, n));
        }
        for (const auto& [key, pair] : vectors) {
          const std::string name = py::str(key).cast<std::string>();
          const auto xy = pair.cast<py::sequence>();
          if (xy.size() != 2) throw py::value_error("vector " + name + " must be a pair (x, y) of arrays");
          extra.vectors[name] = {columns.emplace_back(to_doubles(xy[0], name + " x", n)),
                                 columns.emplace_back(to_doubles(xy[1], name + " y", n))};
        }
        mps::write_vtp(path, particles, time, extra);
      },
      py::arg("path"), py::arg("particles"), py::arg("fields") = py::dict(), py::kw_only(), py::arg("time"),
      py::arg("vectors") = py::dict(),
      "Writes a ParaView frame (VTK PolyData, binary and zlib-compressed, as the apps' frames) at simulation time\n"
      "`time` (its field array TIME): position, velocity, pressure, kind, group, id, the per-particle arrays of\n"
      "`fields` ({name: array}) and the vectors of `vectors` ({name: (x, y)}), written with 3 components.");

  py::class_<Simulation>(m, "Simulation",
                         "The MPS time loop (mps::Simulation) on a copy of the particles. Steps run without the GIL.")
      .def(py::init([](const mps::Particles& p, py::handle domain, py::handle config, const py::kwargs& fields) {
             return std::make_unique<Simulation>(p, domain_of(domain), config_of(config, fields));
           }),
           py::arg("particles"), py::arg("domain"), py::arg("config") = py::none(),
           "particles: Particles. domain: Domain or (xmin, xmax, ymin, ymax). config: SimulationConfig or dict;\n"
           "keyword fields override it. Raises ValueError for a bad configuration, particles outside the domain, a\n"
           "NaN or Inf velocity or pressure, or two particles at one position.")
      .def("step", &Simulation::step,
           "Advances one step; returns its StepInfo. Raises SimulationError (the state kept as before the step) if\n"
           "the stability guard trips or the solve fails.")
      .def(
          "run",
          [](Simulation& s, std::optional<double> end_time, std::optional<long long> steps) {
            check_run(s, end_time, steps);
            for (long long done = 0;; ++done) {
              if (end_time && s.sim->time() >= *end_time - 1e-12) break;
              if (steps && done >= *steps) break;
              s.step();
              if (PyErr_CheckSignals() != 0) throw py::error_already_set();  // Ctrl-C between steps
            }
            return s.sim->last_step();
          },
          py::arg("end_time") = py::none(), py::arg("steps") = py::none(),
          "Steps until time >= end_time and/or `steps` steps are done; returns the last StepInfo.\n"
          "Raises ValueError for an end_time that is not finite or not beyond the current time, steps below 1, or\n"
          "a run of more than 1e8 steps.")
      .def(
          "add_particle_collision",
          [](Simulation& s, double distance, double restitution) {
            s.locked([&] { add_particle_collision(*s.sim, distance, restitution); });
          },
          py::arg("distance") = 0.8, py::arg("restitution") = 0.2,
          "Close pairs collide after the predictor (mps::ParticleCollision): fluid particles nearer than distance l0\n"
          "that approach lose their approach speed down to restitution of it (the dam break's default).")
      .def(
          "add_asymmetry_surface",
          [](Simulation& s, double fraction) { s.locked([&] { add_asymmetry_surface(*s.sim, fraction); }); },
          py::arg("fraction") = 0.9,
          "Fluid whose neighbours lie one-sided (above fraction of a flat surface's asymmetry) is free surface too\n"
          "(mps::AsymmetrySurface): the toe of a surge, a thin jet.")
      .def(
          "add_wet_walls", [](Simulation& s) { s.locked([&] { s.sim->add<mps::WetWalls>(); }); },
          "Wall particles next to fluid that is not free surface stay PPE unknowns (mps::WetWalls).")
      .def_property_readonly("time", [](const Simulation& s) { return s.locked([&] { return s.sim->time(); }); })
      .def_property_readonly("steps", [](const Simulation& s) { return s.locked([&] { return s.sim->last_step().step; }); }, "steps completed")
      .def_property_readonly("last_step", [](const Simulation& s) { return s.locked([&] { return s.sim->last_step(); }); })
      .def_property_readonly(
          "particles",
          [](Simulation& s) {
            const std::lock_guard<std::mutex> lock(s.mutex);
            return s.sim->particles();
          },
          "a copy of the particles (reordered by cell every reorder_every steps: id follows each one)")
      .def_property_readonly(
          "last_ppe",
          [](Simulation& s) {
            const std::lock_guard<std::mutex> lock(s.mutex);
            Ppe out = *s.recorded;
            out.system = s.sim->last_ppe();
            return out;
          },
          "the PPE of the last step (a copy)")
      .def_property_readonly("solver_spec", [](const Simulation& s) { return s.sim->solver().spec(); })
      .def_property_readonly("config", [](const Simulation& s) { return s.sim->config(); }, "a copy")
      .def_property_readonly("domain", [](const Simulation& s) { return s.sim->domain(); })
      .def_property_readonly(
          "phase_times",
          [](const Simulation& s) {
            const mps::PhaseTimes& t = s.sim->times();
            return py::dict(py::arg("neighbors") = t.neighbors, py::arg("predict") = t.predict,
                            py::arg("assemble") = t.assemble, py::arg("solver_setup") = t.solver_setup,
                            py::arg("solve") = t.solve, py::arg("correct") = t.correct, py::arg("total") = t.total());
          },
          "wall-clock seconds per phase, summed over the steps");
}

}  // namespace sparsemps
