#pragma once
/// \file
/// The physics and numerics of a run (SimulationConfig) and its schema: every field once, with its unit, its valid
/// range and a line of doc. Validation, Python's SimulationConfig and the apps' summaries all walk the schema
/// (for_each_parameter), so a new field is written here and nowhere else.
#include <algorithm>
#include <limits>
#include <string>
#include <string_view>
#include <type_traits>

#include "mps/core/kernel.hpp"
#include "mps/core/vec.hpp"
#include "mps/numerics/operators.hpp"

namespace mps {

/// The physics and numerics of a run; docs/step.md gives the reason and the measurement behind each default.
struct SimulationConfig {
  double l0 = 0;  ///< initial particle spacing [m]
  /// @{ Kernel radii in l0. The source's number density uses the Laplacian's radius: at 2.1 against a 4.1
  /// Laplacian, short waves grow ~(1 + 0.03 gamma) per step whatever dt is. Free-surface detection keeps 2.1.
  double radius_density = 4.1, radius_surface = 2.1, radius_gradient = 2.1, radius_laplacian = 4.1;  /// @}
  /// The largest of the four radii [l0]: the neighbour search's, and three times it a periodic axis's shortest length.
  [[nodiscard]] double largest_radius() const {
    return std::max({radius_density, radius_surface, radius_gradient, radius_laplacian});
  }
  Weight weight = Weight::bounded;  ///< the weight function of every kernel
  double rho = 1000.0;          ///< density [kg/m^3]
  double nu = 1e-6;             ///< kinematic viscosity [m^2/s]
  /// @{ body force per unit mass [m/s^2] (fz: 3-D only, 0 in 2-D)
  double fx = 0.0, fy = 0.0, fz = 0.0;  /// @}
  double gamma = 0.99;          ///< mixed source weight: 1 = number density error only, 0 = divergence only
  double beta = 0.97;           ///< free surface: n* < beta n0 ...
  double theta = 0.85;          ///< ... and fewer than theta N0 neighbours (0: density test only)
  double dt_max = 0;            ///< the time step when neither limit below binds [s]
  double cfl = 0.2;             ///< dt <= cfl l0 / |u|max
  double viscous_number = 0.2;  ///< dt <= viscous_number l0^2 / nu (explicit viscosity)
  /// Implicit viscosity: (I - dt nu L) u* = u^n + dt f, solved with `viscosity_solver`; drops the viscous limit.
  bool implicit_viscosity = false;
  std::string viscosity_solver = "eigen-cg:precond=jacobi";  ///< solver spec for the implicit viscous systems
  /// Density source against each wall particle's own t = 0 number density and the fluid's t = 0 mean, instead of
  /// the lattice n0 (component InitialReferenceDensity): for packings other than the square lattice.
  bool initial_reference_density = false;
  /// @{ Khayyer & Gotoh's treatments of the projection (docs/pressure.md), each normalised on the perfect lattice.
  /// The source's divergence term is -(d/n_rate) Dn/Dt at r*, u* (the number density's exact rate of change, on
  /// the density kernel) instead of the divergence of u* ("hs", Khayyer & Gotoh 2009).
  bool higher_order_source = false;
  /// The PPE's Laplacian weighs pairs by w'' + (d - 3) w'/r (Kernel::higher_order_weight) ("hl", 2010, 2012).
  bool higher_order_laplacian = false;
  /// The source gains -(rho/dt^2)(|e| delta + |delta| e), e = (n - n0)/n0 and delta = dt (Dn/Dt)/n0 at the step's
  /// start: a number-density error that is also growing is pushed back ("ecs", Khayyer & Gotoh 2011).
  bool error_compensating_source = false;  /// @}
  /// Every fluid particle an unknown of the PPE, the empty part of its support at P = 0 (component
  /// ContinuousFreeSurface, "cfs"; docs/pressure.md) instead of free-surface particles held at P = 0.
  bool continuous_free_surface = false;
  /// Dynamic stabilisation ("ds"): the corrector pushes pairs nearer than this many l0 apart to that distance (0: off;
  /// stabilisation_velocity_changes), so two particles held at the surface's pressure cannot run into each other.
  double stabilisation_distance = 0;
  /// What "ds" sets when no distance is given: on the dam break 0.7 l0 was stopped by the guard at H/50, 0.9 slowed the
  /// classic front 3.4 % below Martin & Moyce's (docs/pressure.md).
  static constexpr double default_stabilisation_distance = 0.85;
  GradientVariant pressure_gradient = GradientVariant::min_reference;  ///< the pressure gradient's form
  /// Min-reference variants take the minimum of P - rho f . r (true) or of P as published (false, which
  /// destabilises a liquid at rest under gravity).
  bool min_reference_tilt = true;
  /// With min_reference_tilt: the body force along non-periodic axes is balanced by P_h = rho f_h . r exactly and
  /// the PPE solves for P - P_h (component HydrostaticSplit), so a liquid at rest is an equilibrium on any packing.
  bool hydrostatic_split = true;
  /// Artificial sound speed [m/s] (0: incompressible): the PPE becomes (-lap + 1/(c dt)^2) P = -source, so a long
  /// channel's coherent density error is not expelled within one step.
  double sound_speed = 0;
  /// Particle shifting coefficient A (0: off; component ParticleShifting): fluid away from free surfaces moves down
  /// the concentration gradient with diffusion A l0 |u|max dt, at most 0.2 l0 per step.
  double shifting = 0;
  /// With shifting: particles on or next to a free surface shift too, along it only (Lind et al. 2012).
  bool shift_along_free_surface = false;
  bool clamp_negative_pressure = true;  ///< P < 0 -> 0 where the fluid touches a free surface (see PpeSystem::scatter)
  int reorder_every = 20;        ///< steps between reorderings of particles by cell (0: never)
  /// Whether the step after `steps` completed ones puts the particles in cell order (every reorder_every-th).
  [[nodiscard]] bool reorders_after(int steps) const { return reorder_every > 0 && steps % reorder_every == 0; }
  /// Serially, the search at r* also lists the pairs up to this far (in l0) beyond the largest radius, and the next
  /// step reuses that list while no particle has moved half as far (0: search twice a step). The sums skip those
  /// pairs, so results do not change (the one exception, collisions, in docs/benchmarks.md).
  double neighbor_skin = 0.1;
  double max_displacement = 0.5;  ///< guard: largest move of a particle in one step, in l0
  double max_speed = std::numeric_limits<double>::infinity();  ///< guard: largest speed [m/s]
  /// The host program's option for the time step, named in the guard's advice (e.g. --dt-factor).
  std::string dt_option;
  /// The pressure solver's spec. "auto" picks Jacobi-CG or reused AMG-PCG per solve by a fixed rule (docs/solvers.md);
  /// "eigen-cg" (incomplete-Cholesky CG) is the classic MPS baseline.
  std::string solver = "auto";
  /// Initial guess of each pressure solve: the previous step's pressure (true) or zeros (false, the classic baseline).
  bool warm_start = true;

