#pragma once
/// \file
/// Probes: what a run measures at fixed places, as an experiment's sensors do. A probe reads one quantity at each of
/// its points (a point, a line or a plane of them): pressure or velocity by kernel interpolation, pressure averaged
/// over a sensor's patch on a wall, the water level (free-surface height) over a point of the floor, or the force on
/// a wall group. A BasicProbeSeries samples its probes at a stated interval of simulation time and writes them as one
/// CSV; it is saved in checkpoints. Probes read a particle set as given: on MPI ranks, sample the particles gathered
/// on rank 0 (mps/parallel/distributed.hpp). docs/probes.md.
#include <array>
#include <filesystem>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mps/core/kernel.hpp"
#include "mps/core/particles.hpp"
#include "mps/core/vec.hpp"

namespace mps {

class WallForce;
class ElasticStructure;
class ElasticSolid;

/// @{ Sample points: `n` points evenly from a to b, both ends included (n = 1: the midpoint); and the n1 x n2 points
/// origin + (i / (n1 - 1)) e1 + (j / (n2 - 1)) e2 of a plane's parallelogram, j fastest (a count of 1 takes the middle
/// along that edge). Throw std::invalid_argument for a count below 1 or a non-finite coordinate.
template <int D>
std::vector<Vec<D>> line_points(const Vec<D>& a, const Vec<D>& b, int n);
template <int D>
std::vector<Vec<D>> plane_points(const Vec<D>& origin, const Vec<D>& e1, const Vec<D>& e2, int n1, int n2);
/// @}

/// The pressure at `at` by kernel interpolation: the fluid and wall particles within kernel.re, weighted by
/// kernel.w(r) and normalised by the weights' sum (Shepard), so a constant field is read exactly; 0 (the gauge
/// pressure of air) where no particle is within reach.
template <int D>
double kernel_pressure(const BasicParticles<D>& particles, const Vec<D>& at, const Kernel& kernel);
/// The fluid's velocity at `at`, interpolated as kernel_pressure over the fluid particles alone; 0 where none.
template <int D>
Vec<D> kernel_velocity(const BasicParticles<D>& particles, const Vec<D>& at, const Kernel& kernel);

/// A pressure sensor's patch on a wall: the fluid and wall particles closer than `reach` to the wall's plane through
/// `centre` (normal along axis `normal_axis`), within `radius` of `centre` along the wall (2-D: |along| <= radius;
/// 3-D: the disc, distance < radius), and strictly inside `lower`..`upper` on the wall's other axes (the face's edges;
/// the normal axis's entries are ignored). radius 0: the ball of radius `reach` about `centre` instead.
template <int D>
struct BasicSensorPatch {
  Vec<D> centre{};     ///< on the wall's surface [m]
  int normal_axis = 0;  ///< the wall's normal: 0 (x), 1 (y) or 2 (z, 3-D)
  double reach = 0.0;   ///< half-thickness across the wall [m]: the first wall layer sits l0/2 behind its surface
  double radius = 0.0;  ///< the sensor's half-size along the wall [m]
  /// @{ the face's edges along the wall [m] (default: unbounded)
  Vec<D> lower = filled(-std::numeric_limits<double>::infinity());
  Vec<D> upper = filled(std::numeric_limits<double>::infinity());  /// @}

