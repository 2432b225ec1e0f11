#pragma once
// Hydrostatic tank: a water column at rest in a walled tank with an open top, in 2-D (a width x H rectangle, gravity
// along -y) or 3-D (a width x width x H box, gravity along -z). After the start-up transient the pressure must be
// rho g (H - height) and the particles must stay where they are.
#include <string>
#include <vector>
#include <nlohmann/json.hpp>

#include "mps/step/step.hpp"

namespace tank {

struct Params {
  double width = 0.4;         // tank and water width [m]
  double water_height = 0.4;  // H [m]
  double l0 = 0.01;           // particle spacing [m]
  double gamma = 0.99;
  double dt = 1e-3;           // dt_max [s]
  double end_time = 1.0;       // [s]: the 1 s
  double window = 0.1;        // pressures averaged over the last `window` seconds
  double band = 4.0;          // height of the averaging bands, in l0
  std::string solver = "auto";
  double g = 9.81;
  std::string pressure_treatment = "none";  // mps::set_pressure_treatment's names (hs, hl, ecs, cfs, gc)
};

struct Band {
  double y_center, mean_pressure, exact_pressure, relative_error;
  int samples;
};

struct Result {
  std::vector<Band> bands;           // bottom to top
  double max_error_below_top = 0;    // max relative band error, top band excluded
  double max_displacement_l0 = 0;    // largest distance a fluid particle ended from its start, in l0
  int steps = 0;
  double time = 0;
  std::string dt_limit;
  int fluid = 0, boundary = 0;
};

template <int D = 2>
mps::BasicParticles<D> make_particles(const Params& p);
template <int D = 2>
mps::BasicDomain<D> make_domain(const Params& p);
template <int D = 2>
mps::SimulationConfig make_config(const Params& p);

// The scene in progress: step() advances the simulation and samples band pressures over the final window.
template <int D>
class BasicTank {
 public:
  explicit BasicTank(const Params& p);
  void step();  // throws mps::SimulationError if the guard stops the run; sim() then holds the last good state
  [[nodiscard]] bool done() const { return sim_.time() >= params_.end_time - 1e-12; }
  [[nodiscard]] Result result() const;
  [[nodiscard]] const mps::BasicSimulation<D>& sim() const { return sim_; }
  [[nodiscard]] mps::BasicSimulation<D>& sim() { return sim_; }  // to add components of one's own
  [[nodiscard]] const Params& params() const { return params_; }
  // For a checkpoint: the band sums so far (the simulation's own state is Simulation::checkpoint()).
  [[nodiscard]] nlohmann::json save_state() const;
  void restore_state(const nlohmann::json& state);

 private:
  Params params_;
  mps::BasicParticles<D> initial_;
  mps::BasicSimulation<D> sim_;
  double band_h_;
  std::vector<double> sum_;
  std::vector<int> samples_;
};
using Tank = BasicTank<2>;
using Tank3 = BasicTank<3>;

}  // namespace tank
