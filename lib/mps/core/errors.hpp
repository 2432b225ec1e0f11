#pragma once
/// \file
/// The error a simulation step throws when it cannot be completed.
#include <stdexcept>

namespace mps {

/// A step that could not be completed: unstable motion, a failed solve, an inlet out of particles. The
/// simulation's state is that of the last good step.
class SimulationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace mps