 private:
  static Vec<D> filled(double v) {
    Vec<D> r;
    r.fill(v);
    return r;
  }
};
using SensorPatch = BasicSensorPatch<2>;   ///< a 2-D sensor's patch
using SensorPatch3 = BasicSensorPatch<3>;  ///< a 3-D sensor's patch

/// The mean pressure of the particles in `patch` (a sensor's reading); 0 if none.
template <int D>
double patch_pressure(const BasicParticles<D>& particles, const BasicSensorPatch<D>& patch);

/// How a water level is read over a point of the floor (the vertical is the last axis: y in 2-D, z in 3-D).
enum class LevelMethod {
  /// The highest fluid particle within l0 of the vertical line that has another fluid particle within 2.1 l0 (a
  /// lone drop is not the surface), plus l0/2: the free surface's height.
  surface,
  /// A wave gauge's wire: from the floor up, the fluid particles within l0 of the line while each is at most 2 l0
  /// above the one below, the first within 1.5 l0 of the floor; the top one plus l0/2 (a sheet thrown over the
  /// wire is not counted, as the wetted length of a resistive gauge).
  wire,
};
/// The water level over `at` for particles of spacing l0: the surface's vertical coordinate [m]; 0 if no water is
/// over the point. `at`'s vertical coordinate is the floor's, from which the wire counts (`surface` ignores it).
template <int D>
double water_level(const BasicParticles<D>& particles, const Vec<D>& at, double l0,
                   LevelMethod method = LevelMethod::surface);

/// The largest coordinate[i] over the `candidates` i that have another fluid particle within `radius` (a lone drop
/// does not count): a surge front along x, or a free surface's height. Empty if no candidate has one.
template <int D>
std::optional<double> outermost_with_fluid_neighbour(const BasicParticles<D>& particles,
                                                     std::vector<std::size_t> candidates,
                                                     std::span<const double> coordinate, double radius);

/// One probe: a name and the values it reads from a particle set, `components` per point (a CSV column each).
template <int D>
struct BasicProbe {
  std::string name;           ///< letters, digits, '_', '-' and '.' (its CSV columns start with it)
  std::string quantity;       ///< "pressure", "velocity", "level", "force", "displacement" (or a user's own)
  std::vector<Vec<D>> points;  ///< where it reads; one point for a force
  int components = 1;         ///< values per point (velocity, force: D)
  /// Writes components * points.size() values for the particles' present state.
  std::function<void(const BasicParticles<D>& particles, double* values)> read;
};
using Probe = BasicProbe<2>;   ///< a 2-D probe
using Probe3 = BasicProbe<3>;  ///< a 3-D probe

/// @{ Probes of the kinds above. Each throws std::invalid_argument naming the cause (no point, a non-finite
/// coordinate, a kernel radius, patch reach, radius or l0 that is not positive and finite, a normal axis out of range).
template <int D>
BasicProbe<D> pressure_probe(std::string name, std::vector<Vec<D>> points, const Kernel& kernel);
template <int D>
BasicProbe<D> velocity_probe(std::string name, std::vector<Vec<D>> points, const Kernel& kernel);
/// A patch per point, each `patch` moved to centre on it.
template <int D>
BasicProbe<D> patch_probe(std::string name, std::vector<Vec<D>> points, const BasicSensorPatch<D>& patch);
template <int D>
BasicProbe<D> level_probe(std::string name, std::vector<Vec<D>> points, double l0,
                          LevelMethod method = LevelMethod::surface);
/// @}
/// The last step's force of the fluid's pressure on `force`'s wall group [N per unit depth]: (fx, fy). The component
/// must outlive the probe and be added to the simulation sampled.
Probe force_probe(std::string name, const WallForce& force);
/// @{ An elastic body's displacement at reference points [m]: (ux, uy) per point, by ElasticSolid::displacement_at (the
/// body's probe point: a flag's tip, a plate's top), of a solid stepped on its own or of a fluid's component. The
/// solid or component must outlive the probe; the particles sampled are not read. Throws std::invalid_argument for no
/// point or a non-finite coordinate.
Probe displacement_probe(std::string name, std::vector<Vec<2>> points, const ElasticSolid& solid);
Probe displacement_probe(std::string name, std::vector<Vec<2>> points, const ElasticStructure& body);
/// @}

/// Probes sampled at an interval of simulation time, kept as rows (time, then every probe's columns) and written as
/// one CSV. Sampling is the caller's: call sample() after every step; it reads the probes when the time has reached
/// the next mark (the first call's time plus a whole number of intervals, to 1e-9 of an interval), so a run with steps
/// that do not divide the interval samples at the first step on or after each mark.
template <int D>
class BasicProbeSeries {
 public:
  /// interval [s] between samples; 0: at every call. Throws std::invalid_argument if negative or not finite.
  explicit BasicProbeSeries(double interval = 0.0);
  /// Adds a probe; throws std::invalid_argument for an empty or invalid name, a name already taken, no points, a
  /// components count below 1, no read function, or after the first sample.
  void add(BasicProbe<D> probe);
  /// Samples every probe if `time` has reached the next mark less `early` (half a step: the step nearest each mark
  /// rather than the first on or after it, so that a run ending half a step short of its end still samples it);
  /// returns whether it did. Throws std::invalid_argument for a non-finite time, one before the last sample's or a
  /// negative `early`. A probe's non-finite reading is kept as it is (a blow-up is the step's guard to stop, not the
  /// probe's).
  bool sample(double time, const BasicParticles<D>& particles, double early = 0.0);
  /// "time", then per probe: its name (one point, one component), name[k] (point k), with ".x"/".y"/".z" appended per
  /// component for velocity and force.
  [[nodiscard]] std::vector<std::string> columns() const;
  /// Every sample so far: its time, then the probes' values in columns()' order.
  [[nodiscard]] const std::vector<std::vector<double>>& rows() const { return rows_; }
  [[nodiscard]] const std::vector<BasicProbe<D>>& probes() const { return probes_; }  ///< in the order added
  [[nodiscard]] double interval() const { return interval_; }                        ///< as constructed
  /// Writes columns() and rows() as CSV by write_csv (mps/io/io.hpp: 10 significant digits, written atomically).
  void write_csv(const std::filesystem::path& path) const;
  /// Each probe's name, quantity, points (points_m) and component count, and the columns, for a run's summary.
  [[nodiscard]] nlohmann::json describe() const;
  /// @{ For a checkpoint: the rows and the next mark. restore_state() refuses a state whose columns differ from
  /// this series' (other probes) with std::runtime_error.
  [[nodiscard]] nlohmann::json save_state() const;
  void restore_state(const nlohmann::json& state);
  /// @}

 private:
  double interval_;
  std::vector<BasicProbe<D>> probes_;
  std::vector<std::vector<double>> rows_;
  double first_time_ = 0.0;
  long long marks_passed_ = 0;  // marks sampled so far, the first call's included
};
using ProbeSeries = BasicProbeSeries<2>;   ///< 2-D probes
using ProbeSeries3 = BasicProbeSeries<3>;  ///< 3-D probes

extern template class BasicProbeSeries<2>;
extern template class BasicProbeSeries<3>;

}  // namespace mps
