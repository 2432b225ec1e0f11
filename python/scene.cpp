// Particles, domain, configuration, the time loop and PPE assembly from particle arrays.
#include <pybind11/stl.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <regex>
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

// Names from 'a|b,c' or a list of names.
std::vector<std::string> words_of(py::handle obj) {
  std::vector<std::string> names;
  if (py::isinstance<py::str>(obj)) {
    std::string text = obj.cast<std::string>();
    std::replace_if(text.begin(), text.end(), [](char c) { return c == '|' || c == ','; }, ' ');
    std::istringstream words(text);
    for (std::string w; words >> w;) names.push_back(w);
  } else {
    for (py::handle item : obj) names.push_back(py::str(item).cast<std::string>());
  }
  return names;
}

unsigned sides_of(py::handle obj) {
  unsigned sides = 0;
  for (const std::string& name : words_of(obj)) {
    if (name == "left") sides |= mps::left;
    else if (name == "right") sides |= mps::right;
    else if (name == "bottom") sides |= mps::bottom;
    else if (name == "top") sides |= mps::top;
    else throw py::value_error("unknown side '" + name + "'; valid: left, right, bottom, top");
  }
  return sides;
}

std::string type_name(py::handle obj) { return py::str(py::type::of(obj).attr("__name__")).cast<std::string>(); }

// `count` numbers from a tuple or list; `what` and `form` name it in the messages.
std::vector<double> numbers(py::handle obj, std::size_t count, const std::string& what, const std::string& form) {
  std::vector<double> v;
  try {
    v = obj.cast<std::vector<double>>();
  } catch (const py::cast_error&) {
    throw py::type_error(what + " must be " + form + ", got " + type_name(obj));
  }
  if (v.size() != count)
    throw py::value_error(what + " must be " + form + ", got " + std::to_string(v.size()) + " numbers");
  return v;
}

mps::Rect rect_of(py::handle obj, const char* what) {
  const std::vector<double> v = numbers(obj, 4, what, "(x0, y0, x1, y1)");
  for (const double c : v)
    if (!std::isfinite(c)) throw py::value_error(std::string(what) + " holds " + repr(c) + "; give finite coordinates");
  return {v[0], v[1], v[2], v[3]};
}

mps::Box box_of(py::handle obj, const char* what) {
  const std::vector<double> v = numbers(obj, 6, what, "(x0, y0, z0, x1, y1, z1)");
  for (const double c : v)
    if (!std::isfinite(c)) throw py::value_error(std::string(what) + " holds " + repr(c) + "; give finite coordinates");
  return {v[0], v[1], v[2], v[3], v[4], v[5]};
}

// A wall backstop's box: (x0, y0, x1, y1) in 2-D, (x0, y0, z0, x1, y1, z1) in 3-D, each lower corner below its upper.
template <int D>
typename mps::BasicWallBackstop<D>::AxisBox axis_box_of(py::handle obj, const char* what) {
  typename mps::BasicWallBackstop<D>::AxisBox b;
  if constexpr (D == 2) {
    const mps::Rect r = rect_of(obj, what);
    b = {{r.x0, r.y0}, {r.x1, r.y1}};
  } else {
    const mps::Box r = box_of(obj, what);
    b = {{r.x0, r.y0, r.z0}, {r.x1, r.y1, r.z1}};
  }
  for (std::size_t a = 0; a < D; ++a)
    if (!(b.lo[a] < b.hi[a])) throw py::value_error(std::string(what) + ": each lower corner must lie below its upper");
  return b;
}

