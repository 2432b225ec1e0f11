#pragma once
/// \file
/// Elastic solids in 2-D plane strain, total-Lagrangian (seed 003 §2.2; docs/structures.md).
///
/// Neighbours, weights and gradients are taken once in the reference configuration X, so the deformation gradient is a
/// constant sparse operator applied to the current displacement u = x - X,
///   F_i = I + (Gx u_x, Gy u_x ; Gx u_y, Gy u_y)_i,
/// G the gradient of a weighted least-squares quadratic fit over the reference neighbours (exact for quadratic fields,
/// so bending is exact up to the free surfaces). The stress divergence is the same operator transposed: with the strain
/// energy E = sum_i V_i psi(F_i) over the moving particles, the force f = -dE/dx = -(Gx^T (V P_.x) + Gy^T (V P_.y)),
/// P the first Piola-Kirchhoff stress. Momentum is conserved pair by pair and velocity Verlet conserves energy to
/// O(dt^2) (no artificial stress: the reference kernel never changes, so there is no tensile instability to cure).
///
/// Zero-energy modes: F_i averages over a kernel, so a zigzag of particles that leaves every F_i unchanged costs no
/// strain energy; at a clamp such modes open a hinge (the plate's period came out 1.4-2x too long). The hourglass
/// energy E_hg = 1/2 sum_i sum_j c_ij |delta_ij|^2 penalises what the quadratic fit at i does not explain of each
/// pair's relative displacement, c_ij = alpha mu V_i V_j W_ij / (sum_k V_k W_ik |X_ij|^2). It is zero for every
/// quadratic displacement (rigid motions included), so it does not stiffen bending; c_ij is proportional to the fit's
/// own weights, so the fit's normal equations cancel everything in its exact gradient but the pair terms
/// f_k = sum_i c_ik delta_ik - sum_j c_kj delta_kj, on the same sparse pattern.
#include <array>
#include <cstddef>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "mps/boundaries/boundary.hpp"  // SimulationError
#include "mps/core/csr.hpp"
#include "mps/numerics/operators.hpp"  // GradientMatrices

namespace mps {

/// The material law.
enum class ElasticModel {
  linear,                 ///< small strain: eps = sym(F) - I, P = sigma(eps); rotates with spurious stress
  saint_venant_kirchhoff, ///< E = (F^T F - I)/2, S = lambda tr(E) I + 2 mu E, P = F S: exact under rigid rotation
};
ElasticModel parse_elastic_model(std::string_view name);  ///< "linear" | "svk"
std::string_view to_string(ElasticModel model);  ///< the name parse_elastic_model reads

/// An isotropic elastic material.
struct ElasticMaterial {
  double density = 1000.0;        ///< rho [kg/m^3]
  double youngs_modulus = 2e6;    ///< E [Pa]
  double poisson_ratio = 0.3975;  ///< nu, in (-1, 0.5)
  ElasticModel model = ElasticModel::saint_venant_kirchhoff;  ///< the material law

