#include "mps/acoustics/acoustic.hpp"
#include "mps/core/state.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <limits>
#include <map>
#include <numbers>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "mps/step/step.hpp"

namespace mps {
namespace {

using Index = std::ptrdiff_t;

// Below this many rows a stage costs less than waking a second thread (and, on a loaded machine, far less
// than waiting for it at the barrier).
constexpr Index kParallelRows = 16384;

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

bool positive(double v) { return v > 0.0 && std::isfinite(v); }

// ---- quadrature -----------------------------------------------------------------------------------------

struct GaussRule {
  std::vector<double> x, w;  // on [-1, 1]
};

// Nodes by Newton's method on the three-term Legendre recurrence, from the usual cosine first guesses.
GaussRule gauss_legendre(int n) {
  GaussRule g{std::vector<double>(static_cast<std::size_t>(n)), std::vector<double>(static_cast<std::size_t>(n))};
  for (int i = 0; i < (n + 1) / 2; ++i) {
    double z = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5));
    double dp = 1.0;
    for (int iteration = 0; iteration < 100; ++iteration) {
      double p0 = 1.0, p1 = z;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (z * p1 - p0) / (z * z - 1.0);
      const double step = p1 / dp;
      z -= step;
      if (std::abs(step) < 1e-16) break;
    }
    const auto lo = static_cast<std::size_t>(i), hi = static_cast<std::size_t>(n - 1 - i);
    g.x[lo] = -z;
    g.x[hi] = z;
    g.w[lo] = g.w[hi] = 2.0 / ((1.0 - z * z) * dp * dp);
  }
  return g;
}

struct PulseIntegrand {
  double four_a, ct, r;
  [[nodiscard]] std::pair<double, double> operator()(double xi) const {
    const double e = std::exp(-xi * xi / four_a) * xi;
    return {e * std::cos(xi * ct) * std::cyl_bessel_j(0.0, xi * r), e * std::sin(xi * ct) * std::cyl_bessel_j(1.0, xi * r)};
  }
};

std::pair<double, double> apply_rule(const GaussRule& g, const PulseIntegrand& f, double a, double b) {
  const double half = 0.5 * (b - a), mid = 0.5 * (a + b);
  double sp = 0.0, su = 0.0;
  for (std::size_t k = 0; k < g.x.size(); ++k) {
    const auto [fp, fu] = f(mid + half * g.x[k]);
    sp += g.w[k] * fp;
    su += g.w[k] * fu;
  }
  return {half * sp, half * su};
}

std::pair<double, double> adaptive_panel(const PulseIntegrand& f, double a, double b, double tolerance, int depth) {
  static const GaussRule g16 = gauss_legendre(16), g8 = gauss_legendre(8);
  const auto fine = apply_rule(g16, f, a, b);
  const auto coarse = apply_rule(g8, f, a, b);
  const double error = std::max(std::abs(fine.first - coarse.first), std::abs(fine.second - coarse.second));
  if (error <= tolerance || depth >= 40) return fine;
  const double mid = 0.5 * (a + b);
  const auto left = adaptive_panel(f, a, mid, 0.5 * tolerance, depth + 1);
  const auto right = adaptive_panel(f, mid, b, 0.5 * tolerance, depth + 1);
  return {left.first + right.first, left.second + right.second};
}

void check_pulse(double half_width, double c0, double age, double tolerance) {
  if (!positive(half_width))
    throw std::invalid_argument("Gaussian pulse: half-width b must be positive, got " + fmt(half_width));
  if (!positive(c0)) throw std::invalid_argument("Gaussian pulse: speed of sound c0 must be positive, got " + fmt(c0));
  if (!(age >= 0.0) || !std::isfinite(age))
    throw std::invalid_argument("Gaussian pulse: age t - t_emit must be >= 0, got " + fmt(age));
  if (!positive(tolerance)) throw std::invalid_argument("Gaussian pulse: tolerance must be positive, got " + fmt(tolerance));
}

// ---- particles on the lattice ----------------------------------------------------------------------------

int cells(double length, double l0) { return static_cast<int>(std::lround(length / l0)); }

// Virtual layers needed so that every interior particle sees a full neighbourhood: offsets m l0 < re.
int virtual_layers(double radius) { return std::max(1, static_cast<int>(std::ceil(radius - 1e-9)) - 1); }

GradientMatrices interior_rows(GradientMatrices g, std::size_t rows) {
  for (CsrMatrix* m : {&g.x, &g.y}) {
    m->rows = static_cast<int>(rows);
    m->row_ptr.resize(rows + 1);
    const auto nnz = static_cast<std::size_t>(m->row_ptr.back());
    m->col.resize(nnz);
    m->val.resize(nnz);
  }
  return g;
}

