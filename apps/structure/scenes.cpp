#include "scenes.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "mps/boundaries/geometry.hpp"

namespace structure {

namespace {

// How many spacings fit a length, refusing a spacing that does not divide it (the body's edges would move).
int cells(double length, double spacing, const char* what) {
  const double n = length / spacing;
  if (std::abs(n - std::round(n)) > 1e-6 * n || std::round(n) < 1)
    throw std::invalid_argument(std::string("the spacing ") + std::to_string(spacing) + " m does not divide the " +
                                what + " (" + std::to_string(length) + " m): pick one that does");
  return static_cast<int>(std::round(n));
}

}  // namespace

mps::ElasticBody plate_body(const Plate& plate, double spacing, double radius_spacings) {
  const mps::BodyLattice lattice{0.0, -0.5 * plate.thickness, cells(plate.length, spacing, "plate's length"),
                                 cells(plate.thickness, spacing, "plate's thickness"), spacing};
  return mps::clamped_box_body(lattice, mps::x_low, static_cast<int>(std::ceil(radius_spacings)));
}

double plate_initial_velocity(const Plate& plate, const mps::ElasticMaterial& material, double x) {
  const double tip = plate.velocity_factor * std::sqrt(material.bulk_modulus() / material.density);
  return tip * mps::cantilever_first_mode(x, plate.length);
}

mps::ElasticBody flag_body(const Flag& flag, double spacing, double radius_spacings) {
  // From where the flag leaves the cylinder at its centre line, as a scene file lays it, when the spacing divides its
  // length; else back from the tip (H/5 is 87.5 spacings), so that the tip stays where the benchmark puts it.
  const double root = flag.cx + flag.radius, cells_along = (flag.tip_x - root) / spacing;
  const int nx = static_cast<int>(std::ceil(cells_along - 1e-6));
  const bool whole = std::abs(cells_along - std::round(cells_along)) <= 1e-6 * cells_along;
  const mps::BodyLattice lattice{whole ? root : flag.tip_x - nx * spacing, flag.cy - 0.5 * flag.thickness, nx,
                                 cells(flag.thickness, spacing, "flag's thickness"), spacing};
  return mps::cylinder_clamped_box_body(lattice, flag.cx, flag.cy, flag.radius,
                                        static_cast<int>(std::ceil(radius_spacings)));
}

Oscillation oscillation(const std::vector<double>& t, const std::vector<double>& u) {
  Oscillation o;
  if (u.size() < 3) return o;
  const auto [lo, hi] = std::minmax_element(u.begin(), u.end());
  o.mean = 0.5 * (*hi + *lo);
  o.amplitude = 0.5 * (*hi - *lo);
  std::vector<double> at;
  for (std::size_t k = 1; k + 1 < u.size(); ++k) {
    if (!(u[k] < u[k - 1] && u[k] <= u[k + 1])) continue;
    // Vertex of the parabola through the three samples (uniform or not).
    const double t0 = t[k - 1], t1 = t[k], t2 = t[k + 1];
    const double d1 = (u[k] - u[k - 1]) / (t1 - t0), d2 = (u[k + 1] - u[k]) / (t2 - t1);
    const double curvature = (d2 - d1) / (t2 - t0);
    at.push_back(curvature > 0 ? 0.5 * (t0 + t1) - d1 / (2 * curvature) : t1);
  }
  o.minima = static_cast<int>(at.size());
  if (at.size() >= 2) o.frequency = static_cast<double>(at.size() - 1) / (at.back() - at.front());
  return o;
}

double zero_crossing_period(const std::vector<double>& t, const std::vector<double>& u) {
  std::vector<double> at;
  for (std::size_t k = 1; k < u.size(); ++k)
    if (u[k - 1] < 0 && u[k] >= 0) at.push_back(t[k - 1] + (t[k] - t[k - 1]) * (-u[k - 1]) / (u[k] - u[k - 1]));
  if (at.size() < 2) return std::numeric_limits<double>::quiet_NaN();
  return (at.back() - at.front()) / static_cast<double>(at.size() - 1);
}

std::vector<std::vector<double>> read_csv_columns(const std::string& path, std::size_t columns) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path + ": check --data");
  std::string line;
  std::getline(in, line);  // header
  std::vector<std::vector<double>> out(columns);
  int row = 1;
  while (std::getline(in, line)) {
    ++row;
    if (line.empty()) continue;
    std::stringstream ss(line);
    std::string cell;
    for (std::size_t c = 0; c < columns; ++c) {
      if (!std::getline(ss, cell, ',')) throw std::runtime_error(path + ":" + std::to_string(row) + ": too few columns");
      std::size_t used = 0;
      double v = 0;
      try {
        v = std::stod(cell, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used == 0 || !std::isfinite(v))
        throw std::runtime_error(path + ":" + std::to_string(row) + ": '" + cell + "' is not a number");
      out[c].push_back(v);
    }
  }
  if (out[0].size() < 3) throw std::runtime_error(path + " holds fewer than 3 rows");
  return out;
}

}  // namespace structure
