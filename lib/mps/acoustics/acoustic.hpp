#pragma once
/// \file
/// Linearised acoustics on a fixed particle set: the MPS wave-propagation model (MPS-WP, seed 001; design §6)
///   d(dp)/dt + u0 . grad dp = -rho0 c0^2 div du,      d(du)/dt + u0 . grad du = -grad dp / rho0,
/// with the MPS gradient and divergence built once as CSR matrices (particles never move), classic RK4 in time,
/// hard walls by mirrored virtual particles or the first-order Mur absorbing boundary, and the exact solution
/// of a Gaussian pulse (a Hankel-transform integral) to measure the error against.
///
/// Definitions used throughout (and printed in every summary):
/// - relative RMS error: sqrt(sum_i (dp_i - dp_exact_i)^2 / sum_i dp_exact_i^2) over the interior particles;
/// - acoustic energy per unit depth [J/m]: E = l0^2 sum_i (dp_i^2 / (2 rho0 c0^2) + rho0 |du_i|^2 / 2) over the
///   interior particles (virtual particles outside the box carry no energy of their own).
#include <cstddef>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "mps/boundaries/geometry.hpp"
#include "mps/core/csr.hpp"
#include "mps/core/kernel.hpp"
#include "mps/core/neighbors.hpp"
#include "mps/core/particles.hpp"
#include "mps/numerics/operators.hpp"

namespace mps {

// ---------------------------------------------------------------------------------------------------------
// Exact solution of a Gaussian pulse dp(r, 0) = eps exp(-ln2 r^2 / b^2), du(r, 0) = 0 (seed 001, eq. 29-30):
//   dp(r, t)          = (eps / (2 a)) int_0^inf exp(-xi^2/(4a)) cos(xi c0 t) J0(xi r) xi dxi,
//   rho0 c0 du_r(r, t) = (eps / (2 a)) int_0^inf exp(-xi^2/(4a)) sin(xi c0 t) J1(xi r) xi dxi,   a = ln2 / b^2.
// The second follows from rho0 d(du_r)/dt = -d(dp)/dr; it gives the exact energy left in a region.

/// A Gaussian pressure pulse dp(r, 0) = eps exp(-ln2 r^2 / b^2) at rest, emitted at `time`.
struct GaussianPulse {
  /// @{ centre at emission [m]
  double x = 0, y = 0;  /// @}
  double amplitude = 1.0;   ///< eps [Pa]
  double half_width = 3.0;  ///< b [m]: dp = eps/2 at r = b
  double time = 0;          ///< emission time [s]; under a mean flow the centre moves with u0 from then on
};

/// Both integrals for eps = 1, in units of eps (pressure) and eps / (rho0 c0) (radial velocity).
struct PulseProfile {
  /// @{ dp / eps and du_r rho0 c0 / eps
  double pressure = 0, radial_velocity = 0;  /// @}
};

/// Composite Gauss-Legendre quadrature on panels of about one oscillation period of the integrand, each
/// panel refined by bisection until its 16- and 8-point rules agree within its share of `tolerance`; the
/// Gaussian tail beyond the last panel is below tolerance / 10. `tolerance` is absolute, in units of eps.
PulseProfile gaussian_pulse_exact(double r, double age, double half_width, double c0, double tolerance = 1e-10);

/// The profile at one age tabulated on r = 0, h, 2h, ... with h = b / 32 and interpolated by 4-point Lagrange
/// polynomials (the pressure is even in r, the radial velocity odd). Beyond r_max = c0 age + 6.5 b both are
/// below 1e-12 eps (the initial Gaussian there is) and the table returns 0. `r_needed` (optional) limits the table to
/// the distances a caller will ask for: the quadrature costs ~ (c0 age)^2 out to r_max, and long after a pulse has left
/// a box its points are far nearer than its wavefront. Asking beyond r_needed then throws std::out_of_range.
class PulseTable {
 public:
  /// Tabulates the profile of half width b = half_width at time `age` after emission (quadrature `tolerance`).
  PulseTable(double half_width, double c0, double age, double tolerance = 1e-10,
             double r_needed = std::numeric_limits<double>::infinity());
  [[nodiscard]] PulseProfile at(double r) const;  ///< the profile at distance r from the centre
  [[nodiscard]] double r_max() const { return r_max_; }  ///< c0 age + 6.5 b: zero beyond
  [[nodiscard]] double age() const { return age_; }      ///< time since emission [s]

