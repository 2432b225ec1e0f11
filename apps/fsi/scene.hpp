#pragma once
// Fluid-structure scenes of seed 003, each an elastic body (mps::ElasticSolid) coupled to the fluid by
// mps::ElasticStructure, or with `rigid` the same body as fixed wall and dummy particles (its load measured by
// mps::WallForce):
// - plate (§2.4): the classic dam-break column (a = 0.146 m wide, 2a high, tank 4a wide) hits a plate 0.08 m high and
//   0.012 m thick standing on the floor a in front of the water (upstream face at x = 2a), clamped at its foot;
// - gate (§2.3, Antoci et al. 2007): water 0.14 m deep and 0.1 m wide held by a rubber gate 0.079 m long and 0.005 m
//   thick, clamped at its top to a rigid wall, its free end on the floor; the water opens it and runs out beneath.
#include <memory>
#include <string>
#include <vector>

#include "column.hpp"
#include "mps/solids/fsi.hpp"

namespace fsi {

enum class Case { plate, gate };
Case case_from_name(const std::string& name);  // "plate" | "gate"

struct Params {
  Case scene = Case::plate;
  double l0 = 0.004;             // spacing of fluid and body [m]; must divide the body's thickness
  double youngs_modulus = 6e6;   // [Pa]
  double poisson_ratio = 0.4;
  double density = 1100.0;       // the body's [kg/m^3]
  bool rigid = false;
  double relaxation = 0.1;       // of the body's load each fluid step (mps::ElasticStructure); 1: taken whole
  // mps::WetWalls: walls next to the liquid's interior carry pressure even when the density test calls them dry. On a
  // moving body that test flickers from step to step, and the result then depends on the load relaxation (docs/fsi.md).
  bool wet_walls = true;
  // conservative: each pressure pair is equal and opposite, so the body gets exactly what the fluid gives;
  // min-reference: the body's load is -V grad P from the corrected gradient, not the reaction of the fluid's push
  // (docs/fsi.md).
  mps::GradientVariant pressure_gradient = mps::GradientVariant::conservative;
  // Khayyer & Gotoh's treatments (mps::set_pressure_treatment). docs/fsi.md's studies were measured with none; the
  // dam break's default, hs, is measured on the plate there too.
  std::string pressure_treatment = "none";
  // Close-pair components (docs/fsi.md's studies: collisions at 0.8 l0, the asymmetry test at 0.9, the dam break's
  // defaults before its dynamic stabilisation); 0 switches one off. The distance is ds's, used when the treatment
  // names ds.
  double collision = 0.8;        // [l0]
  double asymmetry = 0.9;        // fraction of a flat surface's asymmetry
  double stabilisation_distance = mps::SimulationConfig::default_stabilisation_distance;  // [l0]
  double cfl = 0.2;              // the fluid's: dt <= cfl l0 / |u|max
  double solid_cfl = 0.3;
  double end_time = 0.3;         // [s]
  // Jacobi-CG, which "auto" also picks while a free surface changes the unknowns; kept as the spec so that the
  // impact, sensitive to the solve's last digits, repeats docs/fsi.md's runs.
  std::string solver = "eigen-cg:precond=jacobi";
};
// plate: l0 0.004, E 6e6 (the seed also runs 1.2e7 and 2.38e7), nu 0.4 (not given by the seed), to 0.3 s, the
// conservative gradient;
// gate: l0 0.00125, E and nu from the seed's bulk modulus 1.67e7 and shear modulus 3.57e6 (E = 9KG/(3K+G) = 1.0e7,
// nu = 0.40), to 0.4 s, the min-reference gradient (the gate holds still water).
Params defaults(Case c);

struct Sample {
  double time;
  double tip_x, tip_y;  // displacement of the probe point (plate: top centre; gate: free end's centre) [m]
  double force_x;       // the pressure load on the body (elastic: as relaxed and applied) [N per unit depth]
  double level;         // gate: the water level half-way between the left wall and the gate [m]
};

class Scene {
 public:
  explicit Scene(const Params& p);
  void step();  // throws mps::SimulationError if a guard stops the run
  [[nodiscard]] bool done() const { return sim_->time() >= params_.end_time - 1e-12; }
  [[nodiscard]] const mps::Simulation& sim() const { return *sim_; }
  [[nodiscard]] mps::Simulation& sim() { return *sim_; }  // to add components of one's own
  [[nodiscard]] const Params& params() const { return params_; }
  [[nodiscard]] const mps::ElasticStructure* structure() const { return structure_; }  // null when rigid
  [[nodiscard]] const std::vector<Sample>& samples() const { return samples_; }
  [[nodiscard]] std::size_t body_particles() const { return body_particles_; }
  // For a checkpoint: the samples so far (the simulation's own state, the body's included, is Simulation::checkpoint()).
  [[nodiscard]] nlohmann::json save_state() const;
  void restore_state(const nlohmann::json& state);
  // The geometry as built (lengths rounded to whole spacings): the body's lower-left corner, size, and the water's.
  double body_x = 0, body_y = 0, body_width = 0, body_height = 0, water_width = 0, water_height = 0;

 private:
  void sample();
  Params params_;
  std::size_t body_particles_ = 0;
  double probe_x_ = 0, probe_y_ = 0;
  std::unique_ptr<mps::Simulation> sim_;
  mps::ElasticStructure* structure_ = nullptr;
  mps::WallForce* rigid_force_ = nullptr;
  std::vector<Sample> samples_;
};

}  // namespace fsi