unsigned faces_of(py::handle obj) {
  static const std::map<std::string, unsigned> names{{"x_low", mps::x_low}, {"x_high", mps::x_high},
                                                     {"y_low", mps::y_low}, {"y_high", mps::y_high},
                                                     {"z_low", mps::z_low}, {"z_high", mps::z_high}};
  unsigned faces = 0;
  for (const std::string& name : words_of(obj)) {
    const auto it = names.find(name);
    if (it == names.end())
      throw py::value_error("unknown face '" + name + "'; valid: x_low, x_high, y_low, y_high, z_low, z_high");
    faces |= it->second;
  }
  return faces;
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

// The particles' own field list (BasicParticles::for_each_field) as properties: a NumPy copy out, a checked copy in
// (doubles finite, kinds 0-3 or one name for all); id is read-only. A field added to the list appears here by itself.
const char* field_doc(std::string_view name) {
  if (name.size() == 1 && std::string_view("xyz").find(name[0]) != std::string_view::npos) return "position [m]";
  if (name.size() == 1 && std::string_view("uvw").find(name[0]) != std::string_view::npos) return "velocity [m/s]";
  if (name == "p") return "pressure [Pa]";
  if (name == "kind") return "uint8 array: 0 fluid, 1 wall, 2 dummy, 3 ghost";
  if (name == "group") return "user tag, e.g. which wall moves with which motion";
  if (name == "id") return "index at creation: follows the particle through reorderings";
  return "per-particle array";
}

template <class T>
py::object field_to_python(const std::vector<T>& v) {
  if constexpr (std::is_same_v<T, mps::Kind>) return kinds_to_numpy(v);
  else return to_numpy(v);
}

template <class T>
void field_from_python(std::vector<T>& field, py::handle values, const char* name, std::size_t n) {
  if constexpr (std::is_same_v<T, double>) field = to_finite_doubles(values, name, static_cast<py::ssize_t>(n));
  else if constexpr (std::is_same_v<T, mps::Kind>) field = kinds_of(values, n);
  else field = to_ints(values, name, static_cast<py::ssize_t>(n));
}

// An (N, D) array of finite numbers as D columns; n >= 0 demands N = n.
template <int D>
std::array<std::vector<double>, D> columns_of(py::handle obj, const std::string& what, py::ssize_t n = -1) {
  if (!py::isinstance<py::array>(obj) && !py::isinstance<py::sequence>(obj))
    throw py::type_error(what + " must be an array of shape (N, " + std::to_string(D) + "), got " + type_name(obj));
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
  if (!a || a.ndim() != 2 || a.shape(1) != D || (n >= 0 && a.shape(0) != n)) {
    std::string shape = "(";
    for (py::ssize_t k = 0; a && k < a.ndim(); ++k) shape += (k ? ", " : "") + std::to_string(a.shape(k));
    throw py::value_error(what + " must have shape (" + (n >= 0 ? std::to_string(n) : std::string("N")) + ", " +
                          std::to_string(D) + "), got " + (a ? shape + (a.ndim() == 1 ? ",)" : ")") : "no array"));
  }
  std::array<std::vector<double>, D> out;
  const auto v = a.template unchecked<2>();
  for (std::size_t d = 0; d < D; ++d) {
    out[d].resize(static_cast<std::size_t>(a.shape(0)));
    for (py::ssize_t i = 0; i < a.shape(0); ++i) {
      const double value = v(i, static_cast<py::ssize_t>(d));
      if (!std::isfinite(value))
        throw py::value_error(what + "[" + std::to_string(i) + ", " + std::to_string(d) + "] is " + repr(value) +
                              ": every entry must be a finite number");
      out[d][static_cast<std::size_t>(i)] = value;
    }
  }
  return out;
}

template <int D, class Columns>
py::array_t<double> rows_of(const Columns& columns, std::size_t n) {
  py::array_t<double> out({static_cast<py::ssize_t>(n), static_cast<py::ssize_t>(D)});
  auto a = out.template mutable_unchecked<2>();
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t d = 0; d < D; ++d) a(static_cast<py::ssize_t>(i), static_cast<py::ssize_t>(d)) = (*columns[d])[i];
  return out;
}

template <int D>
void def_fields(py::class_<mps::BasicParticles<D>>& c) {
  using P = mps::BasicParticles<D>;
  P().for_each_field([&c]<class T>(const char* name, const std::vector<T>&) {
    auto get = [name](const P& p) {
      py::object out;
      p.for_each_field([&]<class U>(const char* n, const std::vector<U>& v) {
        if (std::string_view(n) == name) out = field_to_python(v);
      });
      return out;
    };
    if (std::string_view(name) == "id") {
      c.def_property_readonly(name, get, field_doc(name));
      return;
    }
    c.def_property(
        name, get,
        [name](P& p, Typed<ArrayLike> values) {
          const std::size_t n = p.size();
          p.for_each_field([&]<class U>(const char* f, std::vector<U>& v) {
            if (std::string_view(f) == name) field_from_python(v, values, name, n);
          });
        },
        field_doc(name));
  });
  // positions and velocities as (N, D) arrays; `of` gives a particles' D component vectors.
  auto def_rows = [&c](const char* name, auto of, const char* unit) {
    c.def_property(
        name, [of](const P& p) { return rows_of<D>(of(p), p.size()); },
        [of, name](P& p, Typed<ArrayLike> values) {
          auto columns = columns_of<D>(values, name, static_cast<py::ssize_t>(p.size()));
          for (std::size_t d = 0; d < D; ++d) *of(p)[d] = std::move(columns[d]);
        },
        (std::string(name) + " as an array of shape (N, " + std::to_string(D) + ") [" + unit +
         "] (a copy; assigning one sets them all)")
            .c_str());
  };
  def_rows("positions", [](auto& p) { return p.positions(); }, "m");
  def_rows("velocities", [](auto& p) { return p.velocities(); }, "m/s");
  c.def("__len__", &P::size);
  c.def("count", [](const P& p, Typed<KindLike> kind) { return p.count(kind_of(kind)); }, py::arg("kind"),
        "How many particles are of this kind.");
  c.def("__repr__", [](const P& p) {
    return std::string(D == 2 ? "Particles(" : "Particles3(") + std::to_string(p.size()) + ": " +
           std::to_string(p.count(mps::Kind::fluid)) + " fluid, " + std::to_string(p.count(mps::Kind::wall)) +
           " wall, " + std::to_string(p.count(mps::Kind::dummy)) + " dummy, " +
           std::to_string(p.count(mps::Kind::ghost)) + " ghost)";
  });
}

