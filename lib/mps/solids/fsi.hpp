#pragma once
/// \file
/// Fluid-structure coupling (seed 003 §2.3-2.4; docs/fsi.md): an elastic body whose moving particles are also wall and
/// dummy particles of the fluid (the seed's idea: they belong to both media). The fluid sees them as a moving wall at
/// the solid's velocity; the solid feels the pressure the fluid solved for on them (structure_load).
///
/// In a fluid step n -> n+1 (staggered, explicit): after the predictor the solid is advanced to t^{n+1} in sub-steps
/// of its own stable step under the fluid force of step n, and its particles are moved there in the fluid; after the
/// pressure solve the new pair forces become the solid's load for the next step.
#include <array>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "mps/solids/elastic.hpp"
#include "mps/step/step.hpp"

namespace mps {

/// The fluid's pressure force on each particle with target[j], written to (fx, fy) (0 elsewhere) with its sum returned;
/// call at after_pressure. Which one depends on the fluid's pressure gradient:
/// - pressure_force_on, for min-reference and the other difference forms: -V_j grad P_j (V_j = l0^2), the gradient
///   corrected over the pressure carriers. Summed over a body it is the surface integral of -P n (Archimedes for a
///   body in still water). The fluid's min-reference pairs are not antisymmetric, so no pair-by-pair reaction exists:
///   the fluid does not get back exactly this force.
/// - pressure_reaction_on, for the conservative gradient: minus the terms the targets give the moving fluid's pressure
///   force, pair by pair, so the body gets exactly what the fluid gives (action = reaction to round-off).
/// Both need the whole pressure (hydrostatic_split = false) and throw std::invalid_argument otherwise.
///
/// @{
std::array<double, 2> pressure_force_on(const StepContext& context, std::span<const char> target, std::span<double> fx,
                                        std::span<double> fy);
std::array<double, 2> pressure_reaction_on(const StepContext& context, std::span<const char> target,
                                           std::span<double> fx, std::span<double> fy);
/// @}
/// The one of the two that fits the fluid's pressure gradient.
std::array<double, 2> structure_load(const StepContext& context, std::span<const char> target, std::span<double> fx,
                                     std::span<double> fy);

/// Measures the fluid's pressure force on a rigid wall group (its wall and dummy particles) each step, by
/// structure_load; the wall itself is not moved by it.
class WallForce : public StepComponent {
 public:
  explicit WallForce(int group) : group_(group) {}  ///< measures the force on group `group`
  void after_pressure(StepContext& context) override;
  void mark_rows_read(const Particles& particles, std::span<char> rows) const override;  ///< its dummies' rows
  [[nodiscard]] std::array<double, 2> force() const { return force_; }  ///< the last step's [N per unit depth]

 private:
  int group_;
  std::vector<char> target_;
  std::vector<double> fx_, fy_;
  std::array<double, 2> force_{0.0, 0.0};
};

/// An elastic solid coupled to the fluid (see the file's notes): its moving particles are the fluid's wall and dummy
/// particles of one group, moved with the solid, and the fluid's pressure force on them is the solid's load.
class ElasticStructure : public StepComponent {
 public:
  /// The fluid particles of `group` with id = first_id + k are the body's k-th moving particle (in ElasticBody order,
  /// clamped particles skipped, which the fluid does not hold): a scene adds them to the fluid in that order.
  /// `inside_reference(X, Y)` says whether a reference point lies in the body, for counting fluid that got in.
  /// `relaxation` in (0, 1]: each step the load moves this fraction of the way to the new pressure force (1: all of
  /// it), a low-pass filter with time constant dt / relaxation against MPS's step-to-step wall-pressure noise.
  ElasticStructure(ElasticSolid solid, int group, int first_id, std::function<bool(double, double)> inside_reference,
                   double relaxation = 1.0);

  void before_predictor(StepContext& context) override;
  void after_predictor(StepContext& context) override;
  void after_pressure(StepContext& context) override;
  void after_corrector(StepContext& context) override;
  void mark_rows_read(const Particles& particles, std::span<char> rows) const override;  ///< its dummies' rows

  [[nodiscard]] const ElasticSolid& solid() const { return solid_; }  ///< the solid, as stepped so far
  [[nodiscard]] int group() const { return group_; }  ///< the fluid particles' group that are its moving particles
  /// @{ The last step's pressure force on the structure [N per unit depth], and the load it applies (relaxed).
  [[nodiscard]] std::array<double, 2> force_on_structure() const { return on_structure_; }
  [[nodiscard]] std::array<double, 2> load() const;
  /// @}
  [[nodiscard]] int substeps() const { return substeps_; }  ///< of the solid in the last fluid step
  /// @{ For a checkpoint: the solid's state (ElasticSolid::save_state), the relaxed load and the last step's force.
  [[nodiscard]] nlohmann::json save_state() const override;
  void restore_state(const nlohmann::json& state) override;
  /// @}
  /// @{ Wall-clock seconds spent so far advancing the solid, and in the coupling itself (mapping, load, fluid-inside
  /// test).
  [[nodiscard]] double solid_seconds() const { return solid_seconds_; }
  [[nodiscard]] double coupling_seconds() const { return coupling_seconds_; }
  /// @}

 private:
  void map_particles(const Particles& particles);

  ElasticSolid solid_;
  int group_ = 0, first_id_ = 0;
  std::function<bool(double, double)> inside_reference_;
  std::vector<int> fluid_of_solid_;  // solid index -> fluid particle index this step (-1: clamped, not in the fluid)
  std::vector<char> target_;
  std::vector<double> fx_, fy_, load_x_, load_y_;
  std::array<double, 2> on_structure_{0.0, 0.0};
  double relaxation_ = 1.0;
  int substeps_ = 0;
  double solid_seconds_ = 0, coupling_seconds_ = 0;
};

}  // namespace mps
