#pragma once
// The semi-implicit MPS step (design §3), time-step control and the stability guard:
// neighbours -> predictor (viscosity, body force) -> n*, div u* -> PPE -> solve -> pressure-gradient corrector.
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "mps/boundary.hpp"
#include "mps/kernel.hpp"
#include "mps/neighbors.hpp"
#include "mps/operators.hpp"
#include "mps/particles.hpp"
#include "mps/ppe.hpp"
#include "mps/solvers/solver.hpp"

namespace mps {

struct SimulationConfig {
  double l0 = 0;  // initial particle spacing [m]
  // Kernel radii in units of l0. Seed 004: 2.1 for number density and gradient, 4.1 for the Laplacian.
  // The PPE source's number density is measured at radius_density = 4.1, the Laplacian's: with n* at 2.1
  // against a 4.1 Laplacian, short waves (k ~ 0.8 pi/l0) are corrected with the wrong sign and grow by
  // ~(1 + 0.03 gamma) per step whatever dt is (a closed box jittered by 1 % blows up within ~60 steps at
  // gamma = 0.99; with 4.1 it relaxes). Where that kernel reaches a free-surface particle its deficit is
  // geometry, so those particles take the divergence source alone. Free-surface detection keeps the 2.1
  // number density (radius_surface). README, "Numerics and stability".
  double radius_density = 4.1, radius_surface = 2.1, radius_gradient = 2.1, radius_laplacian = 4.1;
  Weight weight = Weight::bounded;
  double rho = 1000.0;          // density [kg/m^3]
  double nu = 1e-6;             // kinematic viscosity [m^2/s]
  double fx = 0.0, fy = 0.0;    // body force per unit mass [m/s^2]
  double gamma = 0.99;          // mixed source weight: 1 = number density error only, 0 = divergence only
  double beta = 0.97;           // free surface: n* < beta n0 ...
  double theta = 0.85;          // ... and fewer than theta N0 neighbours (0: density test only)
  double dt_max = 0;            // the time step when neither limit below binds [s]
  double cfl = 0.2;             // dt <= cfl l0 / |u|max
  double viscous_number = 0.2;  // dt <= viscous_number l0^2 / nu (explicit viscosity)
  // Implicit viscosity: the predictor solves (I - dt nu L) u* = u^n + dt f over the fluid, wall and dummy
  // velocities (mirror values included) taken as known, with `viscosity_solver`; the viscous limit on dt
  // is then dropped. For slow flows (seed 004's Re = 4) whose explicit dt would be far below the CFL bound.
  bool implicit_viscosity = false;
  std::string viscosity_solver = "eigen-cg:precond=jacobi";
  // The density source's reference number density: the lattice n0 for every particle (false), or each wall
  // particle's own number density at t = 0 and the fluid's mean at t = 0 (true). Packings other than the square
  // lattice (seed 000's concentric rings) differ from the lattice n0 by a few per cent, by an amount that varies
  // with the curvature. Walls cannot move to remove that error, so read as compression it drives a standing
  // pressure ~ gamma rho/dt^2 (n - n0)/n0, which grows as the spacing shrinks and outweighs a slow flow's
  // pressure (README, "Rotating boundary"). Wall groups must keep their layout relative to the fluid (rigid
  // walls, not a free surface drying them).
  bool initial_reference_density = false;
  GradientVariant pressure_gradient = GradientVariant::min_reference;
  // Min-reference variants: take the minimum of P less its hydrostatic part rho f . r (true), or of P as
  // published (false). The published form destabilises a liquid at rest under gravity (README, "Numerics").
  bool min_reference_tilt = true;
  // Hydrostatic split (with min_reference_tilt): the body force along non-periodic axes, f_h, is balanced by
  // P_h = rho f_h . r exactly. The predictor leaves f_h out, the PPE solves for P' = P - P_h (walls zero-flux for
  // P', i.e. dP/dn = rho f_h . n; free-surface particles at P = rho |f_h| l0/2, the surface lying half a spacing
  // above their centres) and the corrector takes the particle gradient of P' alone. A liquid at rest is then an
  // equilibrium on any particle arrangement, corners and truncated kernels included. Without it the PPE's
  // zero-flux walls and the particle gradient of the hydrostatic pressure disagree near wall corners, and a
  // closed tank at g = 9.81 drifted 0.95 l0 in 0.5 s (README, "Numerics and stability").
  bool hydrostatic_split = true;
  // Artificial sound speed [m/s] (0: incompressible). The PPE becomes (-lap + 1/(c dt)^2) P = -source, the
  // compressibility term design section 3 lists for closed domains: a density error of wavelength well below c dt
  // is corrected as before, a longer one gets the pressure rho c^2 (n - n0)/n0 of a compressible liquid instead of
  // one growing with the square of its length. Incompressible, the source of a long open channel turns any
  // coherent density error, however small, into a pressure ~ gamma rho (L/dt)^2 (n - n0)/n0 that expels it through
  // the outlet within one step: fluid rows sliding along a wall's particle lattice change their number density in
  // step (1e-3 in the near-wall rows, a mean of 4e-5 over the fluid), and in a channel 750 l0 long that moved the
  // plate pressure by +-4 Pa from step to step (the Poiseuille drop is 0.002 Pa) and the outlet flow by +-40 %
  // (README, "Poiseuille"). Choose c so that the flow's pressures compress the liquid little, e.g. by Morris et
  // al.'s (1997) c^2 = max(u^2, dP/rho)/delta for a density variation delta.
  double sound_speed = 0;
  // Particle shifting coefficient A (0: off): after each step, fluid away from free surfaces and the outflow buffer
  // moves down the particle concentration gradient (shift_particles) with the diffusion A l0 |u|max dt (Lind et al.
  // 2012), at most 0.2 l0 per step. For flows that draw the lattice apart over many steps: the Re = 4 inlet
  // channel's entrance region (README, "Poiseuille").
  double shifting = 0;
  bool clamp_negative_pressure = true;  // P < 0 -> 0 where the fluid touches a free surface (see PpeSystem::scatter)
  int reorder_every = 20;        // steps between reorderings of particles by cell (0: never)
  double max_displacement = 0.5;  // guard: largest move of a particle in one step, in l0
  double max_speed = std::numeric_limits<double>::infinity();  // guard: largest speed [m/s]
  std::string solver = "eigen-cg";
  // Initial guess of each pressure solve: the previous step's pressure (true, design section 5) or zeros (false,
  // the classic baseline that ignores the last step). Direct solvers (cholmod) ignore it either way.
  bool warm_start = true;

