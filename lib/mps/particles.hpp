#pragma once
/// \file
/// Particle state as structure-of-arrays: every per-particle quantity is one contiguous vector, so the
/// numerics are plain loops over indices and a reorder is one permutation applied to each vector.
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

/// Everything SparseMPS offers: particles, neighbours, kernels, operators, the PPE, solvers, the step, output.
namespace mps {

inline constexpr int kDim = 2;  ///< spatial dimension (2-D only so far)

/// What a particle is; operators and the PPE treat each kind differently.
enum class Kind : std::uint8_t {
  fluid = 0,  ///< the liquid
  wall = 1,   ///< first boundary layer: a PPE unknown
  dummy = 2,  ///< outer boundary layers: fill the kernel support, pressure set from the wall after the solve
  ghost = 3,  ///< inactive (recycled at inlets/outlets); invisible to every operator
};
std::string_view to_string(Kind kind);  ///< "fluid", "wall", "dummy" or "ghost"

/// Every particle's state, one vector per quantity, all of length size().
struct Particles {
  /// @{ position [m]
  std::vector<double> x, y;  /// @}
  /// @{ velocity [m/s]
  std::vector<double> u, v;  /// @}
  std::vector<double> p;     ///< pressure (also the warm start of the next solve)
  std::vector<Kind> kind;    ///< fluid, wall, dummy or ghost
  std::vector<int> group;    ///< user tag, e.g. which wall moves with which rigid motion
  std::vector<int> id;       ///< index at creation: follows the particle through reorderings

  [[nodiscard]] std::size_t size() const { return x.size(); }  ///< number of particles, ghosts included
  [[nodiscard]] bool empty() const { return x.empty(); }       ///< no particles at all
  /// Appends a particle at (px, py) with velocity (pu, pv), pressure 0 and the next id.
  void add(double px, double py, Kind k, int grp = 0, double pu = 0.0, double pv = 0.0);
  void reserve(std::size_t n);                   ///< reserves room for n particles in every array
  [[nodiscard]] std::size_t count(Kind k) const;  ///< particles of kind k
  /// Applies new[i] = old[order[i]] to every array; order must be a permutation of 0..size()-1.
  void permute(std::span<const int> order);
};

}  // namespace mps
