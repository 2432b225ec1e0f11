#pragma once
// Dam break: a water column collapses under gravity in a tank with an open top (seed 003 §2.1). Two columns:
// - classic: a wide, 2a high, a = 0.146 m, in a tank 4a wide (Martin & Moyce 1952, Koshizuka & Oka 1996: surge front);
// - seed: 2H wide, H = 1 m high, in a tank 5.366H long and 3H high (Buchner 2002: downstream-wall pressure).
// Or any tank, column and obstacles from a particle file (from_particles).
// The scene samples the surge front, water levels at probe lines and wall pressures at probe patches as it runs.
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "mps/io/probes.hpp"
#include "mps/parallel/rank_exchange.hpp"
#include "mps/step/components.hpp"
#include "mps/step/step.hpp"

namespace dambreak {

// file: a scene from a particle file that is neither built-in column; no experiment applies to it. spheric2: the 3-D
// dam break hitting a box (box_impact.hpp).
enum class Column { classic, seed, file, spheric2 };
Column column_from_name(const std::string& name);  // "classic", "seed" or "spheric2"; throws std::invalid_argument otherwise
std::string to_string(Column c);

struct Params {
  Column column = Column::classic;
  double width = 0.146;        // the column's width a [m]
  double height = 0.292;       // the column's height H [m]
  double tank_length = 0.584;  // [m], the downstream wall at x = tank_length
  double tank_height = 0.438;  // [m], the walls' height; fluid above it or beyond them is removed
  double l0 = 0.0073;          // particle spacing [m]
  double gamma = 0.01;         // mixed source weight
  double cfl = 0.2;            // dt <= cfl l0 / |u|max
  // Close pairs collide (mps::ParticleCollision): closer than `collision` l0 (0: off), with this restitution. The 2-D
  // columns run without since the dynamic stabilisation ("ds"); the 3-D dam break keeps 0.8 l0.
  double collision = 0.0;
  double restitution = 0.2;
  // Free surface also where the neighbours lie one-sided: above this fraction of a flat surface's asymmetry (0: off;
  // the 3-D dam break takes 0.9).
  double asymmetry = 0.0;
  // ... but never fluid at or above this number density, in n0 (0: no limit): fluid pressed onto a wall is not free
  // surface. The 3-D dam break's cubic walls need it (docs/dambreak3d.md); the 2-D columns keep 0.
  double asymmetry_interior_density = 0.0;
  // Wall particles next to fluid that is not free surface carry pressure even where the density test calls them dry.
  bool wet_walls = false;
  // Particle shifting coefficient (0: off); particles on or next to the free surface shift along it only. 0.5 gave the
  // least wall-pressure noise at the seed's spacing (docs/dambreak.md); the 3-D dam break takes 0 (docs/dambreak3d.md).
  double shifting = 0.5;
  // The pressure gradient of the corrector (mps::GradientVariant).
  mps::GradientVariant gradient = mps::GradientVariant::min_reference;
  // Khayyer & Gotoh's treatments of the projection (mps::set_pressure_treatment: hs, hl, ecs, cfs, gc, ds joined by '+').
  // The higher-order source cut the wall pressure's step-to-step noise 2.6-fold at H/25 and H/50; the dynamic
  // stabilisation lets the 2-D columns run without collisions (docs/pressure.md). The 3-D dam break takes hs.
  std::string pressure_treatment = "hs+ds";
  // With "ds" in the treatment: the corrector puts pairs nearer than this back at it (in l0).
  double stabilisation_distance = mps::SimulationConfig::default_stabilisation_distance;
  double end_time = 0.3;       // [s]
  double g = 9.81;
  std::string solver = "auto";
  bool warm_start = true;  // each pressure solve from the previous pressure (false: from zeros, the classic baseline)
  // Level probes, as distances from the downstream wall in H; pressure probes, as heights on it in H.
  std::vector<double> level_probes;
  std::vector<double> pressure_probes;
  double pressure_patch = 2.0;  // the pressure probe reaches this far from the wall line, in l0
  // The pressure probe's height on the wall, in H: a sensor of that size, the same at every spacing (Zhou et al.'s
  // 90 mm sensor on a 0.6 m column is 0.15 H). 0: a disc of radius pressure_patch, which shrinks with the spacing.
  double sensor_height = 0.15;
};

// The column's geometry with its default spacing (40 particles across a for the classic column, H/25 for the seed's;
// spheric2's is box_impact_defaults()).
Params defaults(Column c);
// Sets p's column and what comes with it (tank, probes, end time) to column c's, keeping the numerics.
void take_column_geometry(Params& p, Column c);

// A series of samples' probe values (one row per sample, one value per probe) for a checkpoint, and back.
nlohmann::json pack_rows(const std::vector<std::vector<double>>& rows);
std::vector<std::vector<double>> unpack_rows(const nlohmann::json& state, std::size_t count);

struct Sample {
  double time;
  double front;                  // surge front's distance from the upstream wall [m]
  std::vector<double> levels;    // water height at each level probe [m]
  std::vector<double> pressures;  // mean pressure over each probe patch [Pa]
};

// The steps a run takes at least: its end time over the largest step the CFL (at the free-fall speed) and the
// viscous limit allow.
double estimated_steps(const Params& p);
// The largest spacing the column takes: four particles across its width and its height.
double coarsest_spacing(const Params& p);

mps::Particles make_particles(const Params& p);
mps::Domain make_domain(const Params& p);
mps::SimulationConfig make_config(const Params& p, int dim = 2);  // gravity along -y in 2-D, -z in 3-D

// What every dam break adds to its simulation: close pairs colliding, the asymmetry surface test and wet walls as p
// asks, and the removal of fluid that leaves `inside` (spray over a wall's top).
template <int D>
void add_dam_break_components(mps::BasicSimulation<D>& sim, const Params& p,
                              typename mps::BasicRemoveEscaped<D>::Region inside) {
  if (p.collision > 0.0) sim.template add<mps::BasicParticleCollision<D>>(p.collision, p.restitution);
  if (p.asymmetry > 0.0) sim.template add<mps::BasicAsymmetrySurface<D>>(p.asymmetry, p.asymmetry_interior_density);
  if (p.wet_walls) sim.template add<mps::BasicWetWalls<D>>();
  sim.template add<mps::BasicRemoveEscaped<D>>(std::move(inside));
}

// The leading edge of the water: the largest x of a fluid particle with a fluid neighbour within 2.1 l0 (spray
// ahead of the front is not the front), plus l0/2, from the upstream wall at x = 0.
double surge_front(const mps::Particles& particles, double l0);

// A scene from a particle file's particles (docs/particle-files.md). The spacing is dx, or if dx is 0 the particles'
// median nearest-neighbour distance to 12 significant digits (so a lattice made at 0.01 m gives 0.01). Particles equal
// to a built-in column's at that spacing (as --write-particles writes them) run as that column, with its parameters,
// probes and experiments. Any other file is Column::file: the tank is the wall particles' inner box (the walls' first
// layer half a spacing outside it), the column the fluid's box from the tank's upstream wall and floor, both to the
// lattice where they are within round-off of a whole number of spacings; the particles are moved so that the tank's
// inner lower-left corner is the origin; the classic column's probes are kept where they lie inside the tank. The
// options (gamma, solver, ...) come from `options`. Throws std::invalid_argument saying what to change.
struct FileScene {
  Params params;
  mps::Particles particles;
  std::string description;  // how the spacing, the tank and the column were found, for the console
};
FileScene from_particles(mps::Particles particles, double dx, const Params& options);

// What the 2-D and 3-D particle-file scenes share. The spacing: dx, or (dx <= 0) `median`, the particles' median
// nearest-neighbour distance, to 12 significant digits; `how` says which. Throws if dx is more than 20 % from median.
double file_spacing(double median, double dx, std::string& how);
// A length measured on lattice particles: a whole number of spacings when it is one to round-off.
double snapped(double length, double l0);
// The tank's length as its walls are built (add_rectangle_walls): the nearest whole number of spacings. The seed
// column's 5.366 H is 0.15-0.4 l0 off its wall at H/25-H/100; the probes, the wall checks and the backstop take the
// built wall. Unchanged when it is already whole (the classic column's 8a).
double built_tank_length(const Params& p);
// Whether a file's particles are `built` (a built-in scene's) in any order: the same kinds and groups at the same
// positions to 1e-9 l0, at rest.
template <int D>
bool same_particles_at_rest(const mps::BasicParticles<D>& file, const mps::BasicParticles<D>& built, double l0);
// Refuses a file's state no dam break reaches: a particle faster than 10 times a fall from the tank's top or the
// column's, or holding more than 100 rho g h.
template <int D>
void check_initial_state(const mps::BasicParticles<D>& s, const Params& p);

// `domain` widened to hold every particle a spacing inside its edges (a file's extra dummy layers).
template <int D>
mps::BasicDomain<D> widened_to_hold(mps::BasicDomain<D> domain, const mps::BasicParticles<D>& particles, double l0) {
  for (std::size_t i = 0; i < particles.size(); ++i) {
    domain.xmin = std::min(domain.xmin, particles.x[i] - l0);
    domain.xmax = std::max(domain.xmax, particles.x[i] + l0);
    domain.ymin = std::min(domain.ymin, particles.y[i] - l0);
    domain.ymax = std::max(domain.ymax, particles.y[i] + l0);
    if constexpr (D == 3) {
      domain.zmin = std::min(domain.zmin, particles.z[i] - l0);
      domain.zmax = std::max(domain.zmax, particles.z[i] + l0);
    }
  }
  return domain;
}
// The domain of a scene: make_domain(p), widened where the particles reach beyond it.
mps::Domain make_domain(const Params& p, const mps::Particles& particles);

// On the ranks of an MPI communicator (comm: its Fortran handle) the scene runs with an mps::RankExchange; every
// rank passes the same parameters and particles. Its particles are then gathered on rank 0 after every step and
// sampled there: samples(), all_particles() and the wall counts are rank 0's alone (empty or zero on the others).
class Scene {
 public:
  explicit Scene(const Params& p);  // the column p describes (make_particles)
  Scene(const Params& p, mps::Particles particles, std::optional<int> comm = {});  // these particles in p's tank
  void step();  // throws mps::SimulationError if the guard stops the run; sim() then holds the last good state
  [[nodiscard]] bool done() const { return sim_->time() >= params_.end_time - 1e-12; }
  [[nodiscard]] const mps::Simulation& sim() const { return *sim_; }
  [[nodiscard]] mps::Simulation& sim() { return *sim_; }  // to add components of one's own
  // Every particle after the last step (on ranks: gathered on rank 0, sorted by id; empty on the other ranks).
  [[nodiscard]] const mps::Particles& all_particles() const { return distributed_ ? gathered_ : sim_->particles(); }
  [[nodiscard]] const Params& params() const { return params_; }
  [[nodiscard]] const std::vector<Sample>& samples() const { return samples_; }  // t = 0 and after every step
  // Fluid removed as spray over the walls, as mps::RemoveEscaped counted it (so that fluid plus spray equals the
  // initial count is a check, not a definition); on ranks the sum over them (collective).
  [[nodiscard]] long removed() const;
  // Fluid particles the wall backstop put back on a wall line from inside the wall, summed over steps (collective on
  // ranks).
  [[nodiscard]] long backstop_returns() const;
  [[nodiscard]] long initial_fluid() const { return initial_fluid_; }
  // Fluid particles inside a wall (below its top and past its first layer's centres, l0/2 beyond the wall line) after
  // the backstop: the most there were at any sample. And the deepest any fluid went past a wall line [m] (<= 0: never
  // reached it).
  [[nodiscard]] long most_inside_walls() const { return most_inside_walls_; }
  [[nodiscard]] double deepest_past_wall_line() const { return deepest_past_wall_line_; }
  // For a checkpoint: the samples and wall counts so far (the simulation's own state is Simulation::checkpoint()).
  [[nodiscard]] nlohmann::json save_state() const;
  void restore_state(const nlohmann::json& state);