// The normal equations M c = e_k of the 9-coefficient weighted least-squares fit, by Cholesky. factor() fails
// when M is not safely positive definite (a pivot below 1e-12 of the largest diagonal): neighbours too few or
// too one-sided to determine a cubic.
struct SmallCholesky {
  static constexpr std::size_t n = 9;
  std::array<std::array<double, n>, n> a{};
  void add(double w, const std::array<double, n>& b) {
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = 0; j <= i; ++j) a[i][j] += w * b[i] * b[j];
  }
  bool factor() {
    double scale = 0.0;
    for (std::size_t i = 0; i < n; ++i) scale = std::max(scale, a[i][i]);
    for (std::size_t j = 0; j < n; ++j) {
      double d = a[j][j];
      for (std::size_t k = 0; k < j; ++k) d -= a[j][k] * a[j][k];
      if (!(d > 1e-12 * scale)) return false;
      a[j][j] = std::sqrt(d);
      for (std::size_t i = j + 1; i < n; ++i) {
        double s = a[i][j];
        for (std::size_t k = 0; k < j; ++k) s -= a[i][k] * a[j][k];
        a[i][j] = s / a[j][j];
      }
    }
    return true;
  }
  [[nodiscard]] std::array<double, n> solve(std::size_t unit) const {
    std::array<double, n> x{};
    x[unit] = 1.0;
    for (std::size_t i = 0; i < n; ++i) {  // L y = e
      for (std::size_t k = 0; k < i; ++k) x[i] -= a[i][k] * x[k];
      x[i] /= a[i][i];
    }
    for (std::size_t i = n; i-- > 0;) {  // L^T x = y
      for (std::size_t k = i + 1; k < n; ++k) x[i] -= a[k][i] * x[k];
      x[i] /= a[i][i];
    }
    return x;
  }
};

double rk4_amplification(std::complex<double> z) {
  return std::abs(1.0 + z * (1.0 + z * (0.5 + z * (1.0 / 6.0 + z / 24.0))));
}

}  // namespace

// ---- exact solution -----------------------------------------------------------------------------------

PulseProfile gaussian_pulse_exact(double r, double age, double half_width, double c0, double tolerance) {
  check_pulse(half_width, c0, age, tolerance);
  r = std::abs(r);
  const double a = std::numbers::ln2 / (half_width * half_width);
  // Tail beyond xi_max: int (1/(2a)) exp(-xi^2/(4a)) xi dxi = exp(-xi_max^2/(4a)) = tolerance / 10.
  const double xi_max = std::sqrt(4.0 * a * std::log(10.0 / tolerance));
  const double ct = c0 * age;
  // cos(xi ct) J0(xi r) oscillates with period 2 pi / (ct + r) at most: one panel per period.
  const int panels = static_cast<int>(std::ceil(xi_max * (ct + r) / (2.0 * std::numbers::pi))) + 2;
  const PulseIntegrand f{4.0 * a, ct, r};
  // The integrals are scaled by 1/(2a) at the end; the panel tolerances are in the unscaled units.
  const double panel_tolerance = 0.9 * tolerance * 2.0 * a / panels;
  double sp = 0.0, su = 0.0;
  for (int k = 0; k < panels; ++k) {
    const auto [ip, iu] = adaptive_panel(f, xi_max * k / panels, xi_max * (k + 1) / panels, panel_tolerance, 0);
    sp += ip;
    su += iu;
  }
  return {sp / (2.0 * a), su / (2.0 * a)};
}

PulseTable::PulseTable(double half_width, double c0, double age, double tolerance, double r_needed) {
  check_pulse(half_width, c0, age, tolerance);
  h_ = half_width / 32.0;
  age_ = age;
  r_max_ = c0 * age + 6.5 * half_width;
  r_table_ = std::min(r_max_, r_needed);
  const auto n = static_cast<Index>(std::ceil(r_table_ / h_)) + 3;
  p_.assign(static_cast<std::size_t>(n), 0.0);
  u_.assign(static_cast<std::size_t>(n), 0.0);
#pragma omp parallel for schedule(dynamic, 8)
  for (Index k = 0; k < n; ++k) {
    const PulseProfile v = gaussian_pulse_exact(static_cast<double>(k) * h_, age, half_width, c0, tolerance);
    p_[static_cast<std::size_t>(k)] = v.pressure;
    u_[static_cast<std::size_t>(k)] = v.radial_velocity;
  }
}

PulseProfile PulseTable::at(double r) const {
  r = std::abs(r);
  if (r > r_max_) return {};
  if (r > r_table_) throw std::out_of_range("PulseTable: r = " + fmt(r) + " beyond the tabulated " + fmt(r_table_));
  const double s = r / h_;
  const auto k = static_cast<long>(std::floor(s));
  const double t = s - static_cast<double>(k);
  const double weights[4] = {-t * (t - 1) * (t - 2) / 6.0, (t + 1) * (t - 1) * (t - 2) / 2.0,
                             -(t + 1) * t * (t - 2) / 2.0, (t + 1) * t * (t - 1) / 6.0};
  PulseProfile out;
  for (long m = 0; m < 4; ++m) {
    const long node = k - 1 + m;
    // Reflect through r = 0: the pressure is even in r, the radial velocity odd.
    const auto at = static_cast<std::size_t>(std::abs(node));
    if (at >= p_.size()) continue;
    out.pressure += weights[m] * p_[at];
    out.radial_velocity += weights[m] * (node < 0 ? -u_[at] : u_[at]);
  }
  return out;
}

