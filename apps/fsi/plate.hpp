#pragma once
// Dam break on an elastic plate (seed 003 §2.4): the classic column (a = 0.146 m wide, 2a high, tank 4a wide) with a
// plate 0.08 m high and 0.012 m thick standing on the floor a in front of the water (its upstream face at x = 2a),
// clamped at its foot. The plate is an mps::ElasticSolid coupled to the fluid by mps::ElasticStructure, or, with
// `rigid`, plain wall and dummy particles of the tank.
#include <array>
#include <memory>
#include <vector>

#include "column.hpp"
#include "mps/fsi.hpp"

namespace fsi {

struct PlateParams {
  double l0 = 0.004;               // spacing of fluid and plate [m]; must divide 0.012 and 0.08
  double column_width = 0.146;     // a; rounded to whole spacings (0.144 at l0 = 0.004)
  double plate_height = 0.08, plate_thickness = 0.012;
  double youngs_modulus = 6e6;     // seed: 6e6, 1.2e7, 2.38e7 Pa
  double poisson_ratio = 0.4;      // not given by the seed: an assumption, recorded in the summary
  double plate_density = 1100.0;
  bool rigid = false;              // the plate as fixed walls
  double solid_cfl = 0.3;
  double relaxation = 0.2;         // of the plate's load each fluid step (mps::ElasticStructure)
  double end_time = 0.6;           // [s]
  std::string solver = "eigen-cg:precond=jacobi";
};

struct PlateSample {
  double time;
  double tip_x, tip_y;  // displacement of the plate's top centre [m]
  double force_x;       // the fluid's pressure force on the plate [N per unit depth]
};

class PlateScene {
 public:
  explicit PlateScene(const PlateParams& p);
  void step();  // throws mps::SimulationError if a guard stops the run
  [[nodiscard]] bool done() const { return sim_->time() >= params_.end_time - 1e-12; }
  [[nodiscard]] const mps::Simulation& sim() const { return *sim_; }
  [[nodiscard]] const PlateParams& params() const { return params_; }
  [[nodiscard]] const mps::ElasticStructure* structure() const { return structure_; }  // null when rigid
  [[nodiscard]] const std::vector<PlateSample>& samples() const { return samples_; }
  [[nodiscard]] double column_width() const { return width_; }
  [[nodiscard]] std::size_t plate_particles() const { return plate_particles_; }

 private:
  void sample();
  PlateParams params_;
  double width_ = 0;
  std::size_t plate_particles_ = 0;
  std::unique_ptr<mps::Simulation> sim_;
  mps::ElasticStructure* structure_ = nullptr;
  std::vector<PlateSample> samples_;
};

}  // namespace fsi
