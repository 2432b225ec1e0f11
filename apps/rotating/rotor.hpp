#pragma once
// Rotating boundaries (seed 000; design §6 "Rotating boundary"):
//  couette: a full annulus R1 < r < R2, the inner cylinder turning counter-clockwise at omega, the outer one
//           at rest; steady u_theta = A r + B/r, A = -omega R1^2/(R2^2 - R1^2), B = omega R1^2 R2^2/(R2^2 - R1^2);
//  channel: seed 000's screw channel. A barrel of radius R2 about the origin and a channel, the annular sector
//           R1 < r < R2 of `span` radians closed by a bottom at R1 and two radial flights, turning clockwise
//           at omega. Two models of the same flow:
//             moving: the bottom and flights (group 1) turn rigidly; the barrel particles over the opening
//                     (group 2) follow the channel in position but stay at rest (mps::RigidMotion);
//             fixed:  nothing moves (the channel's own frame); the barrel particles carry the barrel's
//                     relative velocity, counter-clockwise omega r.
// The closed domains take the library's all-Neumann PPE treatment (zero-mean pressure). Walls are one wall
// layer and four dummy layers; fluid on concentric rings. The circular walls (cylinders, bottom, barrel) take
// mirror velocities across the circle (mps::MirrorWall with a radius) unless `mirror` is off; the flights, and
// with `mirror` off every wall, carry the wall velocity itself (seed 000's static particles).
// couette in 3-D (dim 3): the annulus extruded along z over period_layers() spacings, periodic in z, the cylinders'
// axis along z; the same walls (mps::MirrorNoSlip3 on the cylinders) and numerics but for the kernel radii (3.1 l0
// for the Laplacian and density, the 3-D channels' choice: a third of the 4.1 l0 sphere's neighbours).
// Results are read in the channel's frame: angle phi from the channel's centre line (phi = 0 points along +y
// at t = 0; the barrel moves towards +phi relative to the channel), velocities less the channel's rotation.
#include <string>
#include <vector>
#include <nlohmann/json.hpp>

#include "mps/step/step.hpp"

namespace rotating {

enum class Scene { couette, channel };
enum class Model { moving, fixed };
Scene parse_scene(const std::string& name);  // "couette" | "channel"
Model parse_model(const std::string& name);  // "moving" | "fixed"
std::string to_string(Scene scene);
std::string to_string(Model model);

// Channel: inner = the bottom, outer = the barrel, and the two flights.
inline constexpr int kFluidGroup = 0, kInnerGroup = 1, kOuterGroup = 2, kFlightGroup = 3;

struct Params {
  Scene scene = Scene::channel;
  Model model = Model::moving;
  double R1 = 1, R2 = 2;   // inner radius (couette: turning cylinder; channel: its bottom), outer (the barrel)
  double span = 1;         // channel: opening angle [rad]
  double omega = 1;        // couette: inner cylinder, counter-clockwise; channel: the channel, clockwise [rad/s]
  double rho = 1, nu = 1;
  int dim = 2;              // 3: couette only, the annulus extruded along z, periodic in z
  double across = 49;      // fluid rings across the gap, l0 = (R2 - R1)/across; 49: seed 000's 3,626 fluid particles
  // Small: the density part of the source turns layout errors into pressure ~ gamma rho dn/dt^2, which grows with
  // resolution at a viscous dt; shifting keeps the layout even instead (docs/rotating.md).
  double gamma = 0.01;
  double dt_factor = 1;    // multiplies both time-step limits (CFL 0.2, viscous number 0.2)
  bool mirror = true;      // mirror velocities on the circular walls
  mps::GradientVariant gradient = mps::GradientVariant::corrected_min_reference;
  bool initial_reference = true;  // the density source against the packing at t = 0, not the lattice n0
  std::string solver = "auto";
  bool warm_start = true;  // pressure solve from the previous step's pressure (false: from zeros)
  // Particle shifting coefficient (SimulationConfig::shifting; 0: off). The corner flow tears the layout open at
  // the upstream corner and packs it at the downstream one; with little density control left (gamma above) the
  // shift is what keeps it even.
  double shifting = 1;

