#pragma once
// Fluid-structure coupling (seed 003 §2.3-2.4; docs/fsi.md): an elastic body whose moving particles are also wall and
// dummy particles of the fluid. The fluid sees them as a moving wall at the solid's velocity; the solid feels the
// fluid through the corrector's own pressure pairs (mps::pressure_pair_reactions), so the force the fluid gets from
// the body and the force the body gets from the fluid cancel pair by pair, and this component checks that each step.
//
// In a fluid step n -> n+1 (staggered, explicit): after the predictor the solid is advanced to t^{n+1} in sub-steps
// of its own stable step under the fluid force of step n, and its particles are moved there in the fluid; after the
// pressure solve the new pair forces become the solid's load for the next step.
#include <array>
#include <functional>
#include <string>
#include <vector>

#include "mps/elastic.hpp"
#include "mps/step.hpp"

namespace mps {

class ElasticStructure : public StepComponent {
 public:
  // The fluid particles of `group` with id = first_id + k are the body's k-th moving particle (in ElasticBody order,
  // clamped particles skipped, which the fluid does not hold): a scene adds them to the fluid in that order. `inside_reference(X, Y)` says whether a
  // reference point lies in the body, for counting fluid that got in.
  ElasticStructure(ElasticSolid solid, int group, int first_id, std::function<bool(double, double)> inside_reference);

  void before_predictor(StepContext& context) override;
  void after_predictor(StepContext& context) override;
  void after_pressure(StepContext& context) override;
  void after_corrector(StepContext& context) override;

  [[nodiscard]] const ElasticSolid& solid() const { return solid_; }
  // The last step's pressure force on the structure and on the fluid from it [N per unit depth]: they sum to zero.
  [[nodiscard]] std::array<double, 2> force_on_structure() const { return on_structure_; }
  [[nodiscard]] std::array<double, 2> force_on_fluid() const { return on_fluid_; }
  [[nodiscard]] int substeps() const { return substeps_; }  // of the solid in the last fluid step

 private:
  void map_particles(const Particles& particles);

  ElasticSolid solid_;
  int group_ = 0, first_id_ = 0;
  std::function<bool(double, double)> inside_reference_;
  std::vector<int> fluid_of_solid_;  // solid index -> fluid particle index this step (-1: clamped, not in the fluid)
  std::vector<char> target_, acting_;
  std::vector<double> fx_, fy_, load_x_, load_y_;
  std::array<double, 2> on_structure_{0.0, 0.0}, on_fluid_{0.0, 0.0};
  int substeps_ = 0;
};

}  // namespace mps
