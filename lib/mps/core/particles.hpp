#pragma once
/// \file
/// Particle state as structure-of-arrays: every per-particle quantity is one contiguous vector, so the
/// numerics are plain loops over indices and a reorder is one permutation applied to each vector. The dimension D
/// (2 or 3) is a compile-time parameter: a 2-D set holds x, y and u, v, a 3-D one also z and w, never a wasted axis.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "mps/core/vec.hpp"

/// Everything SparseMPS offers: particles, neighbours, kernels, operators, the PPE, solvers, the step, output.
namespace mps {

/// What a particle is; operators and the PPE treat each kind differently.
enum class Kind : std::uint8_t {
  fluid = 0,  ///< the liquid
  wall = 1,   ///< first boundary layer: a PPE unknown
  dummy = 2,  ///< outer boundary layers: fill the kernel support, pressure set from the wall after the solve
  ghost = 3,  ///< inactive (recycled at inlets/outlets); invisible to every operator
};
std::string_view to_string(Kind kind);  ///< "fluid", "wall", "dummy" or "ghost"

/// The positions and velocities of D-dimensional particles, by axis (specialised for D = 2 and 3).
template <int D>
struct Coordinates;

/// 2-D positions (x, y) and velocities (u, v).
template <>
struct Coordinates<2> {
  /// @{ position [m]
  std::vector<double> x, y;  /// @}
  /// @{ velocity [m/s]
  std::vector<double> u, v;  /// @}
  /// The position components by axis, and the velocity's.
  [[nodiscard]] std::array<std::vector<double>*, 2> positions() { return {&x, &y}; }
  [[nodiscard]] std::array<const std::vector<double>*, 2> positions() const { return {&x, &y}; }  ///< same
  [[nodiscard]] std::array<std::vector<double>*, 2> velocities() { return {&u, &v}; }  ///< (u, v)
  [[nodiscard]] std::array<const std::vector<double>*, 2> velocities() const { return {&u, &v}; }  ///< same
};

/// 3-D positions (x, y, z) and velocities (u, v, w).
template <>
struct Coordinates<3> {
  /// @{ position [m]
  std::vector<double> x, y, z;  /// @}
  /// @{ velocity [m/s]
  std::vector<double> u, v, w;  /// @}
  /// The position components by axis, and the velocity's.
  [[nodiscard]] std::array<std::vector<double>*, 3> positions() { return {&x, &y, &z}; }
  [[nodiscard]] std::array<const std::vector<double>*, 3> positions() const { return {&x, &y, &z}; }  ///< same
  [[nodiscard]] std::array<std::vector<double>*, 3> velocities() { return {&u, &v, &w}; }  ///< (u, v, w)
  [[nodiscard]] std::array<const std::vector<double>*, 3> velocities() const { return {&u, &v, &w}; }  ///< same
};

/// Every particle's state, one vector per quantity, all of length size(). for_each_field is the one list of the
/// fields: reserve, permute, the MPI record, frames, particle files and Python all walk it, so a field is added in
/// one place.
template <int D>
struct BasicParticles : Coordinates<D> {
  static constexpr int dim = D;  ///< the dimension
  std::vector<double> p;     ///< pressure (also the warm start of the next solve)
  std::vector<Kind> kind;    ///< fluid, wall, dummy or ghost
  std::vector<int> group;    ///< user tag, e.g. which wall moves with which rigid motion
  std::vector<int> id;       ///< index at creation: follows the particle through reorderings

  [[nodiscard]] std::size_t size() const { return this->x.size(); }  ///< number of particles, ghosts included
  [[nodiscard]] bool empty() const { return this->x.empty(); }       ///< no particles at all
  /// Appends a particle at r with velocity vel, pressure 0 and the next id.
  void add(const Vec<D>& r, Kind k, int grp = 0, const Vec<D>& vel = {});
  /// 2-D: appends a particle at (px, py) with velocity (pu, pv).
  void add(double px, double py, Kind k, int grp = 0, double pu = 0.0, double pv = 0.0)
    requires(D == 2)
  {
    add(Vec<2>{px, py}, k, grp, Vec<2>{pu, pv});
  }
  void reserve(std::size_t n);                   ///< reserves room for n particles in every array
  [[nodiscard]] std::size_t count(Kind k) const;  ///< particles of kind k
  /// Applies new[i] = old[order[i]] to every array; order must be a permutation of 0..size()-1.
  void permute(std::span<const int> order);
  /// Particle i's position, and its velocity.
  [[nodiscard]] Vec<D> position(std::size_t i) const;
  [[nodiscard]] Vec<D> velocity(std::size_t i) const;  ///< particle i's velocity

  /// Calls f(name, vector) for every per-particle vector: the position's and velocity's components ("x", "y", "z";
  /// "u", "v", "w"), then "p", "kind", "group", "id".
  template <class F>
  void for_each_field(F&& f) {
    fields(*this, f);
  }
  /// Same, read-only.
  template <class F>
  void for_each_field(F&& f) const {
    fields(*this, f);
  }

 private:
  template <class Self, class F>
  static void fields(Self& s, F& f) {
    static constexpr const char* position_names[3] = {"x", "y", "z"};
    static constexpr const char* velocity_names[3] = {"u", "v", "w"};
    const auto r = s.positions();
    const auto vel = s.velocities();
    for (int d = 0; d < D; ++d) f(position_names[d], *r[static_cast<std::size_t>(d)]);
    for (int d = 0; d < D; ++d) f(velocity_names[d], *vel[static_cast<std::size_t>(d)]);
    f("p", s.p);
    f("kind", s.kind);
    f("group", s.group);
    f("id", s.id);
  }
};

using Particles = BasicParticles<2>;   ///< 2-D particles
using Particles3 = BasicParticles<3>;  ///< 3-D particles

extern template struct BasicParticles<2>;
extern template struct BasicParticles<3>;

}  // namespace mps