  /// Throws std::invalid_argument naming the first parameter outside its range in the schema, and the range.
  void validate() const;
  /// The body force as a vector of a D-dimensional run.
  template <int D>
  [[nodiscard]] Vec<D> body_force() const {
    if constexpr (D == 2) return {fx, fy};
    else return {fx, fy, fz};
  }
};

/// One field of SimulationConfig as the schema lists it. T is double, int, bool, std::string, Weight or
/// GradientVariant; numbers must lie in [min, max] (an end excluded when its flag says open) and be finite unless max
/// is an included infinity.
template <class T>
struct Parameter {
  const char* name;              ///< the field's name in C++, Python and the summaries
  T SimulationConfig::*member;   ///< the field
  const char* unit;              ///< "m", "l0", "kg/m^3", ...; "" when dimensionless or not a number
  const char* doc;               ///< one line
  double min = -std::numeric_limits<double>::infinity();  ///< lowest valid value (numbers only)
  double max = std::numeric_limits<double>::infinity();   ///< highest valid value (numbers only)
  bool min_open = false;  ///< min itself is invalid
  bool max_open = true;   ///< max itself is invalid (so infinity is refused unless this is false)
};

/// Calls f(Parameter<T>) for every field of SimulationConfig, in the struct's order.
template <class F>
void for_each_parameter(F&& f) {
  using C = SimulationConfig;
  constexpr double inf = std::numeric_limits<double>::infinity();
  const auto radius = [](const char* name, double C::*m, const char* doc) {
    return Parameter<double>{name, m, "l0", doc, 1.0, kMaxRadius, true, false};
  };
  f(Parameter<double>{"l0", &C::l0, "m", "initial particle spacing, required", 0, inf, true});
  f(radius("radius_density", &C::radius_density, "number density (source) kernel radius"));
  f(radius("radius_surface", &C::radius_surface, "free-surface detection kernel radius"));
  f(radius("radius_gradient", &C::radius_gradient, "gradient and divergence kernel radius"));
  f(radius("radius_laplacian", &C::radius_laplacian, "Laplacian (PPE, viscosity) kernel radius"));
  f(Parameter<Weight>{"weight", &C::weight, "", "'bounded' (Lan, Zhao & Wan 2022) or 'classic' (re/r - 1)"});
  f(Parameter<double>{"rho", &C::rho, "kg/m^3", "density", 0, inf, true});
  f(Parameter<double>{"nu", &C::nu, "m^2/s", "kinematic viscosity", 0, inf});
  f(Parameter<double>{"fx", &C::fx, "m/s^2", "body force per unit mass, x"});
  f(Parameter<double>{"fy", &C::fy, "m/s^2", "body force per unit mass, y"});
  f(Parameter<double>{"fz", &C::fz, "m/s^2", "body force per unit mass, z (3-D only)"});
  f(Parameter<double>{"gamma", &C::gamma, "", "mixed source weight: 1 number density error only, 0 divergence only",
                      0, 1, false, false});
  f(Parameter<double>{"beta", &C::beta, "", "free surface: n* < beta n0 ...", 0, 1, true, true});
  f(Parameter<double>{"theta", &C::theta, "", "... and fewer than theta N0 neighbours (0: density test only)", 0, 1,
                      false, false});
  f(Parameter<double>{"dt_max", &C::dt_max, "s", "the time step when neither the CFL nor the viscous limit binds", 0,
                      inf, true});
  f(Parameter<double>{"cfl", &C::cfl, "", "dt <= cfl l0 / |u|max", 0, inf, true});
  f(Parameter<double>{"viscous_number", &C::viscous_number, "", "dt <= viscous_number l0^2 / nu (explicit viscosity)",
                      0, inf, true});
  f(Parameter<bool>{"implicit_viscosity", &C::implicit_viscosity, "", "solve the viscous predictor implicitly"});
  f(Parameter<std::string>{"viscosity_solver", &C::viscosity_solver, "", "solver spec of the implicit viscosity"});
  f(Parameter<bool>{"initial_reference_density", &C::initial_reference_density, "",
                    "source against each particle's t = 0 number density instead of the lattice n0"});
  f(Parameter<bool>{"higher_order_source", &C::higher_order_source, "",
                    "source's divergence from the number density's rate of change (Khayyer & Gotoh 2009)"});
  f(Parameter<bool>{"higher_order_laplacian", &C::higher_order_laplacian, "",
                    "PPE Laplacian weighted by w'' + (d - 3) w'/r (Khayyer & Gotoh 2010)"});
  f(Parameter<bool>{"error_compensating_source", &C::error_compensating_source, "",
                    "source term against a growing number-density error (Khayyer & Gotoh 2011)"});
  f(Parameter<bool>{"continuous_free_surface", &C::continuous_free_surface, "",
                    "every fluid particle an unknown, its support's empty part at P = 0"});
  f(Parameter<double>{"stabilisation_distance", &C::stabilisation_distance, "l0",
                      "the corrector pushes closer pairs apart to this distance (0: off)", 0, 1, false, true});
  f(Parameter<GradientVariant>{"pressure_gradient", &C::pressure_gradient, "",
                               "plain, min-reference, corrected, corrected-min-reference or conservative"});
  f(Parameter<bool>{"min_reference_tilt", &C::min_reference_tilt, "", "min-reference of P - rho f.r instead of P"});
  f(Parameter<bool>{"hydrostatic_split", &C::hydrostatic_split, "", "solve for P - rho f.r (with min_reference_tilt)"});
  f(Parameter<double>{"sound_speed", &C::sound_speed, "m/s", "artificial sound speed (0: incompressible)", 0, inf});
  f(Parameter<double>{"shifting", &C::shifting, "", "particle shifting coefficient (0: off)", 0, inf});
  f(Parameter<bool>{"shift_along_free_surface", &C::shift_along_free_surface, "", "shift surface particles along it"});
  f(Parameter<bool>{"clamp_negative_pressure", &C::clamp_negative_pressure, "",
                    "P < 0 -> 0 where a free surface is near"});
  f(Parameter<int>{"reorder_every", &C::reorder_every, "steps", "between reorderings of the particles by cell (0: never)",
                   0, inf});
  f(Parameter<double>{"neighbor_skin", &C::neighbor_skin, "l0",
                      "pairs listed beyond the largest radius so the next step need not search (0: off)", 0, 1, false,
                      false});
  f(Parameter<double>{"max_displacement", &C::max_displacement, "l0", "guard: largest move in one step", 0, inf, true});
  f(Parameter<double>{"max_speed", &C::max_speed, "m/s", "guard: largest speed (infinity: off)", 0, inf, true, false});
  f(Parameter<std::string>{"dt_option", &C::dt_option, "", "the host's option for the time step, named in the guard's "
                           "advice"});
  f(Parameter<std::string>{"solver", &C::solver, "", "pressure solver spec (default 'auto')"});
  f(Parameter<bool>{"warm_start", &C::warm_start, "", "start each solve from the previous pressure"});
}

/// The treatments of the projection as names joined by '+': "hs" (higher_order_source), "hl" (higher_order_laplacian),
/// "ecs" (error_compensating_source), "cfs" (continuous_free_surface) and "gc" (pressure_gradient corrected, Khayyer &
/// Gotoh's gradient correction), in that order; "none" when no treatment is on.
std::string pressure_treatment(const SimulationConfig& config);
/// Sets the four treatments' flags from such names, in any order ("none": all off); "gc" also sets the pressure
/// gradient to corrected, and without it the gradient is left as it is. Throws std::invalid_argument naming an unknown
/// or repeated name and the valid ones.
void set_pressure_treatment(SimulationConfig& config, std::string_view names);

/// A number range as a reader writes it: "positive", ">= 0", "in (1, 10]", "finite"; "" when anything goes.
std::string range_text(double min, double max, bool min_open, bool max_open);
/// Whether v lies in the range; it must be finite unless max is an included infinity.
bool in_range(double v, double min, double max, bool min_open, bool max_open);

}  // namespace mps