AcousticField exact_acoustic_field(std::span<const double> x, std::span<const double> y, double t,
                                   std::span<const GaussianPulse> pulses, double c0, double rho0, double u0x,
                                   double u0y, std::optional<Rect> hard_walls, double tolerance) {
  if (x.size() != y.size()) throw std::invalid_argument("exact_acoustic_field: x and y differ in length");
  if (!positive(rho0)) throw std::invalid_argument("exact_acoustic_field: rho0 must be positive, got " + fmt(rho0));
  if (hard_walls && (u0x != 0.0 || u0y != 0.0))
    throw std::invalid_argument("exact_acoustic_field: the image solution for hard walls needs u0 = 0 "
                                "(a mean flow through a wall is not a reflection problem)");
  if (hard_walls && !(hard_walls->x1 > hard_walls->x0 && hard_walls->y1 > hard_walls->y0))
    throw std::invalid_argument("exact_acoustic_field: hard-wall box is empty");
  // Without walls no point is farther from a pulse than this: its table need reach no further (images, with hard
  // walls, reach as far as the wavefront).
  double r_needed = std::numeric_limits<double>::infinity();
  if (!hard_walls) {
    r_needed = 0.0;
    for (const GaussianPulse& pulse : pulses) {
      const double age = std::max(0.0, t - pulse.time), cx = pulse.x + u0x * age, cy = pulse.y + u0y * age;
      for (std::size_t i = 0; i < x.size(); ++i) r_needed = std::max(r_needed, std::hypot(x[i] - cx, y[i] - cy));
    }
  }
  // One table per distinct (age, half-width): superposed pulses emitted together share it.
  std::map<std::pair<double, double>, PulseTable> tables;
  struct Source {
    double cx, cy, scale_p, scale_u;
    const PulseTable* table;
  };
  std::vector<Source> sources;
  for (const GaussianPulse& pulse : pulses) {
    if (pulse.time > t + 1e-12 * std::max(1.0, std::abs(t))) continue;
    const double age = std::max(0.0, t - pulse.time);
    auto it = tables.find({age, pulse.half_width});
    if (it == tables.end())
      it = tables.emplace(std::pair{age, pulse.half_width}, PulseTable(pulse.half_width, c0, age, tolerance, r_needed)).first;
    sources.push_back({pulse.x + u0x * age, pulse.y + u0y * age, pulse.amplitude, pulse.amplitude / (rho0 * c0),
                       &it->second});
  }
  AcousticField out{std::vector<double>(x.size(), 0.0), std::vector<double>(x.size(), 0.0),
                    std::vector<double>(x.size(), 0.0)};
  // Image positions along one axis: the source reflected in both walls repeatedly, i.e. lo + 2 m W +- (c - lo).
  auto images = [](double c, double lo, double hi, double point, double reach) {
    std::vector<double> at;
    const double width = hi - lo;
    const int m_max = static_cast<int>(std::ceil((std::abs(point - lo) + reach) / (2.0 * width))) + 1;
    for (int m = -m_max; m <= m_max; ++m)
      for (double image : {lo + 2.0 * m * width + (c - lo), lo + 2.0 * m * width - (c - lo)})
        if (std::abs(image - point) <= reach) at.push_back(image);
    return at;
  };
  const auto n = static_cast<Index>(x.size());
#pragma omp parallel for schedule(static) if (n > kParallelRows)
  for (Index ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    double p = 0.0, u = 0.0, v = 0.0;
    for (const Source& s : sources) {
      const double reach = s.table->r_max();
      auto add = [&](double cx, double cy) {
        const double dx = x[i] - cx, dy = y[i] - cy, r = std::hypot(dx, dy);
        if (r > reach) return;
        const PulseProfile f = s.table->at(r);
        p += s.scale_p * f.pressure;
        if (r > 0.0) {
          u += s.scale_u * f.radial_velocity * dx / r;
          v += s.scale_u * f.radial_velocity * dy / r;
        }
      };
      if (!hard_walls) {
        add(s.cx, s.cy);
        continue;
      }
      for (double ix : images(s.cx, hard_walls->x0, hard_walls->x1, x[i], reach))
        for (double iy : images(s.cy, hard_walls->y0, hard_walls->y1, y[i], reach)) add(ix, iy);
    }
    out.p[i] = p;
    out.u[i] = u;
    out.v[i] = v;
  }
  return out;
}

double relative_rms_error(std::span<const double> value, std::span<const double> exact) {
  if (value.size() != exact.size()) throw std::invalid_argument("relative_rms_error: lengths differ");
  double diff = 0.0, ref = 0.0;
  for (std::size_t i = 0; i < value.size(); ++i) {
    diff += (value[i] - exact[i]) * (value[i] - exact[i]);
    ref += exact[i] * exact[i];
  }
  if (ref == 0.0) return diff == 0.0 ? 0.0 : std::numeric_limits<double>::infinity();
  return std::sqrt(diff / ref);
}

