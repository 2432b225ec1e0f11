#pragma once
// Particle state as structure-of-arrays: every per-particle quantity is one contiguous vector, so the
// numerics are plain loops over indices and a reorder is one permutation applied to each vector.
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

namespace mps {

inline constexpr int kDim = 2;

enum class Kind : std::uint8_t {
  fluid = 0,
  wall = 1,   // first boundary layer: a PPE unknown
  dummy = 2,  // outer boundary layers: fill the kernel support, pressure set from the wall after the solve
  ghost = 3,  // inactive (recycled at inlets/outlets); invisible to every operator
};
std::string_view to_string(Kind kind);

struct Particles {
  std::vector<double> x, y;  // position
  std::vector<double> u, v;  // velocity
  std::vector<double> p;     // pressure (also the warm start of the next solve)
  std::vector<Kind> kind;
  std::vector<int> group;    // user tag, e.g. which wall moves with which rigid motion
  std::vector<int> id;       // index at creation: follows the particle through reorderings

  [[nodiscard]] std::size_t size() const { return x.size(); }
  [[nodiscard]] bool empty() const { return x.empty(); }
  void add(double px, double py, Kind k, int grp = 0, double pu = 0.0, double pv = 0.0);
  void reserve(std::size_t n);
  [[nodiscard]] std::size_t count(Kind k) const;
  // Applies new[i] = old[order[i]] to every array; order must be a permutation of 0..size()-1.
  void permute(std::span<const int> order);
};

}  // namespace mps
