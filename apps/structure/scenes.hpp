#pragma once
// Elastic structure scenes (seed 003 §2.2): the oscillating plate of Gray, Monaghan & Swift (2001) and Turek & Hron's
// CSM3 flag under gravity, each built as an mps::ElasticBody with its probe point and reference values.
#include <string>
#include <utility>
#include <vector>

#include "mps/solids/elastic.hpp"

namespace structure {

// The plate: L = 0.2 m long (x from the clamp at 0), H = 0.02 m thick (y in [-H/2, H/2]); E = 2e6 Pa, nu = 0.3975,
// rho = 1000. The clamp is a band of particles continuing the lattice to x < 0, as deep as the kernel radius, held
// at rest: the moving particles near x = 0 see displacement zero beyond it (u = 0 on x <= 0).
struct Plate {
  double length = 0.2, thickness = 0.02;
  double velocity_factor = 0.01;  // V_f of seed eq. 13
  [[nodiscard]] mps::ElasticMaterial material(mps::ElasticModel model) const {
    return {1000.0, 2e6, 0.3975, model};
  }
};
mps::ElasticBody plate_body(const Plate& plate, double spacing, double radius_spacings);
// v_y(x) = V_f c0 mps::cantilever_first_mode(x, L), c0 = sqrt(K / rho) (the 3-D bulk modulus): the first mode at the
// tip's velocity V_f c0 (seed eq. 13-14); 0 for x <= 0.
double plate_initial_velocity(const Plate& plate, const mps::ElasticMaterial& material, double x);
// Reference of the same plane-strain plate, linear elasticity: Q9 finite elements with modal superposition,
// Richardson-extrapolated over meshes to 160 x 16 (bench/plate_reference.py).
struct PlateReference {
  static constexpr double period = 0.255225;     // first mode [s]
  static constexpr double amplitude = 0.023038;  // max |u_y| at the tip over 5 periods [m]
  static constexpr double first_max = 0.023025;  // the first maximum [m] (t = 0.064 s)
  static constexpr double euler_bernoulli_period = 0.254032;
};

// CSM3 (Turek & Hron 2006): a flag 0.35 m long and 0.02 m thick hanging from a rigid cylinder (centre (0.2, 0.2),
// radius 0.05) under g = 2 m/s^2; St. Venant-Kirchhoff, rho = 1000, nu = 0.4, mu = 0.5e6 (E = 1.4e6). The clamp: the
// lattice of the flag, laid from where it leaves the cylinder (0.25, 0.19) (from the tip if the spacing does not
// divide its length), continued into the cylinder (mps::cylinder_clamped_box_body), so the flag is held along the arc
// it is attached to and free above and below.
struct Flag {
  double cx = 0.2, cy = 0.2, radius = 0.05, tip_x = 0.6, thickness = 0.02, gravity = 2.0;
  [[nodiscard]] static mps::ElasticMaterial material() { return {1000.0, 1.4e6, 0.4, mps::ElasticModel::saint_venant_kirchhoff}; }
};
mps::ElasticBody flag_body(const Flag& flag, double spacing, double radius_spacings);

// A signal's oscillation as Turek & Hron report it: mean = (max + min) / 2, amplitude = (max - min) / 2 over the
// samples, frequency = 1 / the mean spacing of the local minima (each refined by a parabola through its three samples).
struct Oscillation {
  double mean = 0, amplitude = 0, frequency = 0;
  int minima = 0;
};
Oscillation oscillation(const std::vector<double>& t, const std::vector<double>& u);
// The mean spacing of upward zero crossings (linear interpolation); NaN with fewer than two.
double zero_crossing_period(const std::vector<double>& t, const std::vector<double>& u);

// Reads a CSV with a header line (time first); the columns as numbers. Throws std::runtime_error naming the file.
std::vector<std::vector<double>> read_csv_columns(const std::string& path, std::size_t columns);

}  // namespace structure
