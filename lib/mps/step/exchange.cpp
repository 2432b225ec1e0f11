#include "mps/step/exchange.hpp"

namespace mps {

template <int D>
PpeCounts BasicSerialExchange<D>::assemble(const BasicStencil<D>& laplacian, std::span<const char> held,
                                           std::span<const double> source, std::span<const double> held_value,
                                           double shift, OpenSupport open, PpeRows rows) {
  assemble_ppe<D>(laplacian, held, source, ppe_, held_value, shift, ClosedGroups::gauge, open, rows);
  return {ppe_.solved_rows(), ppe_.floating.size()};
}

template <int D>
SolveReport BasicSerialExchange<D>::solve(LinearSolver& solver, Particles& particles, bool from_zero,
                                          bool clamp_negative, std::span<const double> offset) {
  if (from_zero) pressure_.assign(ppe_.size(), 0.0);
  else ppe_.gather(particles, pressure_, offset);
  SolveReport report;
  if (ppe_.size() > 0) report = solver.solve(ppe_.matrix, ppe_.rhs, pressure_);
  ppe_.scatter(pressure_, particles, clamp_negative, offset);
  return report;
}

template class BasicSerialExchange<2>;
template class BasicSerialExchange<3>;

}  // namespace mps