double acoustic_energy(std::span<const double> p, std::span<const double> u, std::span<const double> v,
                       double cell_area, double c0, double rho0) {
  if (p.size() != u.size() || p.size() != v.size()) throw std::invalid_argument("acoustic_energy: lengths differ");
  double potential = 0.0, kinetic = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    potential += p[i] * p[i];
    kinetic += u[i] * u[i] + v[i] * v[i];
  }
  return cell_area * (potential / (2.0 * rho0 * c0 * c0) + 0.5 * rho0 * kinetic);
}

// ---- gradients --------------------------------------------------------------------------------------------

AcousticGradient parse_acoustic_gradient(std::string_view name) {
  if (name == "mps") return AcousticGradient::mps;
  if (name == "ls3") return AcousticGradient::least_squares;
  throw std::invalid_argument("unknown acoustic gradient '" + std::string(name) + "'; valid: mps, ls3");
}

std::string_view to_string(AcousticGradient gradient) {
  return gradient == AcousticGradient::mps ? "mps" : "ls3";
}

GradientMatrices least_squares_gradient_matrices(const Stencil& s, std::size_t rows) {
  if (rows > s.particles.size()) throw std::invalid_argument("least_squares_gradient_matrices: more rows than particles");
  using Vector9 = std::array<double, 9>;
  const Particles& p = s.particles;
  const double re = s.kernel.re;
  // Monomials of the scaled offset (dx, dy)/re up to degree 3, so that M stays well scaled for any re.
  auto basis = [](double x, double y) {
    return Vector9{x, y, x * x, x * y, y * y, x * x * x, x * x * y, x * y * y, y * y * y};
  };
  struct Pair {
    int j;
    double dx, dy, w;
  };
  auto pairs_of = [&](std::size_t i) {
    std::vector<Pair> out;
    for (int j : s.neighbors.of(i)) {
      const auto d = s.domain.displacement(p.x[i], p.y[i], p.x[static_cast<std::size_t>(j)], p.y[static_cast<std::size_t>(j)]);
      const double w = s.kernel.w(std::hypot(d[0], d[1]));
      if (w > 0.0) out.push_back({j, d[0], d[1], w});
    }
    return out;
  };
  GradientMatrices g;
  for (CsrMatrix* m : {&g.x, &g.y}) {
    m->rows = static_cast<int>(rows);
    m->cols = static_cast<int>(p.size());
    m->row_ptr.assign(rows + 1, 0);
  }
  const auto n = static_cast<Index>(rows);
#pragma omp parallel for schedule(static)
  for (Index i = 0; i < n; ++i) g.x.row_ptr[static_cast<std::size_t>(i) + 1] = static_cast<int>(pairs_of(static_cast<std::size_t>(i)).size()) + 1;
  for (std::size_t i = 1; i <= rows; ++i) g.x.row_ptr[i] += g.x.row_ptr[i - 1];
  g.y.row_ptr = g.x.row_ptr;
  const auto nnz = static_cast<std::size_t>(g.x.row_ptr.back());
  for (CsrMatrix* m : {&g.x, &g.y}) {
    m->col.resize(nnz);
    m->val.resize(nnz);
  }
  std::string failure;
#pragma omp parallel for schedule(static)
  for (Index ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    const std::vector<Pair> pairs = pairs_of(i);
    SmallCholesky fit;
    for (const Pair& q : pairs) fit.add(q.w, basis(q.dx / re, q.dy / re));
    if (!fit.factor()) {
#pragma omp critical
      if (failure.empty())
        failure = "least-squares gradient: particle " + std::to_string(i) + " at (" + fmt(p.x[i]) + ", " + fmt(p.y[i]) +
                  ") has " + std::to_string(pairs.size()) +
                  " neighbours, too few or too one-sided to fit a cubic (9 coefficients): use a larger radius";
      continue;
    }
    const Vector9 cx = fit.solve(0), cy = fit.solve(1);
    auto k = static_cast<std::size_t>(g.x.row_ptr[i]);
    std::size_t diagonal = k;
    bool placed = false;
    double sum_x = 0.0, sum_y = 0.0;
    for (const Pair& q : pairs) {
      if (!placed && q.j > static_cast<int>(i)) {
        diagonal = k++;
        placed = true;
      }
      const Vector9 b = basis(q.dx / re, q.dy / re);
      double ax = 0.0, ay = 0.0;
      for (std::size_t m = 0; m < b.size(); ++m) {
        ax += cx[m] * b[m];
        ay += cy[m] * b[m];
      }
      ax *= q.w / re;
      ay *= q.w / re;
      g.x.col[k] = g.y.col[k] = q.j;
      g.x.val[k] = ax;
      g.y.val[k] = ay;
      sum_x += ax;
      sum_y += ay;
      ++k;
    }
    if (!placed) diagonal = k;
    g.x.col[diagonal] = g.y.col[diagonal] = static_cast<int>(i);
    g.x.val[diagonal] = -sum_x;
    g.y.val[diagonal] = -sum_y;
  }
  if (!failure.empty()) throw std::invalid_argument(failure);
  return g;
}

// ---- the module -------------------------------------------------------------------------------------------