  [[nodiscard]] double lame_lambda() const;  ///< E nu / ((1 + nu)(1 - 2 nu)), the 3-D value (plane strain)
  [[nodiscard]] double shear_modulus() const;  ///< mu = E / (2 (1 + nu))
  [[nodiscard]] double bulk_modulus() const;   ///< K = E / (3 (1 - 2 nu)), the 3-D value
  [[nodiscard]] double p_wave_speed() const;   ///< sqrt((lambda + 2 mu) / rho): sets the time step
  void validate() const;  ///< throws std::invalid_argument naming the value and its range
};

/// Plane-strain constitutive law at one particle: F = (fxx, fxy; fyx, fyy) -> P and the energy density psi [J/m^3].
struct StressResult {
  std::array<double, 4> p{};  ///< pxx, pxy, pyx, pyy
  double energy_density = 0;  ///< psi [J/m^3]
};
/// P and psi at deformation gradient f for `material`.
StressResult first_piola_stress(const std::array<double, 4>& f, const ElasticMaterial& material);
/// Same, from the Lame constants lambda and mu [Pa].
StressResult first_piola_stress(const std::array<double, 4>& f, double lambda, double mu, ElasticModel model);

/// The gradient and second derivatives of a field from a weighted least-squares fit of a quadratic through each
/// particle's reference neighbours within `radius`: rows are particles 0..rows-1 (the moving ones), columns all
/// particles; each row holds the coefficient of phi_j off the diagonal and minus their sum on it, so
/// (gradient.x phi)_i = sum_j a_ij (phi_j - phi_i), exact for every quadratic field (a bent plate's strain is exact up
/// to its free surfaces, where a kernel-corrected gradient only fits a plane and loses 8 % of the surface strain at ten
/// particles across). The weights are V_j W(r_ij) / r_ij^2 (Wendland C2, support `radius`); `weight` holds them per
/// entry normalised by sum_j V_j W(r_ij), 0 on the diagonal. Throws std::invalid_argument naming the particle whose
/// neighbourhood cannot fix a quadratic (too few neighbours or too one-sided).
struct ReferenceFit {
  GradientMatrices gradient;  ///< d/dx and d/dy
  /// @{ d2/dx2, d2/dxdy, d2/dy2 on the same pattern
  CsrMatrix hxx, hxy, hyy;  /// @}
  std::vector<double> weight;  ///< per entry of the pattern
};
/// The fit (see ReferenceFit) over particles at reference positions (x, y) with volumes `volume`.
ReferenceFit quadratic_reference_fit(std::span<const double> x, std::span<const double> y,
                                    std::span<const double> volume, std::size_t rows, double radius);

/// Transposes a CSR matrix (rows and columns swap), columns sorted in each row; `source_entry`, if given, receives
/// for each entry of the result the index of the entry of `a` it came from.
CsrMatrix transpose(const CsrMatrix& a, std::vector<int>* source_entry = nullptr);

/// A body to simulate: reference positions, each particle's volume, and which particles are clamped (held at their
/// reference position; they complete the kernel of their moving neighbours, so a clamp is a band of such particles
/// at least one kernel radius deep beyond the clamped edge).
struct ElasticBody {
  /// @{ reference position [m]
  std::vector<double> x, y;  /// @}
  std::vector<double> volume;  ///< [m^2] (per unit depth)
  std::vector<char> clamped;   ///< non-zero: held at its reference position
  double spacing = 0;  ///< the lattice spacing the body was built with (sets the kernel radius and the time step)

