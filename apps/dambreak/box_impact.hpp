#pragma once
// SPHERIC Benchmark Test 2, a 3-D dam break hitting a box (Kleefsman, Fekken, Veldman, Iwanowski & Buchner 2005, the
// MARIN experiment): a tank 3.22 x 1 x 1 m (x along it, y across, z up), a water column 1.228 m long, 1 m wide and
// 0.55 m high against its x = 3.22 end, a box 0.161 x 0.403 x 0.161 m on the floor in the flow's path. Pressure
// sensors P1-P4 on the box's face towards the water and P5-P8 on its top, water-height gauges H1-H4: their positions
// are read from data/dambreak/spheric2_sensors.csv. The scene samples them after every step.
#include <memory>
#include <string>
#include <vector>

#include "column.hpp"
#include "mps/boundaries/geometry.hpp"
#include "mps/parallel/distributed.hpp"

namespace dambreak {

// A pressure sensor (on the box: `face` is "front", towards the water, or "top") or a height gauge (z and face unused).
struct Sensor {
  std::string name;
  double x = 0, y = 0, z = 0;
  std::string face;
};
struct BoxImpactSensors {
  std::vector<Sensor> pressure;  // P1-P8
  std::vector<Sensor> height;    // H1-H4
};
// Reads name,x,y,z,face lines ('#' comments); throws naming the file and the line.
BoxImpactSensors read_box_impact_sensors(const std::string& path);

// The experiment's lengths [m].
struct BoxImpactSize {
  double tank_length = 3.22, tank_width = 1.0, tank_height = 1.0;
  double column_length = 1.228, column_height = 0.55;
  double box_x0 = 0.6635, box_x1 = 0.8245, box_y0 = 0.2985, box_y1 = 0.7015, box_height = 0.161;
};

// The tank (open at its top), the water's box, and the box-shaped obstacles in the tank that the wall backstop and the
// wall check hold (the experiment's box, on which its sensors sit, first).
struct BoxImpactGeometry {
  mps::Box tank, column;
  std::vector<mps::Box> boxes;
};
// The experiment on the lattice of spacing l0: every length the nearest whole number of spacings, the column against
// the tank's x-high end, the box's face towards the water (x1) and its sides at their nearest lattice lines.
BoxImpactGeometry box_impact_geometry(double l0, const BoxImpactSize& size = {});

// The dam break's numerics (defaults(Column::classic)'s, with the asymmetry test's interior density at n0) with this
// experiment's column and tank, spacing 0.04 m, to 0.7 s: the first impact on the box and the column's collapse, in a
// few minutes. The run to 6 s (40 minutes at 0.04 m on one thread) is the user's choice; docs/dambreak3d.md has it.
Params box_impact_defaults();

mps::Particles3 make_box_impact_particles(const BoxImpactGeometry& g, double l0);

// A 3-D scene from a particle file (dambreak --dim 3 --particles, docs/particle-files.md). SPHERIC Test 2's particles
// at rest, as --write-particles writes them, are the experiment (`experiment`: its sensors and record apply); any
// other file is a new scene: the tank is the inner box of its wall particles (open at the top), the water its fluid,
// and the wall and dummy particles inside the tank are obstacles, each (a face-connected group) held by the backstop
// and the wall check if it fills a box. dx: the spacing (0: the file's median nearest-neighbour distance). Throws
// std::invalid_argument naming what to change for a file no dam break can run.
struct BoxImpactFile {
  Params params;
  mps::Particles3 particles;
  BoxImpactGeometry geometry;
  bool experiment = false;
  long unchecked_obstacle_particles = 0;  // in obstacles that are not boxes: neither backstopped nor checked
  std::string description;
};
BoxImpactFile box_impact_from_particles(mps::Particles3 particles, double dx, const Params& options);

// On MPI ranks the cuts balance these loads of a fluid, wall, dummy and ghost particle: the walls and dummies
// outnumber the fluid but a wall or dummy particle costs about a tenth of a fluid one a step (fitted to each rank's
// phases by bench/kind_weights_fit.py, docs/scaling.md).
inline constexpr mps::RcbPartition::KindWeights box_impact_kind_weights{1.0, 0.2, 0.05, 0.01};
// The domain around the tank, with room above the column for splashes; and what the scene adds to its simulation: the
// dam break's components (collisions, the surface test, spray over the walls removed) and the wall backstop.
mps::Domain3 box_impact_domain(const BoxImpactGeometry& g, double l0);
void add_box_impact_components(mps::Simulation3& sim, const Params& p, const BoxImpactGeometry& g);

// The sensor's patch on its face of the box: the fluid and wall particles within `reach` of the face's plane and
// within `radius` of the sensor along it, inside the face (the 2-D probe's patch on a face of the box).
mps::SensorPatch3 box_face_patch(const BoxImpactGeometry& g, const Sensor& sensor, double reach, double radius);
// The height gauges read the water level as a wave probe's wire over the floor at z = 0 (mps::LevelMethod::wire): a
// sheet of water thrown over the line is not the surface (docs/dambreak3d.md).

struct BoxImpactSample {
  double time;
  std::vector<double> pressures;  // [Pa] at each pressure sensor
  std::vector<double> heights;    // [m] at each height gauge
};

class BoxImpact {
 public:
  // comm: step on the MPI ranks of that communicator (every rank passes the same p), sampled on rank 0.
  BoxImpact(const Params& p, BoxImpactSensors sensors, std::optional<int> comm = {});
  // A scene of these particles in this geometry (box_impact_from_particles'); sensors on the front or top face sit on
  // the first box.
  BoxImpact(const Params& p, BoxImpactSensors sensors, mps::Particles3 particles, BoxImpactGeometry geometry,
            std::optional<int> comm = {});
  void step();  // throws mps::SimulationError if the guard stops the run; sim() then holds the last good state
  [[nodiscard]] bool done() const { return sim_->time() >= params_.end_time - 1e-12; }
  [[nodiscard]] const mps::Simulation3& sim() const { return *sim_; }
  [[nodiscard]] mps::Simulation3& sim() { return *sim_; }
  // Every particle after the last step (on ranks: gathered on rank 0, sorted by id; empty on the other ranks).
  [[nodiscard]] const mps::Particles3& all_particles() const { return distributed_ ? gathered_ : sim_->particles(); }
  [[nodiscard]] const Params& params() const { return params_; }
  [[nodiscard]] const BoxImpactGeometry& geometry() const { return geometry_; }
  [[nodiscard]] const BoxImpactSensors& sensors() const { return sensors_; }
  [[nodiscard]] const std::vector<BoxImpactSample>& samples() const { return samples_; }  // t = 0 and every step
  [[nodiscard]] long removed() const;  // fluid removed as spray over the walls (on ranks: the sum, collective)
  // Fluid particles the wall backstop put back on a wall's or the box's face, summed over steps (collective on ranks).
  [[nodiscard]] long backstop_returns() const;
  [[nodiscard]] long initial_fluid() const { return initial_fluid_; }
  // Fluid particles inside a wall or a box (past its first layer's centres, l0/2 beyond its surface): the most at any
  // sample; and the deepest any fluid went past a wall's or the box's surface [m] (<= 0: never).
  [[nodiscard]] long most_inside_walls() const { return most_inside_walls_; }
  // For a checkpoint: the samples and wall counts so far (the simulation's own state is Simulation::checkpoint()).
  [[nodiscard]] nlohmann::json save_state() const;
  void restore_state(const nlohmann::json& state);
  [[nodiscard]] double deepest_past_wall() const { return deepest_past_wall_; }
  // The patch over which each sensor's pressure is averaged: its radius along the face and its reach across it [m].
  [[nodiscard]] double patch_radius() const { return 2.0 * params_.l0; }
  [[nodiscard]] double patch_reach() const { return 2.0 * params_.l0; }

 private:
  void start(const mps::Particles3& particles, std::optional<int> comm);
  void sample();
  Params params_;
  BoxImpactSensors sensors_;
  BoxImpactGeometry geometry_;
  std::unique_ptr<mps::Simulation3> sim_;
  const mps::RankExchange3* distributed_ = nullptr;  // the simulation's, on ranks
  mps::Particles3 gathered_;
  long initial_fluid_ = 0;
  long most_inside_walls_ = 0;
  double deepest_past_wall_ = -1e300;
  std::vector<BoxImpactSample> samples_;
};

// The experiment's record (time [s], P1 [Pa], H2 [m], H4 [m]).
struct BoxImpactRecord {
  std::vector<double> time, p1, h2, h4;
};
BoxImpactRecord read_box_impact_record(const std::string& path);

// The mean absolute difference of a run's series from the record's over the record's times in [t0, t1] that the run
// covers (the run interpolated linearly); NaN if none.
double mean_absolute_error(const std::vector<double>& run_time, const std::vector<double>& run, const std::vector<double>& time,
                           const std::vector<double>& record, double t0, double t1);

}  // namespace dambreak