AcousticBoundary parse_acoustic_boundary(std::string_view name) {
  if (name == "hard") return AcousticBoundary::hard;
  if (name == "mur") return AcousticBoundary::mur;
  if (name == "mur-step") return AcousticBoundary::mur_step;
  throw std::invalid_argument("unknown acoustic boundary '" + std::string(name) + "'; valid: hard, mur, mur-step");
}

std::string_view to_string(AcousticBoundary boundary) {
  switch (boundary) {
    case AcousticBoundary::hard: return "hard";
    case AcousticBoundary::mur: return "mur";
    case AcousticBoundary::mur_step: return "mur-step";
  }
  return "?";
}

void AcousticConfig::validate() const {
  auto require = [](bool ok, const std::string& message) {
    if (!ok) throw std::invalid_argument("acoustic config: " + message);
  };
  require(positive(l0), "particle spacing l0 must be positive, got " + fmt(l0));
  require(positive(cfl), "CFL number c0 dt / l0 must be positive, got " + fmt(cfl));
  require(positive(c0), "speed of sound c0 must be positive, got " + fmt(c0));
  require(positive(rho0), "density rho0 must be positive, got " + fmt(rho0));
  require(std::isfinite(u0x) && std::isfinite(u0y), "mean flow u0 must be finite");
  require(std::hypot(u0x, u0y) < c0, "mean flow speed |u0| = " + fmt(std::hypot(u0x, u0y)) +
                                         " m/s must be below c0 = " + fmt(c0) + " m/s (subsonic)");
  require(positive(radius) && radius > 1.0 && radius <= 10.0,
          "kernel radius re/l0 must be in (1, 10], got " + fmt(radius));
  require(guard_energy_factor > 1.0 && std::isfinite(guard_energy_factor),
          "guard_energy_factor must exceed 1, got " + fmt(guard_energy_factor));
  const double width = box.x1 - box.x0, height = box.y1 - box.y0;
  require(positive(width) && positive(height), "box must have x1 > x0 and y1 > y0");
  for (const auto& [length, name] : {std::pair{width, "width"}, std::pair{height, "height"}}) {
    const double n = length / l0;
    require(std::abs(n - std::round(n)) < 1e-6 * std::max(1.0, n),
            std::string("box ") + name + " " + fmt(length) + " m is not a multiple of l0 = " + fmt(l0) +
                " m: choose l0 = " + name + " / n");
  }
  const int layers = virtual_layers(radius);
  require(cells(width, l0) >= 2 * layers + 1 && cells(height, l0) >= 2 * layers + 1,
          "box must be at least " + std::to_string(2 * layers + 1) + " spacings wide and high for radius " + fmt(radius));
}