  [[nodiscard]] std::size_t size() const { return x.size(); }  ///< number of particles
  /// Appends a particle at (px, py) of volume v.
  void add(double px, double py, double v, bool is_clamped) {
    x.push_back(px);
    y.push_back(py);
    volume.push_back(v);
    clamped.push_back(is_clamped ? 1 : 0);
  }
};

/// A rectangular body's lattice: `nx` by `ny` cells of `spacing` from the corner (x0, y0). Bodies are laid row by row
/// (y outermost), each row from low x to high x, the order scene files lay them in.
struct BodyLattice {
  /// @{ the corner [m]
  double x0 = 0, y0 = 0;  /// @}
  /// @{ cells along x and y
  int nx = 0, ny = 0;  /// @}
  double spacing = 0;  ///< [m]
};
/// The lattice held at its face `clamp` (one of Face's x_low, x_high, y_low, y_high, mps/boundaries/geometry.hpp): the
/// lattice continued `layers` spacings beyond that face, those points clamped (at least the kernel radius deep).
/// Throws std::invalid_argument for an empty lattice, a spacing that is not positive, another face or no layer.
ElasticBody clamped_box_body(const BodyLattice& lattice, unsigned clamp, int layers);
/// The lattice held in a cylinder (centre (cx, cy), `radius`) its x_low face rests against, as Turek & Hron's flag:
/// each row continued from that face into the cylinder. A point outside the cylinder moves, one inside it within
/// `layers` spacings of its surface (along x) is clamped, a deeper one is left out, so the body is held along the arc
/// it meets and free above and below. Throws std::invalid_argument for a row that misses the cylinder.
ElasticBody cylinder_clamped_box_body(const BodyLattice& lattice, double cx, double cy, double radius, int layers);
/// The first bending mode of a clamped-free beam of `length`, f(s) / f(length) at the distance s from the clamp
/// (f(s) = (cos kL + cosh kL)(cosh ks - cos ks) + (sin kL - sinh kL)(sinh ks - sin ks), kL = 1.8751); 0 for s <= 0.
/// A velocity v(s) = v_tip mode(s) sets the body swinging in that mode (Gray, Monaghan & Swift 2001).
double cantilever_first_mode(double s, double length);

/// How an elastic solid is modelled and stepped.
struct ElasticConfig {
  ElasticMaterial material;  ///< the material
  double radius = 3.0;  ///< kernel support in spacings
  double hourglass = 30.0;  ///< alpha of the hourglass energy (0: off); docs/structures.md measures what it changes
  double cfl = 0.3;     ///< c_p dt / spacing
  /// @{ gravity [m/s^2]
  double gravity_x = 0.0, gravity_y = 0.0;  /// @}
  /// Guard: stop when the total energy (kinetic + strain + gravity) has moved from its start by more than this
  /// fraction of the largest kinetic + strain energy seen, or any particle moved more than half a spacing in one step.
  double guard_energy_fraction = 0.25;
  /// The host program's option for `cfl`, named in the guard's advice (e.g. --solid-cfl; empty: "the CFL").
  std::string cfl_option;
  void validate() const;  ///< throws std::invalid_argument naming the value and what to change
};

/// An elastic solid's energies.
struct ElasticEnergy {
  /// @{ kinetic, strain, hourglass and gravitational energy [J per unit depth], gravity's from the reference position
  double kinetic = 0, strain = 0, hourglass = 0, gravity = 0;  /// @}
  [[nodiscard]] double total() const { return kinetic + strain + hourglass + gravity; }  ///< their sum
};

/// An elastic body stepped on its own (ElasticStructure couples one to a fluid).
class ElasticSolid {
 public:
  /// Validates the configuration and builds the reference fit (throws std::invalid_argument naming what is wrong).
  /// Moving particles are reordered first and clamped ones after them; id() maps back to the body's order.
  ElasticSolid(const ElasticBody& body, const ElasticConfig& config);

  /// Velocity Verlet. Throws SimulationError (naming the step, the time, the energies and what to change) and keeps
  /// the previous state if the guard trips.
  void step();
  /// Advances by `duration` in equal steps no longer than dt() (a host's step split into the solid's own); returns
  /// how many. Throws SimulationError as step() does.
  int advance(double duration);
  void set_velocity(std::span<const double> u, std::span<const double> v);  ///< every particle, in this solid's order
  /// Moves the moving particles (clamped ones stay), re-evaluates F, P and the forces, and takes the energy there as
  /// the guard's new reference.
  void set_positions(std::span<const double> x, std::span<const double> y);
  /// A force on each particle [N per unit depth] from outside the body (a fluid's pressure), held until set again;
  /// clamped particles ignore theirs. Its work is counted in external_work(), and the guard watches
  /// total energy - external work.
  void set_external_force(std::span<const double> fx, std::span<const double> fy);
  [[nodiscard]] double external_work() const { return external_work_; }  ///< [J per unit depth] since the start

