#pragma once
// Plane channel flows of width D between no-slip walls (seed 004; design §6 "Poiseuille"), periodic along x:
//  body-force: fluid at rest driven by a uniform force F from t = 0; the transient series solution
//              (Morris et al. 1997) tends to the parabola with mean velocity U, u_max = 1.5 U;
//  couette:    fluid at rest, the top wall sliding at U from t = 0; the start-up series tends to U y / D.
// Walls are one wall layer and four dummy layers with mirror velocities (mps::MirrorWall). The channel is
// closed (no free surface): the PPE takes the library's all-Neumann treatment.
#include <string>
#include <vector>

#include "mps/step.hpp"

namespace poiseuille {

enum class Mode { body_force, couette };
Mode parse_mode(const std::string& name);  // "body-force" | "couette"; throws std::invalid_argument otherwise
std::string to_string(Mode mode);

struct Params {
  Mode mode = Mode::body_force;
  double D = 0.2;          // channel width [m]
  double re = 40;          // Reynolds number U D / nu
  double across = 50;      // particles across the channel: l0 = D / across (50: the paper's dx = 0.004 m)
  double length_l0 = 16;   // periodic length in l0 (at least 13: three cells of the 4.1 l0 search)
  double rho = 1000, nu = 1e-6;
  double gamma = 0.99;
  double dt_factor = 1;    // multiplies both time-step limits (CFL 0.2, viscous number 0.2); > 1 probes stability
  std::string solver = "eigen-cg";

  [[nodiscard]] double l0() const { return D / across; }
  [[nodiscard]] double U() const { return re * nu / D; }          // mean velocity (body-force) or wall speed
  [[nodiscard]] double force() const { return 12.0 * nu * U() / (D * D); }  // F giving mean velocity U
  [[nodiscard]] double diffusion_time() const { return D * D / nu; }
  [[nodiscard]] double convective_time() const { return D / U(); }
  void validate() const;  // throws std::invalid_argument naming the bad parameter
};

// The exact velocity u(y, t) of the mode, y from the bottom wall line (0 <= y <= D). The series is summed
// until its terms fall below 1e-14 of the scale velocity (at most 100000 terms).
double exact_velocity(const Params& p, double y, double t);

mps::Particles make_particles(const Params& p);  // fluid group 0, bottom wall group 1, top wall group 2
mps::Simulation make_simulation(const Params& p);

// Velocity profile across the channel: fluid particles binned into rows of height l0 (their lattice rows),
// averaged over x; and errors against the exact solution at the same time.
struct Profile {
  double time = 0;
  std::vector<double> y, u, exact;
  double l2_error = 0;     // ||u - exact|| / ||exact|| over the rows
  double peak_error = 0;   // |max u - max exact| / max exact
  double flow_rate_error = 0;  // |sum u l0 - integral of exact| / integral of exact
  double max_abs_v = 0;    // largest transverse speed of any fluid particle [m/s]
};
Profile measure_profile(const Params& p, const mps::Simulation& sim);

}  // namespace poiseuille
