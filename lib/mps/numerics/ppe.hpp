#pragma once
/// \file
/// Pressure Poisson equation with the mixed source term (seed 004, eq. 4), assembled straight into CSR.
///
/// Unknowns: fluid and wall particles that are not on the free surface. Free-surface fluid particles are
/// Dirichlet P = 0 and eliminated: they add to their neighbours' diagonals only, so the matrix stays
/// symmetric. Dummy particles and dry walls (wall particles flagged free surface, e.g. above the water
/// line) are not unknowns and not in the Laplacian sum: a zero-flux wall.
/// The stored matrix is A = -(discrete Laplacian): symmetric positive definite when every connected
/// group of unknowns touches the free surface, so CG and Cholesky apply.
///
/// Closed domains (a connected group of unknowns with no free-surface neighbour, e.g. a sealed channel)
/// give a singular all-Neumann block whose null space is the constant pressure. For each such group the
/// assembly (1) removes the mean of the right-hand side over the group, the part no pressure field can
/// produce, (2) doubles the diagonal of one member (the lowest-numbered), which fixes that member's
/// pressure to 0 without touching symmetry or the sparsity pattern, and PpeSystem::scatter (3) shifts
/// the group's solution to zero mean. The result is the unique zero-mean solution of the consistent
/// singular system, identical whichever solver produced it.
#include <span>
#include <vector>

#include "mps/core/csr.hpp"
#include "mps/core/particles.hpp"
#include "mps/numerics/operators.hpp"

namespace mps {

/// (1 - gamma) (rho/dt) div u*_i - gamma (rho/dt^2) (n*_i - n0)/n0, the right-hand side of lap P = ...
std::vector<double> mixed_source(std::span<const double> n_star, double n0, std::span<const double> div_u_star,
                                 double rho, double dt, double gamma);
void mixed_source(std::span<const double> n_star, double n0, std::span<const double> div_u_star, double rho,
                  double dt, double gamma, std::vector<double>& out);  ///< same, reusing out's memory

/// Wall particles with n* < beta n0, and fluid particles with n* < beta n0 and fewer than theta N0 neighbours
/// (N0: the perfect lattice's count; theta <= 0 skips the count test). Dummies and ghosts are never flagged. The
/// count keeps the row under the surface from flickering; walls take the density test alone (docs/numerics.md).
template <int D>
std::vector<char> detect_free_surface(const BasicParticles<D>& particles, std::span<const double> n_star, double n0,
                                      double beta, const NeighborList* neighbors = nullptr, int lattice_neighbors = 0,
                                      double theta = 0.0);
template <int D>
void detect_free_surface(const BasicParticles<D>& particles, std::span<const double> n_star, double n0, double beta,
                         const NeighborList* neighbors, int lattice_neighbors, double theta,
                         std::vector<char>& out);  ///< same, reusing out's memory

/// A connected group of unknowns that touches no free surface (a closed domain): its gauge (see the file's notes).
struct FloatingGroup {
  int pinned = -1;              ///< unknown whose diagonal was doubled
  int size = 0;                 ///< unknowns in the group
  double removed_rhs_mean = 0;  ///< mean of b taken out over the group (the inconsistent part)
};

/// The assembled PPE, A x = b over the unknowns, with the maps between unknowns and particles.
struct PpeSystem {
  CsrMatrix matrix;            ///< A = -lap restricted to the unknowns
  std::vector<double> rhs;     ///< b = -source
  std::vector<int> unknown;    ///< particle -> unknown, or -1
  std::vector<int> particle;   ///< unknown -> particle
  std::vector<int> group;      ///< unknown -> index into floating, or -1 when anchored by a free surface
  std::vector<FloatingGroup> floating;  ///< the closed groups, each with its gauge
  /// unknown -> 1 if its row has a free-surface (Dirichlet) neighbour or a shift, which fixes its group's level
  std::vector<char> anchored;
  /// unknown -> 1 for a held row (PpeRows::every_particle): a particle that is not solved for, alone in its row
  /// with its value as the solution
  std::vector<char> held;
  std::size_t held_rows = 0;  ///< how many rows are held

  /// The rows solved for: every row but the held ones.
  [[nodiscard]] std::size_t solved_rows() const { return particle.size() - held_rows; }

