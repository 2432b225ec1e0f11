#pragma once
// Scene files (docs/scene-files.md): a case described as data in TOML, 2-D or 3-D — a walled tank, blocks of fluid,
// solid box obstacles (fixed or oscillating), the domain, the physics and numerics by SimulationConfig's own names,
// the components a scene adds, the run's length, its outputs and its probes; or an elastic body alone, or an acoustic
// field and its pulses. sparsemps-run runs them; every error names the file, the line and the key.
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "acoustic_run.hpp"
#include "mps/boundaries/boundary.hpp"
#include "mps/boundaries/geometry.hpp"
#include "mps/core/domain.hpp"
#include "mps/core/particles.hpp"
#include "mps/io/probes.hpp"
#include "mps/solids/elastic.hpp"
#include "mps/step/step.hpp"

namespace scene_file {

// An axis-aligned box [lo, hi] of the scene's dimension, and the file's line that gave it (for errors).
template <int D>
struct Block {
  mps::Vec<D> lo{}, hi{};
  mps::Vec<D> velocity{};  // fluid blocks: the initial velocity [m/s]
  int line = 0;
};

// A solid box: dummy particles inside, `wall_layers` layers of wall particles under its faces `walls` (the Face bits
// of mps::add_box_walls; by default every face that does not lie on the tank's). It oscillates when `amplitude` > 0:
// its particles are at start + amplitude sin(2 pi t / period) along `axis`.
template <int D>
struct Obstacle {
  Block<D> box;
  unsigned walls = 0;
  int group = 0;
  int axis = 0;
  double amplitude = 0, period = 0;
};

// Walls outside a box on its faces `walls`, as the tank's, with a group of their own, for a wall that is not a tank's
// (a channel's). With `no_slip` (one face only) the fluid meets it by mirror velocities (mps::MirrorNoSlip in 2-D,
// mps::MirrorPlaneNoSlip3 in 3-D), the wall sliding at `velocity` (its particles stay where they are).
// With `part_group` > 0, the wall's particles below `part_below` along `part_axis` form a part of their own: that
// group, sliding at `part_velocity` (the conveyor beside an inlet's plate, which moves with the fluid it pushes).
template <int D>
struct Wall {
  Block<D> box;
  unsigned walls = 0;
  int group = 0, wall_layers = 1, dummy_layers = 4;
  bool no_slip = false;
  mps::Vec<D> velocity{};
  int part_group = 0, part_axis = 0;
  double part_below = 0;
  mps::Vec<D> part_velocity{};
};

// A pushing-plate inlet (mps::BasicPushingPlate): the [[wall]] of group `plate` on an x_low face moves at `speed` along
// +x, adding a column of fluid at each spacing it advances, from a pool of ghosts parked one spacing behind it
// (`ghost_rows` per spacing of its height, in 3-D on every layer of its depth); fluid past `outlet` (x) returns to the
// pool. With `buffer` > 0 an outflow buffer that thick holds the outlet at P = 0 (mps::BasicOutflowBuffer); without,
// the outlet's last 4 spacings are free surface.
struct Inlet {
  int plate = 0, ghost_rows = 3;
  std::size_t wall = 0;  // the plate's [[wall]]: its index in the scene's walls
  double speed = 0, outlet = 0, buffer = 0;
  int line = 0;
};

// One wall of an annulus: its surface turns at `omega` (the velocity the fluid meets, counter-clockwise positive) and
// its particles are carried round at `turns` (by default omega; the screw channel's barrel over a turning channel
// moves with the channel but is at rest: turns = the channel's rate, omega = 0).
struct AnnulusWall {
  double omega = 0, turns = 0;
};

// A walled annulus about the z axis (mps::fill_walled_annulus): fluid in r_inner < r < r_outer, closed by circular
// walls, over the sector of `span` radians centred on the angle `centre` between radial flights when span < 2 pi. In
// 3-D the rings are extruded along z over 0 < z < height, periodic.
struct Annulus {
  double r_inner = 0, r_outer = 0, span = 0, centre = 0, height = 0;
  int rings = 0, layers_z = 0, wall_layers = 1, dummy_layers = 4;
  bool mirror = true;  // the circular walls meet the fluid by mirror velocities (mps::MirrorWall with a radius)
  AnnulusWall inner, outer, flights;
  static constexpr mps::AnnulusGroups groups{};  // fluid 0, inner wall 1, outer wall 2, flights 3
  [[nodiscard]] bool full() const;
};

// An elastic body coupled to the fluid (mps::ElasticStructure; the library's solids are 2-D): the box's lattice, its
// particles the fluid's wall particles (one layer under the faces `walls`) and dummies of `group`, moved with the
// solid. It is held by its lattice continued `clamp_layers` spacings (the solid kernel's reach) beyond its face
// `clamp`, inside what holds it (the floor, or its `mount`): the solid's clamped particles, not the fluid's. A mount
// continues the lattice past the clamp face up to `mount_to` (along the clamp face's axis) as standing wall (under the
// faces `mount_walls`) and dummy particles of group 0: the rigid wall a gate hangs from.
//
// A scene of one elastic body alone (no fluid; `structure`'s scenes) may instead hold it in a cylinder its x_low face
// rests against (mps::cylinder_clamped_box_body: Turek & Hron's flag) and start it swinging in its first bending mode
// with the tip's velocity `first_mode_tip_velocity` (across its length, mps::cantilever_first_mode).
template <int D>
struct Elastic {
  Block<D> box;
  unsigned walls = 0, clamp = 0, mount_walls = 0;
  int group = 1;
  bool has_mount = false;
  double mount_to = 0;
  mps::ElasticMaterial material;
  double relaxation = 1, cfl = 0.3, hourglass = 30;
  mps::Vec<2> cylinder_centre{};
  double cylinder_radius = 0;  // 0: held at its clamp face, not in a cylinder
  double first_mode_tip_velocity = 0;
  static constexpr int clamp_layers = 3;  // mps::ElasticConfig's kernel radius, 3 spacings
};

template <int D>
struct Scene {
  std::filesystem::path file;
  std::string title;
  double l0 = 0;
  bool has_tank = false;
  Block<D> tank;            // the tank's inner box; its walls outside it on the faces `tank_walls`
  unsigned tank_walls = 0;  // Face bits (Side bits in 2-D: the same values)
  int wall_layers = 1, dummy_layers = 4;
  std::vector<Block<D>> fluid;
  std::vector<Wall<D>> walls;
  std::vector<Obstacle<D>> obstacles;
  std::vector<Elastic<D>> elastic;
  bool has_inlet = false;
  Inlet inlet;
  bool has_annulus = false;  // a scene of its own: no tank, fluid blocks, walls or obstacles beside it
  Annulus annulus;
  bool solid_alone = false;  // one [[elastic]] body and no fluid: stepped on its own (mps::ElasticSolid)
  mps::BasicDomain<D> domain;  // periodic on the axes the file's [domain] lists
  mps::SimulationConfig config;
  // Components, added in this order (each off unless the file asks for it): no free surface anywhere (a closed
  // liquid: mps::SurfaceRegion), the walls' no-slip, the obstacles' motion, then these.
  bool free_surface = true;
  double collision = 0, restitution = 0.2;  // mps::ParticleCollision: distance [l0] (0: off), restitution
  double asymmetry = 0, asymmetry_interior_density = 0;  // mps::AsymmetrySurface (0: off)
  bool wet_walls = false;       // mps::WetWalls
  bool remove_escaped = false;  // mps::RemoveEscaped: fluid over the tank's walls or near the domain's ceiling
  bool wall_backstop = false;   // mps::WallBackstop: fluid kept inside the tank and out of the obstacles
  double wall_backstop_slack = 0;  // ... once more than this past a face [l0]
  double end_time = 0;          // [s]
  std::filesystem::path out;    // the file's out relative to its folder; by default runs/<file stem>
  int frames = 20;
  double probe_interval = 0;    // [s] (0: every step)
  bool has_probes = false;
  nlohmann::json parameters;    // the scene as its summary records it
};

// The scene file's dimension: its `dimensions` key (2 or 3). Throws std::invalid_argument naming the line.
int dimensions_of(const std::filesystem::path& file);
// The whole scene, every key checked. Throws std::invalid_argument naming the file, the line and the key.
template <int D>
Scene<D> read_scene(const std::filesystem::path& file);
// The particles: the fluid blocks in the file's order, then the tank's walls, the [[wall]]s, the obstacles, each
// elastic body's mount and body, the inlet's ghosts (or the annulus's rings, from the innermost).
template <int D>
mps::BasicParticles<D> make_particles(const Scene<D>& scene);
// The simulation with the scene's components (and each moving obstacle's motion); `plate`, if given, receives the
// inlet's plate (null without an [inlet]): its counts go into a checkpoint.
template <int D>
std::unique_ptr<mps::BasicSimulation<D>> make_simulation(const Scene<D>& scene,
                                                         std::shared_ptr<mps::BasicPushingPlate<D>>* plate = nullptr);
// An [[elastic]] body's lattice and clamp, and its solid's configuration (its material, CFL and hourglass control, the
// scene's gravity; the kernel's 3 spacings).
mps::ElasticBody elastic_body(const Elastic<2>& body, double l0);
mps::ElasticConfig elastic_config(const Scene<2>& scene, const Elastic<2>& body);
// A scene of an elastic body alone: its solid, moving as first_mode_tip_velocity says, and its [[probe]]s, each a
// displacement of the body.
mps::ElasticSolid make_solid(const Scene<2>& scene);
mps::ProbeSeries read_solid_probes(const Scene<2>& scene, const mps::ElasticSolid& solid);
// The file's [[probe]] tables for `sim` (an empty series when it has none).
template <int D>
mps::BasicProbeSeries<D> read_probes(const Scene<D>& scene, mps::BasicSimulation<D>& sim);

// An acoustic scene: a file with an [acoustic] table, a linearised-Euler field on a lattice of particles (MPS-WP,
// mps::AcousticSolver; 2-D) in a box with its boundary, the Gaussian pulses it starts from ([[pulse]]; fired again at
// repeat_frequency), the times it is compared with the exact solution and mapped, its frames and output folder: what
// `acoustic` runs, as data.
struct AcousticScene {
  std::filesystem::path file;
  std::string title;
  acoustic::AcousticRun run;  // its dir: the file's [output] out
  nlohmann::json parameters;  // the scene as its summary records it
};
// Whether the file is an acoustic scene (has an [acoustic] table).
bool is_acoustic(const std::filesystem::path& file);
// The whole acoustic scene, every key checked, its end time `end_time` if positive (before the samples and maps past
// the end are dropped). Throws std::invalid_argument naming the file, the line and the key.
AcousticScene read_acoustic_scene(const std::filesystem::path& file, double end_time = 0);

}  // namespace scene_file
