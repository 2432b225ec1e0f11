#pragma once
// Plane channel flows of width D between no-slip walls (seed 004; design §6 "Poiseuille"):
//  inlet:      the paper's set-up. A channel of length L with a pushing plate at x = 0 moving at U (ghost
//              recycling, mps::PushingPlate) and an open outlet at x = L; the flow develops into the parabola
//              with mean velocity U, u_max = 1.5 U, measured at the station x = 10 D;
//  body-force: periodic along x, fluid at rest driven by a uniform force F from t = 0; the transient series
//              solution (Morris et al. 1997) tends to the same parabola;
//  couette:    periodic along x, fluid at rest, the top wall sliding at U from t = 0; the start-up series
//              tends to U y / D.
// Walls are one wall layer and four dummy layers with mirror velocities (mps::MirrorWall). The periodic
// channels are closed (no free surface): the PPE takes the library's all-Neumann treatment; the inlet
// channel's outlet is free surface (P = 0).
#include <memory>
#include <optional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mps/boundaries/boundary.hpp"
#include "mps/parallel/rank_exchange.hpp"
#include "mps/step/step.hpp"

namespace poiseuille {

enum class Mode { inlet, body_force, couette };
Mode parse_mode(const std::string& name);  // "inlet" | "body-force" | "couette"; throws std::invalid_argument otherwise
std::string to_string(Mode mode);

struct Params {
  Mode mode = Mode::inlet;
  double D = 0.2;          // channel width [m]
  double re = 40;          // Reynolds number U D / nu
  double across = 50;      // particles across the channel: l0 = D / across (50: the paper's dx = 0.004 m)
  double length_l0 = 16;   // periodic modes: the periodic length in l0 (at least 13: three cells of the 4.1 l0 search)
  double length_D = 15;    // inlet: channel length in D (the paper's 15 D) ...
  double station_D = 10;   // ... and the measuring station x, in D from the plate's start
  double rho = 1000, nu = 1e-6;
  double gamma = 0.99;
  double dt_factor = 1;    // multiplies both time-step limits (CFL 0.2, viscous number 0.2); > 1 probes stability
  bool implicit_viscosity = false;  // lifts the viscous limit (Re = 4 at dx = 0.004 m: ~31,000 explicit steps)
  // inlet: the outlet as an outflow buffer this many l0 thick (mps::OutflowBuffer; 0: an open end of free-surface
  // particles, which the guard stopped at step 67 at Re = 400, 50 across: docs/poiseuille.md)
  double outlet_buffer_l0 = 5;
  // inlet: the density variation an artificial compressibility may cause (0: incompressible). Its sound speed
  // follows Morris et al.'s (1997) criterion c^2 = max(u_max^2, dP/rho) / compression, u_max = 1.5 U and dP the
  // Poiseuille drop along the channel (SimulationConfig::sound_speed).
  double compression = 1e-4;
  double shifting = 0;  // particle shifting coefficient (SimulationConfig::shifting; 0: off)
  [[nodiscard]] double sound_speed() const;
  std::string solver = "auto";
  bool warm_start = true;  // pressure solve from the previous step's pressure (false: from zeros)

  [[nodiscard]] double l0() const { return D / across; }
  [[nodiscard]] double U() const { return re * nu / D; }          // mean velocity (body-force) or wall speed
  [[nodiscard]] double force() const { return 12.0 * nu * U() / (D * D); }  // F giving mean velocity U
  [[nodiscard]] double diffusion_time() const { return D * D / nu; }
  [[nodiscard]] bool periodic() const { return mode != Mode::inlet; }
  [[nodiscard]] double convective_time() const { return D / U(); }
  void validate() const;  // throws std::invalid_argument naming the bad parameter
};

// The exact velocity u(y, t) of the mode, y from the bottom wall line (0 <= y <= D): for inlet the developed
// parabola 6 U (y/D)(1 - y/D) whatever t; for the periodic modes the start-up series, summed until its terms
// fall below 1e-14 of the scale velocity (at most 100000 terms).
double exact_velocity(const Params& p, double y, double t);

// Fluid group 0, bottom wall group 1, top wall group 2; inlet: plate group 3 and a pool of ghosts.
mps::Particles make_particles(const Params& p);
mps::Domain make_domain(const Params& p);
mps::SimulationConfig make_config(const Params& p);
// The mode's components (inlet: the pushing plate, returned so that its counts can be read; else nullptr), added to a
// simulation of make_particles(p) (`initial`), serial or distributed.
std::shared_ptr<mps::PushingPlate> add_components(const Params& p, const mps::Particles& initial,
                                                  mps::Simulation& sim);
// The three above together; on the ranks of an MPI communicator (comm: its Fortran handle) with an mps::RankExchange,
// every rank passing the same parameters.
// plate: where the inlet's plate goes (a checkpoint saves its counts); null for the periodic channels.
mps::Simulation make_simulation(const Params& p, std::optional<int> comm = {},
                                std::shared_ptr<mps::PushingPlate>* plate = nullptr);
// Before anything is built: about how many particles the scene holds, and the time step at the developed speed (for
// refusing runs too large to be meant).
double estimated_particles(const Params& p);
double initial_dt(const Params& p);

// Velocity profile across the channel: fluid particles binned into rows of height l0 (their lattice rows),
// averaged over x (inlet: over the two columns nearest the station) and over the samples taken; and errors
// against the exact solution.
struct Profile {
  double time = 0;
  int samples = 0;
  std::vector<double> y, u, exact;
  double l2_error = 0;     // ||u - exact|| / ||exact|| over the rows
  double peak_error = 0;   // |max u - max exact| / max exact
  double flow_rate_error = 0;  // |sum u l0 - integral of exact| / integral of exact
  double max_abs_v = 0;    // largest transverse speed of any sampled fluid particle [m/s]
};

// Accumulates samples of the profile. The inlet channel's developed profile is averaged over many steps:
// one snapshot holds two particles per row, and their velocities scatter by a few per cent.
class ProfileSampler {
 public:
  explicit ProfileSampler(const Params& p);
  void add(const mps::Simulation& sim);  // on ranks: this rank's own particles
  void sum_over_ranks(int comm);  // on ranks, before result(): the samples of every rank (collective)
  [[nodiscard]] Profile result(double time) const;  // compared with the exact solution at `time`
  [[nodiscard]] int samples() const { return samples_; }
  void clear();
  // For a checkpoint: the sums so far.
  [[nodiscard]] nlohmann::json save_state() const;
  void restore_state(const nlohmann::json& state);

 private:
  Params p_;
  std::vector<double> sum_;
  std::vector<long> count_;
  int samples_ = 0;
  double max_abs_v_ = 0;
};

// One sample at the simulation's time.
Profile measure_profile(const Params& p, const mps::Simulation& sim);

}  // namespace poiseuille