 private:
  double h_ = 0, r_max_ = 0, age_ = 0, r_table_ = 0;
  std::vector<double> p_, u_;
};

/// An acoustic field at a set of points.
struct AcousticField {
  /// @{ dp [Pa] and du = (u, v) [m/s] at each point
  std::vector<double> p, u, v;  /// @}
};

/// The exact field at points (x, y) and time t: the sum over the pulses emitted at or before t, each centred at
/// (x, y) + u0 (t - time). With `hard_walls`, the box's walls reflect by the method of images (needs u0 = 0).
AcousticField exact_acoustic_field(std::span<const double> x, std::span<const double> y, double t,
                                   std::span<const GaussianPulse> pulses, double c0, double rho0, double u0x,
                                   double u0y, std::optional<Rect> hard_walls = std::nullopt,
                                   double tolerance = 1e-10);

/// sqrt(sum (value - exact)^2 / sum exact^2) (0 when both are zero, infinite when only exact is).
double relative_rms_error(std::span<const double> value, std::span<const double> exact);

/// E = cell_area sum (p^2 / (2 rho0 c0^2) + rho0 (u^2 + v^2) / 2) [J per unit depth]
double acoustic_energy(std::span<const double> p, std::span<const double> u, std::span<const double> v,
                       double cell_area, double c0, double rho0);

// ---------------------------------------------------------------------------------------------------------
// Gradient operators for the acoustic equations.

/// The gradient (and divergence) operator of the acoustic equations.
enum class AcousticGradient {
  mps,            ///< the plain MPS gradient (d/n0) sum (phi_j - phi_i) r_ij/|r_ij|^2 w_ij of seed 001
  least_squares,  ///< "ls3": weighted least squares on a cubic Taylor basis (LSMPS-type), exact for cubics; on the
                  ///< lattice its dispersion error is O(l0^4) instead of the MPS gradient's O(l0^2)
};
AcousticGradient parse_acoustic_gradient(std::string_view name);  ///< "mps" | "ls3"
std::string_view to_string(AcousticGradient gradient);  ///< the name parse_acoustic_gradient reads

/// Rows for the first `rows` particles of s.particles (columns: all of them), coefficients from the cubic
/// weighted least-squares fit with the stencil's kernel weight; the diagonal holds minus the row sum so that
/// the product is sum_j a_ij (phi_j - phi_i). Throws std::invalid_argument where a neighbourhood cannot
/// determine a cubic (too few or collinear neighbours).
GradientMatrices least_squares_gradient_matrices(const Stencil& s, std::size_t rows);

// ---------------------------------------------------------------------------------------------------------
// The time-stepping module.

/// What the box's sides do: reflect, or absorb by Mur's boundary condition.
enum class AcousticBoundary {
  hard,      ///< mirrored virtual particles: dp even, the normal component of du odd (a reflecting wall)
  /// First-order Mur on every virtual layer, f0^{n+1} = f1^n + (c dt - dx)/(c dt + dx) (f1^{n+1} - f0^n), with c the
  /// outgoing speed c0 + u0 . n and dx the distance to the partner one layer inward (sqrt(2) l0 at corners) ...
  mur,       ///< ... evaluated at each RK4 stage time too (dt -> the stage's offset 0, dt/2, dt/2, dt): stable up
             ///< to the interior's RK4 limit
  mur_step,  ///< Mur as above, once per step, the virtual particles frozen through the stages (as published):
             ///< limits the stable CFL to ~0.8 with the MPS gradient (docs/acoustics.md)
};
AcousticBoundary parse_acoustic_boundary(std::string_view name);  ///< "hard" | "mur" | "mur-step"
std::string_view to_string(AcousticBoundary boundary);  ///< the name parse_acoustic_boundary reads

/// The parameters of an acoustic run (defaults: seed 001's).
struct AcousticConfig {
  Rect box{-50.0, -50.0, 50.0, 50.0};  ///< the fluid region [m]; its sides must be multiples of l0
  double l0 = 0.25;                    ///< particle spacing [m]
  double cfl = 0.136;                  ///< c0 dt / l0
  double c0 = 340.0;                   ///< speed of sound [m/s]
  double rho0 = 1.2;                   ///< density [kg/m^3] (air)
  /// @{ uniform mean flow [m/s], subsonic
  double u0x = 0.0, u0y = 0.0;  /// @}
  AcousticGradient gradient = AcousticGradient::mps;  ///< the gradient and divergence operator
  Weight weight = Weight::classic;     ///< seed 001: w = re/r - 1 ...
  double radius = 2.1;                 ///< ... with re = 2.1 l0
  AcousticBoundary boundary = AcousticBoundary::mur;  ///< what the box's sides do
  /// Guard: the energy may not exceed this factor times the largest energy any superposition of the injected
  /// pulses can carry, (sum_k sqrt(E_k))^2. The exact and the stable discrete dynamics never exceed 1.
  double guard_energy_factor = 2.0;