  void validate() const;  // throws std::invalid_argument naming the bad parameter and its valid range
};

struct StepInfo {
  int step = 0;                 // steps completed
  double time = 0, dt = 0;
  std::string dt_limit;         // which bound set dt: "dt_max", "cfl" or "viscous"
  SolveReport solve;
  int viscosity_iterations = 0;  // implicit viscosity: CG iterations of both components
  std::size_t unknowns = 0, free_surface = 0, floating_groups = 0;
  double max_speed = 0;
};

struct PhaseTimes {
  double neighbors = 0, predict = 0, assemble = 0, solver_setup = 0, solve = 0, correct = 0;
  [[nodiscard]] double total() const { return neighbors + predict + assemble + solver_setup + solve + correct; }
};

class Simulation {
 public:
  Simulation(Particles particles, Domain domain, SimulationConfig config);
  Simulation(Particles particles, Domain domain, SimulationConfig config, std::unique_ptr<LinearSolver> solver);

  // Advances one step or throws SimulationError and keeps the previous state.
  const StepInfo& step();

  // Called after the predictor with the particles and the new time: sets wall/dummy positions and
  // velocities of moving boundaries.
  using BoundaryMotion = std::function<void(Particles&, double time)>;
  void set_boundary_motion(BoundaryMotion motion) { motion_ = std::move(motion); }

  // No-slip by mirror velocities on a flat wall (see MirrorWall): its particles' velocities are set from
  // the fluid before the viscous term; the PPE's divergence then sees them at the wall's own velocity.
  void add_mirror_wall(const MirrorWall& wall);

  // Where a free surface may exist (unset: everywhere). Outside it no particle is flagged free surface,
  // whatever its number density: in a confined liquid a low n* is a void to be closed by the source term,
  // and P = 0 there, with no ambient pressure around it to collapse the void, keeps it open.
  using SurfaceRegion = std::function<bool(double x, double y)>;
  void set_free_surface_region(SurfaceRegion region) { surface_region_ = std::move(region); }
  // An open outlet through an outflow buffer (see OutflowBuffer): its particles are held at P = 0 and its fluid
  // leaves at the velocity of the fluid upstream, unmoved by the pressure gradient and the viscous term.
  void set_outflow_buffer(const OutflowBuffer& buffer);
  [[nodiscard]] const std::optional<OutflowBuffer>& outflow_buffer() const { return outflow_; }
  [[nodiscard]] const std::vector<MirrorWall>& mirror_walls() const { return mirror_walls_; }

  [[nodiscard]] const Particles& particles() const { return particles_; }
  [[nodiscard]] const Domain& domain() const { return domain_; }
  [[nodiscard]] const SimulationConfig& config() const { return config_; }
  [[nodiscard]] const LinearSolver& solver() const { return *solver_; }
  [[nodiscard]] const StepInfo& last_step() const { return info_; }
  [[nodiscard]] const PhaseTimes& times() const { return times_; }
  [[nodiscard]] double time() const { return info_.time; }
  [[nodiscard]] const Kernel& density_kernel() const { return k_density_; }
  [[nodiscard]] const Kernel& surface_kernel() const { return k_surface_; }
  [[nodiscard]] const Kernel& gradient_kernel() const { return k_gradient_; }
  [[nodiscard]] const Kernel& laplacian_kernel() const { return k_laplacian_; }
  [[nodiscard]] const std::vector<double>& number_density() const { return n_star_; }  // source n* of the last step
  [[nodiscard]] const PpeSystem& last_ppe() const { return ppe_; }

 private:
  void advance();
  void check_guard() const;
  void apply_mirror_walls();
  void implicit_viscous_predictor(const Stencil& s, double dt, double fx, double fy);
  [[nodiscard]] double choose_dt(std::string& limit) const;

  Particles particles_;
  Domain domain_;
  SimulationConfig config_;
  std::unique_ptr<LinearSolver> solver_;
  std::unique_ptr<LinearSolver> viscosity_solver_;  // only with implicit_viscosity
  Kernel k_density_, k_surface_, k_gradient_, k_laplacian_;
  CellGrid grid_;
  BoundaryMotion motion_;
  SurfaceRegion surface_region_;
  std::vector<MirrorWall> mirror_walls_;
  std::optional<OutflowBuffer> outflow_;
  std::vector<char> in_buffer_;  // this step's outflow-buffer particles, by position at its start
  StepInfo info_;
  PhaseTimes times_;
  // Kept between steps so that their memory is reused, not allocated (and page-faulted) anew each step.
  NeighborList near_now_, near_star_, close_star_;
  Particles before_step_;  // the state a failed step rolls back to
  std::vector<double> n_star_;
  std::vector<double> n_reference_;  // by particle id, with initial_reference_density
  PpeSystem ppe_;
};

}  // namespace mps
