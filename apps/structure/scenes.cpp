#include "scenes.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

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
  const int nx = cells(plate.length, spacing, "plate's length"), ny = cells(plate.thickness, spacing, "plate's thickness");
  const int clamp = static_cast<int>(std::ceil(radius_spacings));
  mps::ElasticBody body;
  body.spacing = spacing;
  const double volume = spacing * spacing;
  for (int i = -clamp; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      body.add((i + 0.5) * spacing, -0.5 * plate.thickness + (j + 0.5) * spacing, volume, i < 0);
  return body;
}

double plate_initial_velocity(const Plate& plate, const mps::ElasticMaterial& material, double x) {
  if (x <= 0) return 0.0;
  const double kl = 1.875104068711961, k = kl / plate.length;
  auto f = [&](double s) {
    return (std::cos(kl) + std::cosh(kl)) * (std::cosh(k * s) - std::cos(k * s)) +
           (std::sin(kl) - std::sinh(kl)) * (std::sinh(k * s) - std::sin(k * s));
  };
  const double c0 = std::sqrt(material.bulk_modulus() / material.density);
  return plate.velocity_factor * c0 * f(x) / f(plate.length);
}

mps::ElasticBody flag_body(const Flag& flag, double spacing, double radius_spacings) {
  const int ny = cells(flag.thickness, spacing, "flag's thickness");
  const double depth = radius_spacings * spacing;
  mps::ElasticBody body;
  body.spacing = spacing;
  const double volume = spacing * spacing;
  // Columns from the tip back into the cylinder: the tip edge lies exactly at tip_x.
  for (int i = 0;; ++i) {
    const double x = flag.tip_x - (i + 0.5) * spacing;
    bool any = false;
    for (int j = 0; j < ny; ++j) {
      const double y = flag.cy - 0.5 * flag.thickness + (j + 0.5) * spacing, dy = y - flag.cy;
      const double arc = flag.cx + std::sqrt(flag.radius * flag.radius - dy * dy);  // where the flag meets the cylinder
      if (x > arc) {
        body.add(x, y, volume, false);
        any = true;
      } else if (x > arc - depth) {
        body.add(x, y, volume, true);
        any = true;
      }
    }
    if (!any) break;
  }
  return body;
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