AcousticSolver::AcousticSolver(const AcousticConfig& config) : config_(config) {
  config_.validate();
  dt_ = config_.dt();
  const Rect& box = config_.box;
  const double l0 = config_.l0;
  fill_rectangle(particles_, box, l0, Kind::fluid);
  interior_ = particles_.size();
  const int layers = virtual_layers(config_.radius);
  add_rectangle_walls(particles_, box, l0, left | right | bottom | top, 0, layers);
  const std::size_t total = particles_.size();

  const double margin = (layers + 2) * l0;
  const Domain domain{box.x0 - margin, box.x1 + margin, box.y0 - margin, box.y1 + margin};
  const Kernel kernel = make_kernel(config_.radius, l0, config_.weight);
  const NeighborList neighbors = find_neighbors(particles_, domain, kernel.re);
  const Stencil stencil{particles_, domain, neighbors, kernel};
  grad_ = config_.gradient == AcousticGradient::mps ? interior_rows(gradient_matrices(stencil), interior_)
                                                    : least_squares_gradient_matrices(stencil, interior_);
  if (grad_.x.row_ptr != grad_.y.row_ptr || grad_.x.col != grad_.y.col)
    throw std::logic_error("acoustic: the x and y gradient matrices must share one pattern");

  // Lattice coordinates of every particle, for the mirror and Mur partners of the virtual ones.
  const int nx = cells(box.x1 - box.x0, l0), ny = cells(box.y1 - box.y0, l0);
  const int wide = nx + 2 * layers;
  std::vector<int> at_lattice(static_cast<std::size_t>(wide) * static_cast<std::size_t>(ny + 2 * layers), -1);
  auto lattice = [&](std::size_t i) {
    return std::array<int, 2>{static_cast<int>(std::lround((particles_.x[i] - box.x0) / l0 - 0.5)),
                              static_cast<int>(std::lround((particles_.y[i] - box.y0) / l0 - 0.5))};
  };
  auto slot = [&](int ix, int iy) { return static_cast<std::size_t>(iy + layers) * static_cast<std::size_t>(wide) + static_cast<std::size_t>(ix + layers); };
  for (std::size_t i = 0; i < total; ++i) {
    const auto [ix, iy] = lattice(i);
    at_lattice[slot(ix, iy)] = static_cast<int>(i);
  }
  const std::size_t ghosts = total - interior_;
  mirror_source_.resize(ghosts);
  mirror_sign_u_.resize(ghosts);
  mirror_sign_v_.resize(ghosts);
  mur_inward_.resize(ghosts);
  mur_speed_.resize(ghosts);
  mur_spacing_.resize(ghosts);
  std::vector<int> depth(ghosts);
  for (std::size_t g = 0; g < ghosts; ++g) {
    const auto [ix, iy] = lattice(interior_ + g);
    const int sx = ix < 0 ? -1 : (ix >= nx ? 1 : 0), sy = iy < 0 ? -1 : (iy >= ny ? 1 : 0);
    // Cell-centred lattice: the wall lies half a spacing beyond the last interior particle, so the mirror
    // of column -1 - k is column k.
    const int mx = ix < 0 ? -1 - ix : (ix >= nx ? 2 * nx - 1 - ix : ix);
    const int my = iy < 0 ? -1 - iy : (iy >= ny ? 2 * ny - 1 - iy : iy);
    mirror_source_[g] = at_lattice[slot(mx, my)];
    mirror_sign_u_[g] = sx != 0 ? -1.0 : 1.0;
    mirror_sign_v_[g] = sy != 0 ? -1.0 : 1.0;
    mur_inward_[g] = at_lattice[slot(ix - sx, iy - sy)];
    // The one-way wave leaving along the outward normal n travels at c0 + u0 . n.
    const double norm = std::hypot(sx, sy);
    mur_speed_[g] = config_.c0 + (config_.u0x * sx + config_.u0y * sy) / norm;
    mur_spacing_[g] = l0 * norm;
    depth[g] = (ix < 0 ? -ix : std::max(0, ix - nx + 1)) + (iy < 0 ? -iy : std::max(0, iy - ny + 1));
    if (mirror_source_[g] < 0 || mirror_source_[g] >= static_cast<int>(interior_) || mur_inward_[g] < 0)
      throw std::logic_error("acoustic: virtual particle without a lattice partner");
  }
  mur_order_.resize(ghosts);
  std::iota(mur_order_.begin(), mur_order_.end(), 0);
  std::stable_sort(mur_order_.begin(), mur_order_.end(), [&](int a, int b) {
    return depth[static_cast<std::size_t>(a)] < depth[static_cast<std::size_t>(b)];
  });

  state_.assign(3 * total, 0.0);
  stage_.assign(3 * total, 0.0);
  next_.assign(3 * total, 0.0);
  sum_.assign(3 * interior_, 0.0);
}

nlohmann::json AcousticSolver::save_state() const {
  std::vector<double> pulses;
  for (const GaussianPulse& g : pulses_) pulses.insert(pulses.end(), {g.x, g.y, g.amplitude, g.half_width, g.time});
  return {{"time", time_}, {"steps", steps_}, {"state", pack_array(state_)}, {"pulses", pack_array(pulses)},
          {"sqrt_energy_sum", sqrt_energy_sum_}, {"injected_energy", injected_energy_}};
}

void AcousticSolver::restore_state(const nlohmann::json& state) {
  std::vector<double> fields, pulses;
  unpack_array(state, "state", fields);
  unpack_array(state, "pulses", pulses);
  if (fields.size() != state_.size())
    throw std::runtime_error("checkpoint: fields of " + std::to_string(fields.size() / 3) + " particles, this solver has " +
                             std::to_string(state_.size() / 3) + " (another configuration?)");
  if (pulses.size() % 5 != 0) throw std::runtime_error("checkpoint: the pulses do not add up (a damaged file?)");
  const double time = unpack_value<double>(state, "time");
  const int steps = unpack_value<int>(state, "steps");
  const double sqrt_sum = unpack_value<double>(state, "sqrt_energy_sum");
  const double injected = unpack_value<double>(state, "injected_energy");
  state_ = std::move(fields);
  pulses_.clear();
  for (std::size_t k = 0; k < pulses.size(); k += 5)
    pulses_.push_back({pulses[k], pulses[k + 1], pulses[k + 2], pulses[k + 3], pulses[k + 4]});
  time_ = time;
  steps_ = steps;
  sqrt_energy_sum_ = sqrt_sum;
  injected_energy_ = injected;
}

GaussianPulse AcousticSolver::add_pulse(GaussianPulse pulse) {
  check_pulse(pulse.half_width, config_.c0, 0.0, 1.0);
  if (!std::isfinite(pulse.amplitude) || !std::isfinite(pulse.x) || !std::isfinite(pulse.y))
    throw std::invalid_argument("acoustic pulse: amplitude and centre must be finite");
  pulse.time = time_;
  const double a = std::numbers::ln2 / (pulse.half_width * pulse.half_width);
  double added = 0.0;
  for (std::size_t i = 0; i < interior_; ++i) {
    const double dx = particles_.x[i] - pulse.x, dy = particles_.y[i] - pulse.y;
    const double dp = pulse.amplitude * std::exp(-a * (dx * dx + dy * dy));
    state_[3 * i] += dp;
    added += dp * dp;
  }
  if (config_.boundary == AcousticBoundary::hard) fill_mirror(state_);
  const double energy = config_.l0 * config_.l0 * added / (2.0 * config_.rho0 * config_.c0 * config_.c0);
  sqrt_energy_sum_ += std::sqrt(energy);
  injected_energy_ += energy;
  pulses_.push_back(pulse);
  return pulse;
}

