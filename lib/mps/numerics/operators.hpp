#pragma once
/// \file
/// The MPS particle operators (design §3), each as a loop over neighbour pairs and as a CSR matrix that
/// gives the same numbers. Sums run over every active neighbour (fluid, wall and dummy alike).
#include <array>
#include <span>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "mps/core/csr.hpp"
#include "mps/core/kernel.hpp"
#include "mps/core/neighbors.hpp"
#include "mps/core/particles.hpp"

namespace mps {

/// What one operator application needs: where the particles are, who neighbours whom, and the weight.
/// The neighbour list's radius may exceed the kernel's; pairs beyond kernel.re weigh zero. Every operator below takes
/// a stencil of dimension D (2 or 3; a braced stencil of 2-D particles is 2-D) and carries d = D in its factors.
template <int D>
struct BasicStencil {
  const BasicParticles<D>& particles;  ///< positions (and kinds: ghosts are skipped)
  const BasicDomain<D>& domain;        ///< for the minimum image on periodic axes
  const NeighborList& neighbors;       ///< pairs to sum over
  const Kernel& kernel;                ///< the weight, n0 and lambda
};
using Stencil = BasicStencil<2>;   ///< a 2-D stencil
using Stencil3 = BasicStencil<3>;  ///< a 3-D stencil

/// D spans, one per axis: a vector field's components.
template <int D>
using Components = std::type_identity_t<std::array<std::span<double>, D>>;
/// Same, read-only.
template <int D>
using ConstComponents = std::type_identity_t<std::array<std::span<const double>, D>>;

/// n_i = sum_j w_ij
template <int D = 2>
std::vector<double> number_density(const BasicStencil<D>& s);
/// Same, reusing out's memory. `rows`, if given: only particles i with rows[i] != 0 are summed, the others get 0 (the
/// step sums the fluid and walls only: dummies and ghosts hold no PPE row).
template <int D = 2>
void number_density(const BasicStencil<D>& s, std::vector<double>& out, std::span<const char> rows = {});

/// |sum_j w_ij r_ij / |r_ij|| / n0: how one-sided particle i's neighbours lie (Khayyer et al. 2009); 0 inside a full
/// kernel, asymmetry_of_flat_surface(kernel) in the top row of a lattice.
/// `rows`, if given: only particles i with rows[i] != 0 are summed, the others get 0.
template <int D = 2>
void neighbour_asymmetry(const BasicStencil<D>& s, std::vector<double>& out, std::span<const char> rows = {});
/// The value neighbour_asymmetry takes in the top layer of a perfect lattice of spacing l0 (a flat free surface), on
/// the kernel's own lattice (kernel.dim).
double asymmetry_of_flat_surface(const Kernel& kernel, double l0);

/// The discrete gradient's form; the pressure gradient's choice is SimulationConfig::pressure_gradient.
enum class GradientVariant {
  plain,          ///< (d/n0) sum (phi_j - phi_i) r_ij/|r_ij|^2 w_ij
  min_reference,  ///< phi_i replaced by the minimum over i and its neighbours (Koshizuka 1998): keeps the
                  ///< pressure gradient repulsive, which suppresses particle clustering
  corrected,      ///< plain, multiplied by the corrective matrix [(d/n0) sum w r_ij r_ij^T/|r_ij|^2]^-1
                  ///< (Randles & Libersky 1996; Khayyer & Gotoh 2011): exact for linear fields with any
                  ///< neighbourhood, truncated ones at free surfaces and walls included
  corrected_min_reference,  ///< the corrective matrix applied to the min_reference sum
  conservative,   ///< (d/n0) sum (phi_i + phi_j) r_ij/|r_ij|^2 w_ij: each pair's term is antisymmetric, so the
                  ///< momentum two particles exchange sums to zero (a structure feels the exact reaction of the
                  ///< fluid's push); exact for linear fields on a full lattice only, the price of that symmetry
};
/// "plain", "min-reference", "corrected", "corrected-min-reference", "conservative"; the parser throws
/// std::invalid_argument naming the valid names.
std::string_view to_string(GradientVariant variant);
GradientVariant gradient_variant_from_name(std::string_view name);  ///< the inverse of to_string
/// `carriers`, if given, limits the sum (and the corrective matrix) to neighbours j with carriers[j] != 0:
/// the particles that hold a value of phi at all (for pressure: not dry walls, see set_dummy_pressure).
/// `min_tilt` (the min-reference variants): the minimum is taken of phi_j - min_tilt . r_ij, i.e. of phi less a
/// known linear part. For pressure under a body force f pass rho f, so that the hydrostatic drop across the kernel
/// is no dip (docs/numerics.md).
/// `own_reference` (the min-reference variants), if given: particles i with own_reference[i] != 0 take phi_i itself as
/// the reference instead of the minimum over their neighbours (for pressure: free-surface particles, whose phi is
/// imposed; see the HydrostaticSplit component).
/// `rows`, if given: only particles i with rows[i] != 0 get their gradient; the others' entries of g are left as they
/// are (the step needs the fluid's only, a fifth of the particles in the 3-D dam break at 5 cm).
template <int D = 2>
void gradient(const BasicStencil<D>& s, std::span<const double> phi, const Components<D>& g,
              GradientVariant variant = GradientVariant::plain, std::span<const char> carriers = {},
              const std::type_identity_t<Vec<D>>& min_tilt = {}, std::span<const char> own_reference = {},
              std::span<const char> rows = {});
/// 2-D: the same with the components as gx, gy.
inline void gradient(const Stencil& s, std::span<const double> phi, std::span<double> gx, std::span<double> gy,
                     GradientVariant variant = GradientVariant::plain, std::span<const char> carriers = {},
                     std::array<double, 2> min_tilt = {0.0, 0.0}, std::span<const char> own_reference = {}) {
  gradient<2>(s, phi, {gx, gy}, variant, carriers, min_tilt, own_reference);
}

/// What the particles j with targets[j] give the conservative gradient of their neighbours i with sources[i], pair by
/// pair: out_j = sum_i (d/n0) (phi_i + phi_j) r_ij/|r_ij|^2 w_ij with r_ij = r_j - r_i, the very terms of i's gradient
/// (j counted only if carriers[j], as there). A force -V grad phi on the sources is so met by +V out on the targets.
template <int D = 2>
void conservative_gradient_terms(const BasicStencil<D>& s, std::span<const double> phi, std::span<const char> sources,
                                 std::span<const char> targets, std::span<const char> carriers,
                                 const Components<D>& out);
/// 2-D: the same with the components as ox, oy.
inline void conservative_gradient_terms(const Stencil& s, std::span<const double> phi, std::span<const char> sources,
                                        std::span<const char> targets, std::span<const char> carriers,
                                        std::span<double> ox, std::span<double> oy) {
  conservative_gradient_terms<2>(s, phi, sources, targets, carriers, {ox, oy});
}

/// (d/n0) sum (u_j - u_i) . r_ij/|r_ij|^2 w_ij; `rows`, if given: only particles i with rows[i] != 0, the others'
/// entries of out left as they are.
template <int D = 2>
void divergence(const BasicStencil<D>& s, const ConstComponents<D>& u, std::span<double> out,
                std::span<const char> rows = {});
/// 2-D: the same for the field (u, v).
inline void divergence(const Stencil& s, std::span<const double> u, std::span<const double> v, std::span<double> out) {
  divergence<2>(s, {u, v}, out);
}

/// Dn/Dt = sum w'(r_ij) (r_ij . u_ij)/r_ij, r_ij = r_j - r_i, u_ij = u_j - u_i: the exact rate of change of the number
/// density when the particles move with u (Khayyer & Gotoh 2009's higher-order source). -(d/kernel.n_rate) Dn/Dt is a
/// divergence of u, exact for linear fields on the perfect lattice and zero for any rigid motion.
template <int D = 2>
void number_density_rate(const BasicStencil<D>& s, const ConstComponents<D>& u, std::span<double> out);
/// number_density and number_density_rate in one pass over the pairs, each pair's distance taken once: the same
/// numbers, bitwise, as the two calls (the higher-order source needs both of the same stencil). `rows`, if given:
/// only particles i with rows[i] != 0 are summed, the others get n = 0 and their entries of rate are left as they are.
template <int D = 2>
void number_density_and_rate(const BasicStencil<D>& s, const ConstComponents<D>& u, std::vector<double>& n,
                             std::span<double> rate, std::span<const char> rows = {});

/// (2d/(lambda n0)) sum (phi_j - phi_i) w_ij; with kernel.higher_order_laplacian, (2d/n_higher_order) sum
/// (phi_j - phi_i) f(r_ij) (Kernel::higher_order_weight)
template <int D = 2>
void laplacian(const BasicStencil<D>& s, std::span<const double> phi, std::span<double> out);
/// Every component of a vector field in one pass over the pairs (the viscous term): the same numbers as a call
/// per component, at a fraction of the distance and kernel evaluations. `rows`, if given: only particles i with
/// rows[i] != 0 are computed, the others' entries of out left as they are.
template <int D = 2>
void laplacian(const BasicStencil<D>& s, const ConstComponents<D>& u, const Components<D>& out,
               std::span<const char> rows = {});
/// 2-D: the same for the field (u, v).
inline void laplacian(const Stencil& s, std::span<const double> u, std::span<const double> v, std::span<double> lu,
                      std::span<double> lv) {
  laplacian<2>(s, ConstComponents<2>{u, v}, Components<2>{lu, lv});
}

/// The Laplacian as a matrix L with L phi = laplacian(s, phi) (row sums zero).
template <int D = 2>
CsrMatrix laplacian_matrix(const BasicStencil<D>& s);

/// grad phi = (x * phi, y * phi) and div(u, v) = x * u + y * v: the divergence uses the same two matrices.
struct GradientMatrices {
  /// @{ the x and y components of the plain gradient
  CsrMatrix x, y;  /// @}
};
GradientMatrices gradient_matrices(const Stencil& s);  ///< the plain gradient's matrices (GradientVariant::plain), 2-D

/// Particle shifting (after Lind et al. 2012, in MPS form): particle i moves down the gradient of the particle
/// concentration, dr_i = -diffusion (d/n0) sum_j r_ij/|r_ij|^2 w_ij, capped at max_shift, which evens out a lattice
/// that the flow has drawn apart or bunched up; its velocity is carried to the new position by the first-order
/// Taylor term, u_i += dr_i . grad u_i (corrected gradient: exact for linear fields), so a smooth flow is not
/// diffused by the move. Every neighbour counts towards the concentration (walls and dummies keep fluid off the
/// wall); only particles with movable[i] != 0 move. Where (normal_x[i], normal_y[i]) is a non-zero unit vector (a free
/// surface's normal at i) the shift keeps only its part along the surface (Lind et al. 2012), so a surface is evened
/// out without being moved off itself. Returns the largest shift.
template <int D = 2>
double shift_particles(const BasicStencil<D>& s, double diffusion, double max_shift, std::span<const char> movable,
                       BasicParticles<D>& particles, const ConstComponents<D>& normal = {});
/// 2-D: the same with the normals as normal_x, normal_y.
inline double shift_particles(const Stencil& s, double diffusion, double max_shift, std::span<const char> movable,
                              Particles& particles, std::span<const double> normal_x,
                              std::span<const double> normal_y = {}) {
  return shift_particles<2>(s, diffusion, max_shift, movable, particles, {normal_x, normal_y});
}

/// The outward unit normal of a free surface at each particle with want[i] != 0 (for shifting, take a kernel wider than
/// the shift's, or the normal is the shift's own direction): minus the direction of
/// sum_j r_ij/|r_ij|^2 w_ij over all neighbours (walls fill the kernel on their side, so it points away from the
/// liquid and the walls), 0 where that sum is round-off (a full kernel) or want[i] == 0.
template <int D = 2>
void surface_normals(const BasicStencil<D>& s, std::span<const char> want, std::type_identity_t<std::array<std::vector<double>, D>>& normal);
/// 2-D: the same with the components as nx, ny.
inline void surface_normals(const Stencil& s, std::span<const char> want, std::vector<double>& nx,
                            std::vector<double>& ny) {
  std::array<std::vector<double>, 2> normal{std::move(nx), std::move(ny)};
  surface_normals<2>(s, want, normal);
  nx = std::move(normal[0]);
  ny = std::move(normal[1]);
}

/// Collisions of close pairs (Koshizuka et al. 1998): a fluid particle i with movable[i] != 0 and a neighbour j nearer
/// than `reach` that approach each other lose their approach speed along r_ij down to `restitution` of it. Between
/// two movable fluid particles the impulse is shared (momentum conserved); a wall, dummy or unmovable fluid particle is
/// fixed and the movable one takes all of it. Writes each particle's velocity change from the velocities as
/// they are, so the result does not depend on the particles' order; the caller applies it. Returns the pairs found.
template <int D = 2>
long collision_velocity_changes(const BasicParticles<D>& particles, const BasicDomain<D>& domain,
                                const NeighborList& neighbors, double reach, double restitution,
                                std::span<const char> movable, std::type_identity_t<std::array<std::vector<double>, D>>& change);
/// Dynamic stabilisation (after Tsuruta, Khayyer & Gotoh 2013): a movable fluid particle i and a neighbour j nearer
/// than `reach` are pushed apart at (reach - r)/dt along r_ij, shared as collisions share, so that the corrector's move
/// puts the pair back at `reach` whether or not it is closing in. Momentum is conserved between movable particles.
/// Writes each particle's velocity change from the positions as they are; the caller applies it. Returns the pairs.
template <int D = 2>
long stabilisation_velocity_changes(const BasicParticles<D>& particles, const BasicDomain<D>& domain,
                                    const NeighborList& neighbors, double reach, double dt, std::span<const char> movable,
                                    std::type_identity_t<std::array<std::vector<double>, D>>& change);
/// 2-D: the same with the changes as du, dv.
inline long collision_velocity_changes(const Particles& particles, const Domain& domain, const NeighborList& neighbors,
                                       double reach, double restitution, std::span<const char> movable,
                                       std::vector<double>& du, std::vector<double>& dv) {
  std::array<std::vector<double>, 2> change{std::move(du), std::move(dv)};
  const long pairs = collision_velocity_changes<2>(particles, domain, neighbors, reach, restitution, movable, change);
  du = std::move(change[0]);
  dv = std::move(change[1]);
  return pairs;
}

}  // namespace mps