template <int D = 2>
mps::BasicDomain<D> domain_of(py::handle obj) {
  if (py::isinstance<mps::BasicDomain<D>>(obj)) return obj.cast<mps::BasicDomain<D>>();
  mps::BasicDomain<D> d;
  if constexpr (D == 2) {
    const std::vector<double> v =
        numbers(obj, 4, "the domain", "a sparsemps.Domain or a 4-tuple (xmin, xmax, ymin, ymax)");
    d = {v[0], v[1], v[2], v[3]};
  } else {
    const std::vector<double> v =
        numbers(obj, 6, "the domain", "a sparsemps.Domain3 or a 6-tuple (xmin, xmax, ymin, ymax, zmin, zmax)");
    d = {v[0], v[1], v[2], v[3], v[4], v[5]};
  }
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
template <int D>
class Recorder : public mps::BasicStepComponent<D> {
 public:
  explicit Recorder(std::shared_ptr<Ppe> out) : out_(std::move(out)) {}
  void before_assembly(mps::BasicStepContext<D>& c) override {
    const mps::BasicStepFields<D>& f = c.fields;
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
class Injector final : public Recorder<2> {
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
template <int D>
void add_asymmetry_surface(mps::BasicSimulation<D>& sim, double fraction, double interior_density = 0.0) {
  if (!(fraction > 0.0 && fraction <= 10.0))
    throw py::value_error("asymmetry fraction must be in (0, 10], got " + std::to_string(fraction));
  if (!(interior_density >= 0.0 && interior_density <= 10.0))
    throw py::value_error("interior_density must be in [0, 10] n0 (0: no limit), got " + std::to_string(interior_density));
  sim.template add<mps::BasicAsymmetrySurface<D>>(fraction, interior_density);
}

template <int D>
void add_particle_collision(mps::BasicSimulation<D>& sim, double distance, double restitution) {
  if (!(distance > 0.0 && distance < 1.0))
    throw py::value_error("collision distance must be in (0, 1) l0, got " + std::to_string(distance));
  if (!(restitution >= 0.0 && restitution <= 1.0))
    throw py::value_error("restitution must be in [0, 1], got " + std::to_string(restitution));
  sim.template add<mps::BasicParticleCollision<D>>(distance, restitution);
}

// ---------------------------------------------------------------------------------------------------------------
// The simulation, with a lock so that a step running without the GIL is never overlapped by another call.

template <int D>
struct Simulation {
  std::unique_ptr<mps::BasicSimulation<D>> sim;
  std::shared_ptr<Ppe> recorded = std::make_shared<Ppe>();
  mutable std::mutex mutex;

  // The recorder goes first among the scene's components: those offered here do not hook before_assembly, so it
  // still sees every field as the assembly does.
  Simulation(const mps::BasicParticles<D>& particles, const mps::BasicDomain<D>& domain, const Config& config)
      : sim(std::make_unique<mps::BasicSimulation<D>>(particles, domain, config)) {
    sim->template add<Recorder<D>>(recorded);
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
template <int D>
void check_run(const Simulation<D>& s, std::optional<double> end_time, std::optional<long long> steps) {
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
    const double margin = config.l0 * (2.0 + config.largest_radius());
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

template <int D>
void bind_simulation(py::module_& m) {
  py::class_<Simulation<D>>(m, D == 2 ? "Simulation" : "Simulation3",
                            D == 2 ? "The 2-D MPS time loop (mps::Simulation) on a copy of the particles. Steps run without "
                                     "the GIL."
                                   : "The 3-D MPS time loop (mps::Simulation3) on a copy of the particles. Steps run without "
                                     "the GIL.")
      .def(py::init([](const mps::BasicParticles<D>& p, Typed<std::conditional_t<D == 2, DomainLike, Domain3Like>> domain,
                       Typed<ConfigLike> config, const py::kwargs& fields) {
             return std::make_unique<Simulation<D>>(p, domain_of<D>(domain), config_of(config, fields));
           }),
           py::arg("particles"), py::arg("domain"), py::arg("config") = py::none(),
           D == 2 ? "particles: Particles. domain: Domain or (xmin, xmax, ymin, ymax). config: SimulationConfig or dict;\n"
                   "keyword fields override it. Raises ValueError for a bad configuration, particles outside the domain, a\n"
                   "NaN or Inf velocity or pressure, or two particles at one position."
                 : "particles: Particles3. domain: Domain3 or (xmin, xmax, ymin, ymax, zmin, zmax). config:\n"
                   "SimulationConfig or dict; keyword fields override it. Raises ValueError as Simulation does.")
      .def("step", &Simulation<D>::step,
           "Advances one step; returns its StepInfo. Raises SimulationError (the state kept as before the step) if\n"
           "the stability guard trips or the solve fails.")
      .def(
          "run",
          [](Simulation<D>& s, std::optional<double> end_time, std::optional<long long> steps) {
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
          [](Simulation<D>& s, double distance, double restitution) {
            s.locked([&] { add_particle_collision(*s.sim, distance, restitution); });
          },
          py::arg("distance") = 0.8, py::arg("restitution") = 0.2,
          "Close pairs collide after the predictor (mps::ParticleCollision): fluid particles nearer than distance l0\n"
          "that approach lose their approach speed down to restitution of it (the dam break's default).")
      .def(
          "add_asymmetry_surface",
          [](Simulation<D>& s, double fraction, double interior_density) {
            s.locked([&] { add_asymmetry_surface(*s.sim, fraction, interior_density); });
          },
          py::arg("fraction") = 0.9, py::arg("interior_density") = 0.0,
          "Fluid whose neighbours lie one-sided (above fraction of a flat surface's asymmetry) is free surface too\n"
          "(mps::AsymmetrySurface): the toe of a surge, a thin jet; but not fluid at or above interior_density n0\n"
          "(0: no limit; the 3-D dam break's 1 keeps fluid pressed onto a wall out of the free surface).")
      .def(
          "add_wall_backstop",
          [](Simulation<D>& s, Typed<AxisBoxLike> tank, const py::list& obstacles, double slack) {
            const auto box = axis_box_of<D>(tank, "the tank");
            std::vector<typename mps::BasicWallBackstop<D>::AxisBox> inside;
            for (py::handle o : obstacles) inside.push_back(axis_box_of<D>(o, "an obstacle"));
            s.locked([&] { s.sim->template add<mps::BasicWallBackstop<D>>(box, std::move(inside), slack); });
          },
          py::arg("tank"), py::arg("obstacles") = py::list(), py::arg("slack") = 0.0,
          "Fluid that goes more than slack [m] past a face of the tank (below its top) or of an obstacle is put back\n"
          "on the face and loses its velocity into the wall (mps::WallBackstop): a backstop for 3-D wall lattices,\n"
          "whose holes let pressed fluid through, and for a 2-D corner hit by a surge (the 2-D columns take l0/2).\n"
          "tank and each obstacle: (x0, y0, x1, y1) in 2-D, (x0, y0, z0, x1, y1, z1) in 3-D.")
      .def(
          "add_wet_walls", [](Simulation<D>& s) { s.locked([&] { s.sim->template add<mps::BasicWetWalls<D>>(); }); },
          "Wall particles next to fluid that is not free surface stay PPE unknowns (mps::WetWalls).")
      .def_property_readonly(
          "time", [](const Simulation<D>& s) { return s.locked([&] { return s.sim->time(); }); }, "simulation time [s]")
      .def_property_readonly("steps", [](const Simulation<D>& s) { return s.locked([&] { return s.sim->last_step().step; }); }, "steps completed")
      .def_property_readonly(
          "last_step", [](const Simulation<D>& s) { return s.locked([&] { return s.sim->last_step(); }); },
          "the last step's StepInfo")
      .def_property(
          "particles",
          [](Simulation<D>& s) {
            const std::lock_guard<std::mutex> lock(s.mutex);
            return s.sim->particles();
          },
          [](Simulation<D>& s, mps::BasicParticles<D> particles) {
            const std::lock_guard<std::mutex> lock(s.mutex);
            s.sim->set_particles(std::move(particles));
          },
          "a copy of the particles (reordered by cell every reorder_every steps: id follows each one). Assign an\n"
          "edited copy to push it back: the same particles in the same order, with new positions, velocities,\n"
          "pressures, kinds or groups (mps::Simulation::set_particles; ValueError for another count or order, a\n"
          "non-finite value or a particle outside the domain).")
      .def_property_readonly(
          "last_ppe",
          [](Simulation<D>& s) {
            const std::lock_guard<std::mutex> lock(s.mutex);
            Ppe out = *s.recorded;
            out.system = s.sim->last_ppe();
            return out;
          },
          "the PPE of the last step (a copy)")
      .def_property_readonly(
          "solver_spec", [](const Simulation<D>& s) { return s.sim->solver().spec(); },
          "the pressure solver's spec, every key spelled out")
      .def_property_readonly("config", [](const Simulation<D>& s) { return s.sim->config(); }, "a copy")
      .def_property_readonly(
          "domain", [](const Simulation<D>& s) { return s.sim->domain(); }, "the domain (a copy)")
      .def_property_readonly(
          "phase_times",
          [](const Simulation<D>& s) {
            const mps::PhaseTimes& t = s.sim->times();
            return py::dict(py::arg("neighbors") = t.neighbors, py::arg("predict") = t.predict,
                            py::arg("assemble") = t.assemble, py::arg("solver_setup") = t.solver_setup,
                            py::arg("solve") = t.solve, py::arg("correct") = t.correct, py::arg("total") = t.total());
          },
          "wall-clock seconds per phase, summed over the steps");
}

// write_vtp(path, particles, fields, time=, vectors=) for D-dimensional particles.
template <int D>
void def_write_vtp(py::module_& m) {
  m.def(
      "write_vtp",
      [](const std::string& path, const mps::BasicParticles<D>& particles, const py::dict& fields, double time,
         const py::dict& vectors) {
        const auto n = static_cast<py::ssize_t>(particles.size());
        std::deque<std::vector<double>> columns;  // the arrays the spans of `extra` view (a deque never moves them)
        mps::BasicPointFields<D> extra;
        for (const auto& [key, values] : fields) {
          const std::string name = py::str(key).cast<std::string>();
          extra.scalars[name] = columns.emplace_back(to_doubles(values, name, n));
        }
        static constexpr const char* axes[3] = {" x", " y", " z"};
        for (const auto& [key, tuple] : vectors) {
          const std::string name = py::str(key).cast<std::string>();
          const auto components = tuple.template cast<py::sequence>();
          if (components.size() != D)
            throw py::value_error("vector " + name + (D == 2 ? " must be a pair (x, y) of arrays"
                                                             : " must be a triple (x, y, z) of arrays"));
          for (std::size_t d = 0; d < D; ++d)
            extra.vectors[name][d] = columns.emplace_back(to_doubles(components[d], name + axes[d], n));
        }
        mps::write_vtp(path, particles, time, extra);
      },
      py::arg("path"), py::arg("particles"), py::arg("fields") = py::dict(), py::kw_only(), py::arg("time"),
      py::arg("vectors") = py::dict(),
      "Writes a ParaView frame (VTK PolyData, binary and zlib-compressed, as the apps' frames) at simulation time\n"
      "`time` (its field array TIME): position, velocity, pressure, kind, group, id, the per-particle arrays of\n"
      "`fields` ({name: array}) and the vectors of `vectors` ({name: (x, y)}, or (x, y, z) for Particles3), written\n"
      "with 3 components.");
}

// Frames, their series and particle files, read back (mps/io/io.hpp), and particle files written.
void bind_readers(py::module_& m) {
  auto check_dim = [](int dim) {
    if (dim != 2 && dim != 3) throw py::value_error("dim must be 2 or 3, got " + std::to_string(dim));
  };
  auto is_frame = [](const std::string& path) { return path.size() >= 4 && path.substr(path.size() - 4) == ".vtp"; };
  m.def(
      "read_particles",
      [=](const std::string& path, int dim) -> Typed<EitherParticles> {
        check_dim(dim);
        if (dim == 2) return {py::cast(is_frame(path) ? mps::read_vtp<2>(path) : mps::read_particles_csv<2>(path))};
        return {py::cast(is_frame(path) ? mps::read_vtp<3>(path) : mps::read_particles_csv<3>(path))};
      },
      py::arg("path"), py::arg("dim") = 2,
      "Particles (dim 2) or Particles3 (dim 3) from a particle file (CSV: x, y[, z], kind and optionally u, v[, w], p,\n"
      "group; docs/particle-files.md) or an app's .vtp frame, in the file's order, bit for bit. RuntimeError naming\n"
      "the file, the line and what to change for a malformed file.");
  m.def(
      "read_frame",
      [=](const std::string& path, int dim) -> py::tuple {
        check_dim(dim);
        double time = 0.0;
        if (dim == 2) {
          mps::Particles particles = mps::read_vtp<2>(path, &time);
          return py::make_tuple(std::move(particles), time);
        }
        mps::Particles3 particles = mps::read_vtp<3>(path, &time);
        return py::make_tuple(std::move(particles), time);
      },
      py::arg("path"), py::arg("dim") = 2,
      "(particles, time) of an app's or write_vtp's .vtp frame: Particles or Particles3 and the frame's simulation\n"
      "time [s] (its TIME array; nan for a frame without one).");
  m.def(
      "read_series",
      [](const std::string& path) {
        std::ifstream in(path);
        if (!in) throw std::runtime_error("cannot read the series " + path);
        const std::filesystem::path folder = std::filesystem::path(path).parent_path();
        static const std::regex dataset(R"re(<DataSet\s[^>]*timestep="([^"]*)"[^>]*file="([^"]*)")re");
        std::vector<std::pair<double, std::string>> frames;
        std::string line;
        for (int number = 1; std::getline(in, line); ++number) {
          std::smatch found;
          if (!std::regex_search(line, found, dataset)) continue;
          const std::string text = found[1].str();
          char* end = nullptr;
          const double t = std::strtod(text.c_str(), &end);
          if (end == text.c_str() || !std::isfinite(t))
            throw std::runtime_error(path + ":" + std::to_string(number) + ": timestep '" + text +
                                     "' is no finite number");
          frames.emplace_back(t, (folder / found[2].str()).lexically_normal().string());
        }
        return frames;
      },
      py::arg("path"),
      "[(time, frame path), ...] of a .pvd series as the apps write it (dambreak.pvd, ...), the paths made from the\n"
      "series' folder; read each frame with read_frame (the .pvd's times have 6 digits, the frame's TIME all 17).");
  m.def(
      "write_particles_csv",
      [](const std::string& path, const mps::Particles& particles, const std::vector<std::string>& comments) {
        mps::write_particles_csv(path, particles, comments);
      },
      py::arg("path"), py::arg("particles"), py::arg("comments") = std::vector<std::string>{},
        "Writes the particles as read_particles reads them (17 significant digits: every bit comes back), each\n"
        "comment as a '# ' line first.");
  m.def(
      "write_particles_csv",
      [](const std::string& path, const mps::Particles3& particles, const std::vector<std::string>& comments) {
        mps::write_particles_csv(path, particles, comments);
      },
      py::arg("path"), py::arg("particles"), py::arg("comments") = std::vector<std::string>{}, "The same for Particles3.");
}

// The 3-D scene: Particles3 (positions and velocities as (N, 3) arrays, and the field list), Domain3, Simulation3.
void bind_dimension3(py::module_& m) {
  py::class_<mps::Domain3>(m, "Domain3", "A 3-D domain; a periodic axis wraps positions (mps::Domain3).")
      .def(py::init([](double xmin, double xmax, double ymin, double ymax, double zmin, double zmax, bool px, bool py_,
                       bool pz) {
             mps::Domain3 d{xmin, xmax, ymin, ymax, zmin, zmax, px, py_, pz};
             d.validate();
             return d;
           }),
           py::arg("xmin"), py::arg("xmax"), py::arg("ymin"), py::arg("ymax"), py::arg("zmin"), py::arg("zmax"),
           py::arg("periodic_x") = false, py::arg("periodic_y") = false, py::arg("periodic_z") = false)
      .def_readwrite("xmin", &mps::Domain3::xmin, "lower bound along x [m]")
      .def_readwrite("xmax", &mps::Domain3::xmax, "upper bound along x [m]")
      .def_readwrite("ymin", &mps::Domain3::ymin, "lower bound along y [m]")
      .def_readwrite("ymax", &mps::Domain3::ymax, "upper bound along y [m]")
      .def_readwrite("zmin", &mps::Domain3::zmin, "lower bound along z [m]")
      .def_readwrite("zmax", &mps::Domain3::zmax, "upper bound along z [m]")
      .def_readwrite("periodic_x", &mps::Domain3::periodic_x, "whether x wraps around")
      .def_readwrite("periodic_y", &mps::Domain3::periodic_y, "whether y wraps around")
      .def_readwrite("periodic_z", &mps::Domain3::periodic_z, "whether z wraps around")
      .def("contains", [](const mps::Domain3& d, double x, double y, double z) { return d.contains({x, y, z}); },
           py::arg("x"), py::arg("y"), py::arg("z"))
      .def("__repr__", [](const mps::Domain3& d) {
        std::ostringstream s;
        s.precision(17);
        auto flag = [](bool b) { return b ? "True" : "False"; };
        s << "Domain3(" << d.xmin << ", " << d.xmax << ", " << d.ymin << ", " << d.ymax << ", " << d.zmin << ", "
          << d.zmax << ", periodic_x=" << flag(d.periodic_x) << ", periodic_y=" << flag(d.periodic_y)
          << ", periodic_z=" << flag(d.periodic_z) << ")";
        return s.str();
      });

  py::class_<mps::Particles3> particles(
      m, "Particles3",
      "3-D particle state as arrays (mps::Particles3): x, y, z, u, v, w, p, kind, group, id (the library's field\n"
      "list), and positions, velocities of shape (N, 3). Reading gives a NumPy copy; assigning takes an array of the\n"
      "same length (positions, velocities and pressures finite).");
  particles
      .def(py::init([](Typed<OptionalArray> positions, Typed<OptionalArray> kind, Typed<OptionalArray> velocities,
                       Typed<OptionalArray> p, Typed<OptionalArray> group) {
             mps::Particles3 out;
             if (positions.is_none()) {
               if (!kind.is_none() || !velocities.is_none() || !p.is_none() || !group.is_none())
                 throw py::value_error("Particles3(positions, kind, ...): positions are required with other arrays");
               return out;
             }
             if (kind.is_none()) throw py::value_error("Particles3(positions, kind): kind is required with positions");
             const auto r = columns_of<3>(positions, "positions");
             const std::size_t n = r[0].size();
             const std::vector<mps::Kind> kinds = kinds_of(kind, n);
             out.reserve(n);
             for (std::size_t i = 0; i < n; ++i) out.add({r[0][i], r[1][i], r[2][i]}, kinds[i]);
             if (!velocities.is_none()) {
               auto vel = columns_of<3>(velocities, "velocities", static_cast<py::ssize_t>(n));
               for (std::size_t d = 0; d < 3; ++d) *out.velocities()[d] = std::move(vel[d]);
             }
             if (!p.is_none()) out.p = to_finite_doubles(p, "p", static_cast<py::ssize_t>(n));
             if (!group.is_none()) out.group = to_ints(group, "group", static_cast<py::ssize_t>(n));
             return out;
           }),
           py::arg("positions") = py::none(), py::arg("kind") = py::none(), py::arg("velocities") = py::none(),
           py::arg("p") = py::none(), py::arg("group") = py::none(),
           "Empty, or from arrays: positions (N, 3) and kind (an array of 0-3, or one Kind / name for all);\n"
           "velocities (N, 3), p and group default to 0.")
      .def(
          "fill_box",
          [](mps::Particles3& p, Typed<BoxLike> box_in, double l0, Typed<KindLike> kind, int group) -> mps::Particles3& {
            const mps::Box box = box_of(box_in, "box");
            if (l0 > 0.0 && std::isfinite(l0))  // else the library names l0
              check_particle_count(cells(box.x1 - box.x0, l0) * cells(box.y1 - box.y0, l0) * cells(box.z1 - box.z0, l0),
                                   p.size(), "fill_box");
            mps::fill_box(p, box, l0, kind_of(kind), group);
            return p;
          },
          py::arg("box"), py::arg("l0"), py::arg("kind") = "fluid", py::arg("group") = 0,
          py::return_value_policy::reference_internal,
          "Adds a cubic lattice of spacing l0 filling box = (x0, y0, z0, x1, y1, z1), points at cell centres;\n"
          "returns self.")
      .def(
          "add_box_walls",
          [](mps::Particles3& p, Typed<BoxLike> inner, double l0, Typed<SidesLike> faces, int wall_layers, int dummy_layers,
             int group) -> mps::Particles3& {
            const mps::Box box = box_of(inner, "inner");
            if (l0 > 0.0 && std::isfinite(l0) && wall_layers >= 0 && dummy_layers >= 0) {  // else the library says why
              const double layers = 2.0 * (static_cast<double>(wall_layers) + dummy_layers);
              const double nx = cells(box.x1 - box.x0, l0), ny = cells(box.y1 - box.y0, l0),
                           nz = cells(box.z1 - box.z0, l0);
              check_particle_count((nx + layers) * (ny + layers) * (nz + layers) - nx * ny * nz, p.size(),
                                   "add_box_walls");
            }
            mps::add_box_walls(p, box, l0, faces_of(faces), wall_layers, dummy_layers, group);
            return p;
          },
          py::arg("inner"), py::arg("l0"), py::arg("faces") = "x_low|x_high|y_low|y_high|z_low",
          py::arg("wall_layers") = 1, py::arg("dummy_layers") = 4, py::arg("group") = 0,
          py::return_value_policy::reference_internal,
          "Adds wall_layers of wall and dummy_layers of dummy particles outside inner = (x0, y0, z0, x1, y1, z1) on\n"
          "the given faces ('x_low|x_high|y_low|y_high|z_low', a tank open at the top, or a list of names; edges and\n"
          "corners between walled faces included); returns self.");
  def_fields(particles);
  bind_simulation<3>(m);
}

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
      .def_readwrite("xmin", &mps::Domain::xmin, "lower bound along x [m]")
      .def_readwrite("xmax", &mps::Domain::xmax, "upper bound along x [m]")
      .def_readwrite("ymin", &mps::Domain::ymin, "lower bound along y [m]")
      .def_readwrite("ymax", &mps::Domain::ymax, "upper bound along y [m]")
      .def_readwrite("periodic_x", &mps::Domain::periodic_x, "whether x wraps around")
      .def_readwrite("periodic_y", &mps::Domain::periodic_y, "whether y wraps around")
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
      "2-D particle state as arrays (mps::Particles): x, y, u, v, p, kind, group, id (the library's field list),\n"
      "and positions, velocities of shape (N, 2). Reading an attribute gives a NumPy copy; assigning one takes an\n"
      "array of the same length (positions, velocities and pressures finite). id is each particle's index at\n"
      "creation and follows it through the reorderings a Simulation makes.");
  particles_class
      .def(py::init([](Typed<OptionalArray> x, Typed<OptionalArray> y, Typed<OptionalArray> kind, Typed<OptionalArray> u,
                       Typed<OptionalArray> v, Typed<OptionalArray> p, Typed<OptionalArray> group) {
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
      .def(
          "fill_rectangle",
          [](mps::Particles& p, Typed<RectLike> rect_in, double l0, Typed<KindLike> kind, int group) -> mps::Particles& {
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
          [](mps::Particles& p, Typed<RectLike> inner, double l0, Typed<SidesLike> sides, int wall_layers, int dummy_layers,
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
          "given sides ('left|right|bottom' or a list of names; corners between walled sides included); returns self.");
  def_fields(particles_class);

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
        [set = f.set](Config& c, Typed<FieldValue> v) { set(c, v); }, f.doc.c_str());

  py::class_<mps::StepInfo>(m, "StepInfo", "What the last step did (mps::StepInfo).")
      .def_readonly("step", &mps::StepInfo::step, "steps completed")
      .def_readonly("time", &mps::StepInfo::time, "simulation time after the step [s]")
      .def_readonly("dt", &mps::StepInfo::dt, "the step's time step [s]")
      .def_readonly("dt_limit", &mps::StepInfo::dt_limit, "which bound set dt: dt_max, cfl or viscous")
      .def_readonly("solve", &mps::StepInfo::solve, "the pressure solve's SolveReport")
      .def_readonly("viscosity_iterations", &mps::StepInfo::viscosity_iterations,
                    "iterations of the implicit viscous solves (0 with explicit viscosity)")
      .def_readonly("unknowns", &mps::StepInfo::unknowns, "the PPE's unknowns")
      .def_readonly("free_surface", &mps::StepInfo::free_surface, "particles flagged free surface")
      .def_readonly("floating_groups", &mps::StepInfo::floating_groups, "closed groups given the gauge")
      .def_readonly("max_speed", &mps::StepInfo::max_speed, "largest fluid speed [m/s]")
      .def_readonly("neighbors_carried", &mps::StepInfo::neighbors_carried,
                    "the step widened the last list at r* by its fringe instead of searching (neighbor_skin)")
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
          "number_density", [](const Ppe& p) { return to_numpy(p.n_star); },
          "n* per particle (0 for dummies and ghosts, which hold no PPE row)")
      .def_property_readonly(
          "divergence", [](const Ppe& p) { return to_numpy(p.div); }, "div u* per particle (0 for dummies and ghosts)")
      .def_property_readonly(
          "source", [](const Ppe& p) { return to_numpy(p.source); }, "per particle: lap P = source")
      .def_property_readonly(
          "offset", [](const Ppe& p) { return optional_doubles(p.offset); },
          "per particle: x solves for P - offset (the hydrostatic split), None when x is P")
      .def(
          "pressures",
          [](const Ppe& p, Typed<ArrayLike> x, bool clamp_negative) {
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
      [](const mps::Particles& particles, double dt, Typed<OptionalDomain> domain, Typed<ConfigLike> config, double asymmetry,
         bool wet_walls, const py::kwargs& fields) {
        return assemble(particles, dt, domain, config_of(config, fields), asymmetry, wet_walls);
      },
      py::arg("particles"), py::kw_only(), py::arg("dt"), py::arg("domain") = py::none(),
      py::arg("config") = py::none(), py::arg("asymmetry") = 0.0, py::arg("wet_walls") = false, assemble_doc);
  m.def(
      "assemble_ppe",
      [](Typed<ArrayLike> x, Typed<ArrayLike> y, Typed<ArrayLike> u, Typed<ArrayLike> v, Typed<ArrayLike> kind, double dt,
         Typed<OptionalDomain> domain, Typed<ConfigLike> config, double asymmetry, bool wet_walls, const py::kwargs& fields) {
        return assemble(particles_from_arrays(x, y, u, v, kind), dt, domain, config_of(config, fields), asymmetry,
                        wet_walls);
      },
      py::arg("x"), py::arg("y"), py::arg("u"), py::arg("v"), py::arg("kind"), py::kw_only(), py::arg("dt"),
      py::arg("domain") = py::none(), py::arg("config") = py::none(), py::arg("asymmetry") = 0.0,
      py::arg("wet_walls") = false,
      "Same, from arrays: positions x, y (r*), velocities u, v (u*) and kind (0 fluid, 1 wall, 2 dummy, 3 ghost).");

  def_write_vtp<2>(m);
  def_write_vtp<3>(m);
  bind_readers(m);
  bind_simulation<2>(m);
  bind_dimension3(m);
}

}  // namespace sparsemps