std::vector<double> AcousticSolver::component(int c) const {
  std::vector<double> out(particles_.size());
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = state_[3 * i + static_cast<std::size_t>(c)];
  return out;
}

void AcousticSolver::fill_mirror(std::vector<double>& state) const {
  for (std::size_t g = 0; g < mirror_source_.size(); ++g) {
    const auto src = 3 * static_cast<std::size_t>(mirror_source_[g]), dst = 3 * (interior_ + g);
    state[dst] = state[src];
    state[dst + 1] = mirror_sign_u_[g] * state[src + 1];
    state[dst + 2] = mirror_sign_v_[g] * state[src + 2];
  }
}

// One RK4 stage in one pass over the shared pattern of the two gradient matrices: each neighbour's (dp, du, dv)
// is read once for all six gradient components, and the stage's derivative k goes straight into the running
// sum (weight) and the next stage's input state + to_next k, or on the last stage into state + dt/6 sum.
void AcousticSolver::rk4_stage(std::vector<double>& in, std::vector<double>& out, double weight, double to_next,
                               bool first, bool last, double stage_offset) {
  if (config_.boundary == AcousticBoundary::hard) fill_mirror(in);
  if (config_.boundary == AcousticBoundary::mur && stage_offset > 0.0) apply_mur(state_, in, stage_offset);
  const double stiffness = config_.rho0 * config_.c0 * config_.c0, inv_rho = 1.0 / config_.rho0;
  const double ux = config_.u0x, uy = config_.u0y, sixth = dt_ / 6.0;
  const int* row_ptr = grad_.x.row_ptr.data();
  const int* col = grad_.x.col.data();
  const double* ax = grad_.x.val.data();
  const double* ay = grad_.y.val.data();
  const double* s = in.data();
  const double* y = state_.data();
  double* sum = sum_.data();
  double* o = out.data();
  const auto n = static_cast<Index>(interior_);
#pragma omp parallel for schedule(static) if (n > kParallelRows)
  for (Index i = 0; i < n; ++i) {
    double gpx = 0, gpy = 0, gux = 0, guy = 0, gvx = 0, gvy = 0;
    for (int k = row_ptr[i]; k < row_ptr[i + 1]; ++k) {
      const double* f = s + 3 * static_cast<std::size_t>(col[k]);
      gpx += ax[k] * f[0];
      gpy += ay[k] * f[0];
      gux += ax[k] * f[1];
      guy += ay[k] * f[1];
      gvx += ax[k] * f[2];
      gvy += ay[k] * f[2];
    }
    const double d[3] = {-stiffness * (gux + gvy) - (ux * gpx + uy * gpy), -inv_rho * gpx - (ux * gux + uy * guy),
                         -inv_rho * gpy - (ux * gvx + uy * gvy)};
    for (Index c = 0; c < 3; ++c) {
      const Index at = 3 * i + c;
      const double total = (first ? 0.0 : sum[at]) + weight * d[c];
      if (last) {
        o[at] = y[at] + sixth * total;
      } else {
        sum[at] = total;
        o[at] = y[at] + to_next * d[c];
      }
    }
  }
}

// Mur's box scheme for the one-way wave g_t + c_n g_n = 0 across the cell between a virtual particle and its
// inward partner, from the step start to `tau` later: g(tau) = f^n + (c_n tau - dx)/(c_n tau + dx) (f(tau) - g^n).
// Inward partners that are virtual themselves come earlier in mur_order_, so f(tau) is already set.
void AcousticSolver::apply_mur(const std::vector<double>& old_state, std::vector<double>& new_state, double tau) const {
  for (int g : mur_order_) {
    const auto gi = static_cast<std::size_t>(g);
    const auto ghost = 3 * (interior_ + gi), inward = 3 * static_cast<std::size_t>(mur_inward_[gi]);
    const double travel = mur_speed_[gi] * tau;
    const double a = (travel - mur_spacing_[gi]) / (travel + mur_spacing_[gi]);
    for (std::size_t c = 0; c < 3; ++c)
      new_state[ghost + c] = old_state[inward + c] + a * (new_state[inward + c] - old_state[ghost + c]);
  }
}

double AcousticSolver::energy_of(const std::vector<double>& state) const {
  double potential = 0.0, kinetic = 0.0;
  for (std::size_t i = 0; i < interior_; ++i) {
    potential += state[3 * i] * state[3 * i];
    kinetic += state[3 * i + 1] * state[3 * i + 1] + state[3 * i + 2] * state[3 * i + 2];
  }
  const double c0 = config_.c0, rho0 = config_.rho0;
  return config_.l0 * config_.l0 * (potential / (2.0 * rho0 * c0 * c0) + 0.5 * rho0 * kinetic);
}

double AcousticSolver::energy() const { return energy_of(state_); }