  [[nodiscard]] double l0() const { return (R2 - R1) / across; }
  // Velocity scale: the wall speed, omega R1 (couette) or omega R2 (channel: the barrel relative to it).
  [[nodiscard]] double U() const { return omega * (scene == Scene::couette ? R1 : R2); }
  [[nodiscard]] double reynolds() const { return U() * (R2 - R1) / nu; }
  [[nodiscard]] double diffusion_time() const { return (R2 - R1) * (R2 - R1) / nu; }
  void validate() const;  // throws std::invalid_argument naming the bad parameter and its valid range
};

double couette_exact(const Params& p, double r);  // steady u_theta(r)

mps::Particles make_particles(const Params& p);  // the 2-D layout (in 3-D, each layer's)
// Sets up the walls' motion (and their velocities at t = 0).
mps::Simulation make_simulation(const Params& p);
// 3-D couette: layers along z, the smallest whole number of spacings a periodic axis may have (three search radii).
int period_layers(const Params& p);
mps::Particles3 make_particles3(const Params& p);
mps::Simulation3 make_simulation3(const Params& p);

// The channel frame: rotation of the channel at time t (moving model: -omega t; otherwise 0) and its rate.
double frame_angle(const Params& p, double time);
double frame_rate(const Params& p);

// Relative velocity in the lab axes (velocity less the frame's rotation), per particle: the field written to
// the frames.
void relative_velocity(const Params& p, const mps::Particles& s, std::vector<double>& ur, std::vector<double>& vr);

// Averages over particles near a line and over the samples taken (as the Poiseuille ProfileSampler does):
//  couette: u_theta of all fluid in rings of width l0 (axis: r);
//  line1:   relative u_theta / (omega R2) of the fluid within l0 of the channel's radial centre line, in bins of
//           l0 along r (axis: r);
//  arc2:    relative u_r / (omega R2) of the fluid within l0 of r = (R1 + R2)/2, in bins of l0 along the arc
//           (axis: phi);
//  barrel:  pressure of the barrel's wall particles, one bin per particle of the ring (axis: phi).
struct Curve {
  std::vector<double> axis, value, exact;  // exact: couette only
  std::vector<long> count;
};

class LineSampler {
 public:
  enum class Line { couette, line1, arc2, barrel };
  LineSampler(const Params& p, Line line);
  template <int D>
  void add(const mps::BasicSimulation<D>& sim);  // in 3-D every layer along z alike
  [[nodiscard]] Curve result() const;  // every bin; NaN where no particle was sampled
  [[nodiscard]] int samples() const { return samples_; }
  void clear();
  // For a checkpoint: the sums so far.
  [[nodiscard]] nlohmann::json save_state() const;
  void restore_state(const nlohmann::json& state);

 private:
  Params p_;
  Line line_;
  double lo_ = 0, width_ = 0;
  std::vector<double> sum_;
  std::vector<long> count_;
  int samples_ = 0;
};

// Measures on curves; NaN bins are skipped.
double couette_max_error(const Curve& c);  // max |u - exact| over the bins, in the curve's units
// Largest |f(a) + f(-a)| over bins within |a| <= limit, f interpolated linearly at -a: zero for an odd f.
double odd_defect(const Curve& c, double limit);
// Largest |f(x) - g(x)| over f's bins, g interpolated linearly at f's axis values (inside g's range).
double max_difference(const Curve& f, const Curve& g);
// Range (max - min) of a curve over |axis| <= limit.
double range(const Curve& c, double limit);

// Fluid particles outside the fluid region (channel frame: R1 < r < R2 and, for the channel, |phi| < span/2).
template <int D>
long escaped_particles(const Params& p, const mps::BasicSimulation<D>& sim);
// 3-D: the largest |w| of the fluid, the velocity along the axis, which the exact flow does not have.
double max_axial_speed(const mps::Simulation3& sim);

}  // namespace rotating