  [[nodiscard]] double dt() const { return cfl * l0 / c0; }  ///< the time step cfl l0 / c0 [s]
  void validate() const;  ///< throws std::invalid_argument naming the parameter and what to change
};

/// Linearised acoustics (MPS-WP) on the lattice filling config.box, at rest until pulses are added.
class AcousticSolver {
 public:
  /// Validates the configuration, fills the box and its virtual layers, and builds the operators.
  explicit AcousticSolver(const AcousticConfig& config);

  /// Adds the pulse's dp to the current field, emitted now (the returned copy carries the emission time).
  GaussianPulse add_pulse(GaussianPulse pulse);
  /// @{ The state between steps for a checkpoint (mps/io/io.hpp write_checkpoint): the fields, clock and pulses.
  /// restore_state() takes it back into a solver made with the same configuration; a run continued from it repeats
  /// the uninterrupted one bitwise. Throws std::runtime_error naming what does not fit.
  [[nodiscard]] nlohmann::json save_state() const;
  void restore_state(const nlohmann::json& state);
  /// @}

  /// One RK4 step and the boundary update. Throws SimulationError (naming the step, the time, the energy bound
  /// and the CFL against its stability limit) and keeps the previous state if the guard trips.
  void step();

  [[nodiscard]] const AcousticConfig& config() const { return config_; }  ///< the validated configuration
  [[nodiscard]] double time() const { return time_; }  ///< simulated time [s]
  [[nodiscard]] int steps() const { return steps_; }   ///< steps taken
  [[nodiscard]] double dt() const { return dt_; }      ///< the time step [s]
  /// Interior particles (Kind::fluid) come first, the virtual ones outside the box (Kind::dummy) after them.
  [[nodiscard]] const Particles& particles() const { return particles_; }
  [[nodiscard]] std::size_t interior() const { return interior_; }  ///< number of interior particles
  [[nodiscard]] std::vector<double> pressure() const { return component(0); }    ///< dp of all particles [Pa]
  [[nodiscard]] std::vector<double> velocity_x() const { return component(1); }  ///< du_x of all particles [m/s]
  [[nodiscard]] std::vector<double> velocity_y() const { return component(2); }  ///< du_y of all particles [m/s]
  [[nodiscard]] double energy() const;        ///< interior only, see the header comment
  [[nodiscard]] double energy_bound() const;  ///< the guard's limit
  [[nodiscard]] double injected_energy() const { return injected_energy_; }  ///< sum of the pulses' own energies
  [[nodiscard]] const std::vector<GaussianPulse>& pulses() const { return pulses_; }  ///< as add_pulse returned them
  /// interior rows x all columns: grad phi = (x phi, y phi), div(u, v) = x u + y v
  [[nodiscard]] const GradientMatrices& gradient() const { return grad_; }
  /// The largest CFL at which RK4 is stable for this operator on the interior lattice: von Neumann analysis of
  /// the coefficients of the particle nearest the box centre, max over wavenumbers of
  /// |u0 . G(k)| + c0 |G(k)| against RK4's imaginary-axis limit 2 sqrt(2).
  [[nodiscard]] double stable_cfl_estimate() const;

 private:
  [[nodiscard]] std::vector<double> component(int c) const;
  void fill_mirror(std::vector<double>& state) const;
  void rk4_stage(std::vector<double>& in, std::vector<double>& out, double weight, double to_next, bool first, bool last,
                 double stage_offset);
  void apply_mur(const std::vector<double>& old_state, std::vector<double>& new_state, double tau) const;
  [[nodiscard]] double energy_of(const std::vector<double>& state) const;

  AcousticConfig config_;
  double dt_ = 0, time_ = 0;
  int steps_ = 0;
  Particles particles_;
  std::size_t interior_ = 0;
  GradientMatrices grad_;
  // Virtual particles (index interior_ + g): the interior particle they mirror with the velocity signs, and for
  // Mur the particle one spacing inward with its coefficient, listed so that inward ones come first.
  std::vector<int> mirror_source_;
  std::vector<double> mirror_sign_u_, mirror_sign_v_;
  std::vector<int> mur_order_, mur_inward_;
  std::vector<double> mur_speed_, mur_spacing_;
  std::vector<double> state_;  // interleaved (dp, du, dv) per particle: one gather per neighbour
  std::vector<double> stage_, next_, sum_;  // RK4 stage inputs and the running sum of the stages' derivatives
  std::vector<GaussianPulse> pulses_;
  double sqrt_energy_sum_ = 0;  // sum_k sqrt(E_k) over the injected pulses
  double injected_energy_ = 0;  // sum_k E_k
};

}  // namespace mps