  [[nodiscard]] double time() const { return time_; }  ///< simulated time [s]
  [[nodiscard]] int steps() const { return steps_; }   ///< steps taken
  [[nodiscard]] double dt() const { return dt_; }      ///< the time step, cfl spacing / c_p [s]
  [[nodiscard]] std::size_t size() const { return x_.size(); }    ///< all particles
  [[nodiscard]] std::size_t moving() const { return moving_; }    ///< the moving ones, indices 0..moving()-1
  [[nodiscard]] const std::vector<int>& id() const { return id_; }  ///< body index of each particle
  /// @{ current position [m]
  [[nodiscard]] std::span<const double> x() const { return x_; }
  [[nodiscard]] std::span<const double> y() const { return y_; }
  /// @}
  /// @{ reference position [m]
  [[nodiscard]] std::span<const double> reference_x() const { return x0_; }
  [[nodiscard]] std::span<const double> reference_y() const { return y0_; }
  /// @}
  /// @{ velocity [m/s]
  [[nodiscard]] std::span<const double> u() const { return u_; }
  [[nodiscard]] std::span<const double> v() const { return v_; }
  /// @}
  /// @{ acceleration: forces / mass + gravity [m/s^2]
  [[nodiscard]] std::span<const double> acceleration_x() const { return ax_; }
  [[nodiscard]] std::span<const double> acceleration_y() const { return ay_; }
  /// @}
  [[nodiscard]] const ElasticEnergy& energy() const { return energy_; }  ///< the energies now
  [[nodiscard]] const ElasticConfig& config() const { return config_; }  ///< the validated configuration
  /// The largest CFL velocity Verlet is stable at for this body: 2 / (omega_max dt/CFL), omega_max the highest
  /// frequency of the linearised body (hourglass springs included), by power iteration at the reference configuration.
  [[nodiscard]] double stable_cfl() const { return stable_cfl_; }
  /// @{ Per moving particle: F and P (xx, xy, yx, yy) of the last force evaluation.
  [[nodiscard]] const std::array<std::vector<double>, 4>& deformation_gradient() const { return f_; }
  [[nodiscard]] const std::array<std::vector<double>, 4>& stress() const { return p_; }
  /// @}
  /// The force each clamped particle exerts on the body is minus this (the clamp's reaction) [N per unit depth].
  [[nodiscard]] std::array<double, 2> clamp_reaction() const;
  [[nodiscard]] const ReferenceFit& fit() const { return fit_; }  ///< moving rows x all columns
  /// The displacement at a reference point, by a kernel-weighted linear least-squares fit over the reference
  /// neighbours within the kernel radius (exact for a linear displacement field).
  [[nodiscard]] std::array<double, 2> displacement_at(double px, double py) const;
  /// @{ The state between steps for a checkpoint: positions, velocities, accelerations, the last evaluation's F and
  /// P, the energies, the external force and the clock. restore_state() takes it back into a solid built from the same
  /// body and configuration; the steps that follow repeat the uninterrupted run's bitwise.
  [[nodiscard]] nlohmann::json save_state() const;
  void restore_state(const nlohmann::json& state);
  /// @}

 private:
  void evaluate_forces();  // F, P, strain energy and acceleration at the current positions
  [[nodiscard]] ElasticEnergy measure_energy() const;

  ElasticConfig config_;
  double spacing_ = 0, dt_ = 0, time_ = 0;
  int steps_ = 0;
  std::size_t moving_ = 0;
  std::vector<int> id_;
  std::vector<double> x0_, y0_, volume_, mass_;
  std::vector<double> x_, y_, u_, v_, ax_, ay_;
  ReferenceFit fit_;
  GradientMatrices grad_t_;
  std::array<std::vector<double>, 4> f_, p_;
  std::array<std::vector<double>, 4> vp_;  // V_i P_i, the transposed product's input
  std::vector<double> fx_, fy_;            // elastic force on every particle
  // Hourglass control, per entry of the fit's pattern: c_ij, and c_ij delta_ij of the last evaluation; the
  // position in that pattern of each entry of the transposed one; per moving particle sum_j c_ij delta_ij.
  std::vector<double> hg_coef_, hg_xy_, hg_own_x_, hg_own_y_;  // hg_xy_: x and y interleaved
  std::vector<double> pair_dx_, pair_dy_;  // X_j - X_i per entry
  std::vector<double> disp_x_, disp_y_;    // u = x - X of the evaluation in progress
  std::vector<int> transposed_entry_;
  // Strain energy per moving particle and hourglass energy per entry, summed in order afterwards (the order of one
  // thread): a threaded reduction's sum depended on the thread count.
  std::vector<double> strain_of_, hourglass_of_;
  double hourglass_energy_ = 0;
  std::array<std::vector<double>, 6> saved_;  // x, y, u, v, ax, ay before the step in progress
  double strain_energy_ = 0;
  ElasticEnergy energy_;
  double start_energy_ = 0, largest_mechanical_ = 0, stable_cfl_ = 0;
  std::vector<double> external_x_, external_y_;  // empty: no external force
  double external_work_ = 0;
};

}  // namespace mps