 private:
  void sample();
  Params params_;
  std::unique_ptr<mps::Simulation> sim_;
  const mps::RankExchange* distributed_ = nullptr;  // the simulation's, on ranks
  mps::Particles gathered_;
  long initial_fluid_;
  long most_inside_walls_ = 0;
  double deepest_past_wall_line_ = -1e300;
  std::vector<Sample> samples_;
};

// Experimental data: two columns per line (whitespace separated), '#' starts a comment. Throws naming the file.
using Table = std::vector<std::array<double, 2>>;
Table read_table(const std::string& path);

// The front against an experiment's (T, x/a) points with T <= t_max: the largest |x - x_exp| / x_exp, the run's
// front interpolated linearly in time; points beyond the run's end are left out. NaN if no point was compared.
double max_front_error(const std::vector<Sample>& samples, const Params& p, const Table& data, double t_max);

// The front's developed speed: a line x/a = speed T + intercept fitted by least squares to the points (T, x/a) with T
// in [t0, t1]. NaN with fewer than two such points.
struct FrontLine {
  double speed = 0, intercept = 0;
  int points = 0;
};
FrontLine fit_front_line(const std::vector<double>& T, const std::vector<double>& x_over_a, double t0, double t1);
// The run's front delayed by a time offset dT (the run at T - dT against the experiment at T) that brings it closest
// to an experiment's points with T <= t_max: dT searched in steps of 0.001 over [-0.5, 1], the largest relative error
// left at it. A lead that is a pure time origin leaves a small error at one dT (docs/dambreak.md). NaN if no point.
struct FrontOffset {
  double dT = 0, error = 0;
};
FrontOffset fit_front_offset(const std::vector<Sample>& samples, const Params& p, const Table& data, double t_max);

// A wall-pressure signal, time ascending, in Buchner's units (t sqrt(g/H), p/(rho g H)). The impact's arrival is the first time the
// signal reaches `threshold`; its first peak the largest value of the signal smoothed over `smooth` (a centred moving
// average, in t sqrt(g/H)) within `window` after arrival; its noise the RMS of the signal less its smoothed self over
// the signal's range, after arrival. Arrival and peak are NaN if the signal never reaches the threshold.
//
// The second impact (the run-up's fall onto the first wave, t sqrt(g/H) ~ 5.5-6.5 in Buchner's record): its arrival the
// first time from t = 5 on that the smoothed signal exceeds the plateau (its mean over [3.5, 5]) by 0.1, its peak the
// largest smoothed value within 1 after that. NaN where the signal does not reach so far or never rises.
// noise_rms is that RMS itself, in rho g H: the range grows with the spikes it is meant to judge, so two methods'
// signals compare by it.
struct Impact {
  double arrival = 0, peak = 0, noise = 0, noise_rms = 0;
  double plateau = 0, second_arrival = 0, second_peak = 0;
};
Impact impact(const std::vector<double>& time, const std::vector<double>& pressure, double threshold = 0.25,
              double window = 0.5, double smooth = 0.1);

// The signal as a record sampled only at `at` (ascending) sees it: at each sample time the signal's mean from the
// midpoint with the previous sample to the midpoint with the next (the first and last sample from their own time
// inwards). A digitised curve shows no noise faster than its spacing, so a run's noise is compared with Buchner's at
// his record's own sampling (docs/dambreak.md). Samples whose interval holds no step of the signal, or reaches past
// its end, are left out; returns the kept times and means.
std::pair<std::vector<double>, std::vector<double>> sampled_at(const std::vector<double>& time,
                                                               const std::vector<double>& pressure,
                                                               const std::vector<double>& at);

// Martin & Moyce's and Koshizuka & Oka's time unit: T = t sqrt(2 g / a).
inline double front_time_scale(const Params& p) { return std::sqrt(2.0 * p.g / p.width); }

}  // namespace dambreak