double AcousticSolver::energy_bound() const {
  return config_.guard_energy_factor * sqrt_energy_sum_ * sqrt_energy_sum_;
}

void AcousticSolver::step() {
  const double h = dt_;
  // Under mur-step the virtual particles keep their step-start values through the stages; under mur they
  // are set at each stage's time (offsets 0, h/2, h/2, h) by the same formula.
  const auto ghosts = static_cast<std::ptrdiff_t>(3 * interior_);
  std::copy(state_.begin() + ghosts, state_.end(), stage_.begin() + ghosts);
  std::copy(state_.begin() + ghosts, state_.end(), next_.begin() + ghosts);
  rk4_stage(state_, stage_, 1.0, 0.5 * h, true, false, 0.0);
  rk4_stage(stage_, next_, 2.0, 0.5 * h, false, false, 0.5 * h);
  rk4_stage(next_, stage_, 2.0, h, false, false, 0.5 * h);
  rk4_stage(stage_, next_, 1.0, 0.0, false, true, h);
  if (config_.boundary == AcousticBoundary::hard)
    fill_mirror(next_);
  else
    apply_mur(state_, next_, h);

  const double e = energy_of(next_), bound = energy_bound();
  if (!(e <= bound)) {
    const double limit = stable_cfl_estimate();
    std::string what = std::isfinite(e) ? "acoustic energy " + fmt(e) + " J/m exceeds the guard bound " + fmt(bound) +
                                              " J/m (guard_energy_factor " + fmt(config_.guard_energy_factor) +
                                              " x the largest energy the injected pulses can carry)"
                                        : "the acoustic field is no longer finite (NaN/Inf)";
    throw SimulationError("acoustic step " + std::to_string(steps_ + 1) + " (t = " + fmt(time_ + h) + " s, dt = " +
                          fmt(h) + " s): " + what + ": the run is unstable. CFL = c0 dt / l0 = " + fmt(config_.cfl) +
                          "; RK4 with the " + std::string(to_string(config_.gradient)) +
                          " gradient is stable up to CFL " + fmt(limit) + " (von Neumann estimate): choose cfl below " +
                          fmt(limit));
  }
  std::swap(state_, next_);
  ++steps_;
  time_ = steps_ * h;
}

double AcousticSolver::stable_cfl_estimate() const {
  // The interior particle nearest the box centre has a full neighbourhood (the box is >= 2 layers + 1 wide).
  const Rect& box = config_.box;
  const double cx = 0.5 * (box.x0 + box.x1), cy = 0.5 * (box.y0 + box.y1);
  std::size_t centre = 0;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < interior_; ++i) {
    const double d = std::hypot(particles_.x[i] - cx, particles_.y[i] - cy);
    if (d < best) {
      best = d;
      centre = i;
    }
  }
  struct Term {
    double dx, dy, ax, ay;
  };
  std::vector<Term> terms;
  for (int k = grad_.x.row_ptr[centre]; k < grad_.x.row_ptr[centre + 1]; ++k) {
    const auto j = static_cast<std::size_t>(grad_.x.col[static_cast<std::size_t>(k)]);
    terms.push_back({particles_.x[j] - particles_.x[centre], particles_.y[j] - particles_.y[centre],
                     grad_.x.val[static_cast<std::size_t>(k)], grad_.y.val[static_cast<std::size_t>(k)]});
  }
  // Symbol of the semi-discrete operator on exp(i k.r): G(k) = sum_j a_j exp(i k.r_ij); its eigenvalues are
  // -u0.G and -u0.G +- c0 sqrt(Gx^2 + Gy^2).
  const int samples = 192;
  const double l0 = config_.l0;
  std::vector<std::complex<double>> mu;
  for (int a = 0; a < samples; ++a)
    for (int b = 0; b < samples; ++b) {
      const double kx = std::numbers::pi / l0 * (2.0 * a / samples - 1.0);
      const double ky = std::numbers::pi / l0 * (2.0 * b / samples - 1.0);
      std::complex<double> gx = 0.0, gy = 0.0;
      for (const Term& t : terms) {
        const std::complex<double> e = std::exp(std::complex<double>(0.0, kx * t.dx + ky * t.dy));
        gx += t.ax * e;
        gy += t.ay * e;
      }
      const std::complex<double> advect = -(config_.u0x * gx + config_.u0y * gy);
      const std::complex<double> wave = config_.c0 * std::sqrt(gx * gx + gy * gy);
      mu.push_back(advect);
      mu.push_back(advect + wave);
      mu.push_back(advect - wave);
    }
  auto stable = [&](double cfl) {
    const double h = cfl * l0 / config_.c0;
    return std::all_of(mu.begin(), mu.end(), [h](std::complex<double> z) { return rk4_amplification(z * h) <= 1.0 + 1e-12; });
  };
  double lo = 0.0, hi = 16.0;
  if (stable(hi)) return hi;
  for (int iteration = 0; iteration < 50; ++iteration) {
    const double mid = 0.5 * (lo + hi);
    (stable(mid) ? lo : hi) = mid;
  }
  return lo;
}

}  // namespace mps