  [[nodiscard]] std::size_t size() const { return particle.size(); }  ///< number of rows (held ones included)
  /// Particle pressures of the unknowns, as an initial guess (warm start).
  /// `offset` (per particle, optional): the unknowns are p - offset (see assemble_ppe's `dirichlet`).
  template <int D>
  [[nodiscard]] std::vector<double> gather(const BasicParticles<D>& particles, std::span<const double> offset = {}) const;
  template <int D>
  void gather(const BasicParticles<D>& particles, std::vector<double>& out,
              std::span<const double> offset = {}) const;  ///< same, reusing out's memory
  /// Writes the solution to the particles: unknowns get it (floating groups shifted to zero mean), fluid
  /// and wall particles that are not unknowns get 0; dummies are left for set_dummy_pressure.
  /// clamp_negative sets negative pressures to 0 in groups that touch a free surface: liquid there cannot
  /// hold tension, and letting it (the number-density deficit near a surface asks for suction) is MPS's
  /// tensile instability. Floating groups are never clamped, their level being a gauge.
  /// With `offset` the unknowns solved for are p - offset: each unknown's pressure is solution + offset (the clamp
  /// applying to that sum).
  template <int D>
  void scatter(std::span<const double> solution, BasicParticles<D>& particles, bool clamp_negative = false,
               std::span<const double> offset = {}) const;
};

/// The empty part of each unknown's support (the continuous free surface, ContinuousFreeSurface): its Laplacian
/// weight, taken as neighbours at `value` (per particle; empty: none). It adds to the diagonal and the right-hand side
/// only, so the matrix stays symmetric.
struct OpenSupport {
  std::span<const double> weight;  ///< sum of the Laplacian weight the unknown's support lacks
  std::span<const double> value;   ///< the unknown's value there (P = 0, less any offset)
};

/// What assemble_ppe does with a closed group (one no free surface anchors).
enum class ClosedGroups {
  gauge,  ///< the zero-mean gauge of the file's notes: the system is nonsingular
  leave,  ///< nothing (group and floating stay empty): for a caller that sees only part of a group and gauges
          ///< the whole group itself (mps/parallel/distributed.hpp, where a group spans ranks)
};

/// Which particles get a row of the PPE.
enum class PpeRows {
  unknowns,        ///< the unknowns only (the file's notes)
  every_particle,  ///< every fluid and wall particle: those not solved for (Dirichlet, dry or uncoupled) as held rows,
                   ///< alone in their row with their value as the solution. The numbering then holds from step to
                   ///< step while no particle comes, goes or is reordered, so a solver can keep what it built on it.
};

/// `laplacian` holds the Laplacian kernel and a neighbour list covering its radius; `free_surface` and
/// `source` are per particle.
/// `dirichlet` (per particle, optional): the value a free-surface particle is held at (0 if not given).
/// `shift` (>= 0) is added to every diagonal entry, A = -lap + shift I: a compressibility term (see
/// SimulationConfig::sound_speed). With shift > 0 no group is singular and none gets the gauge.
/// `closed`: whether closed groups get the gauge (the default) or are left singular.
/// `open`: the empty part of each unknown's support (none by default). `rows`: which particles get a row.
template <int D = 2>
PpeSystem assemble_ppe(const BasicStencil<D>& laplacian, std::span<const char> free_surface,
                       std::span<const double> source, std::span<const double> dirichlet = {}, double shift = 0.0,
                       ClosedGroups closed = ClosedGroups::gauge, OpenSupport open = {},
                       PpeRows rows = PpeRows::unknowns);
/// Same, refilling `out` in place (reusing its memory across time steps).
template <int D = 2>
void assemble_ppe(const BasicStencil<D>& laplacian, std::span<const char> free_surface, std::span<const double> source,
                  PpeSystem& out, std::span<const double> dirichlet = {}, double shift = 0.0,
                  ClosedGroups closed = ClosedGroups::gauge, OpenSupport open = {},
                  PpeRows rows = PpeRows::unknowns);

/// Dummy pressure from the nearest wet wall particle (a wall not flagged free surface) within the stencil's radius,
/// carried hydrostatically under body force f: P_wall + rho f.(r_dummy - r_wall); 0 if none is in reach. The pairs
/// are read from the wet walls' rows of the list, so the dummies' own rows may be empty.
/// The nearest wall, not an average: walls at other heights would carry their pressure to the wrong depth.
/// Returns the pressure carriers: fluid particles, wet walls, and dummies that found a wet wall. Dry walls and
/// the dummies behind them hold no pressure and must stay out of the pressure gradient: counted there as
/// P = 0 neighbours, they change a contact-line particle's support from that of the open surface next to it.
template <int D = 2>
std::vector<char> set_dummy_pressure(const BasicStencil<D>& s, BasicParticles<D>& particles,
                                     std::span<const char> free_surface, double rho,
                                     const std::type_identity_t<Vec<D>>& f);
template <int D = 2>
void set_dummy_pressure(const BasicStencil<D>& s, BasicParticles<D>& particles, std::span<const char> free_surface,
                        double rho, const std::type_identity_t<Vec<D>>& f,
                        std::vector<char>& carriers);  ///< same, reusing carriers' memory
/// 2-D: the same with the body force as (fx, fy).
inline std::vector<char> set_dummy_pressure(const Stencil& s, Particles& particles, std::span<const char> free_surface,
                                            double rho, double fx, double fy) {
  return set_dummy_pressure<2>(s, particles, free_surface, rho, Vec<2>{fx, fy});
}
/// 2-D: the same, reusing carriers' memory.
inline void set_dummy_pressure(const Stencil& s, Particles& particles, std::span<const char> free_surface, double rho,
                               double fx, double fy, std::vector<char>& carriers) {
  set_dummy_pressure<2>(s, particles, free_surface, rho, Vec<2>{fx, fy}, carriers);
}

}  // namespace mps
