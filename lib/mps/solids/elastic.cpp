#include "mps/solids/elastic.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>

#include <Eigen/Dense>

#include "mps/boundaries/geometry.hpp"
#include "mps/core/neighbors.hpp"
#include "mps/core/state.hpp"
#include "mps/core/particles.hpp"

namespace mps {

ElasticModel parse_elastic_model(std::string_view name) {
  if (name == "linear") return ElasticModel::linear;
  if (name == "svk" || name == "saint-venant-kirchhoff") return ElasticModel::saint_venant_kirchhoff;
  throw std::invalid_argument("unknown elastic model '" + std::string(name) + "': use linear or svk");
}

std::string_view to_string(ElasticModel model) {
  return model == ElasticModel::linear ? "linear" : "svk";
}

namespace {

void check_lattice(const BodyLattice& l, int layers) {
  if (l.nx < 1 || l.ny < 1 || !(l.spacing > 0) || !std::isfinite(l.spacing) || !std::isfinite(l.x0) ||
      !std::isfinite(l.y0))
    throw std::invalid_argument("an elastic body's lattice needs at least one cell each way, a positive spacing and a "
                                "finite corner");
  if (layers < 1) throw std::invalid_argument("an elastic body's clamp needs at least one layer");
}

}  // namespace

ElasticBody clamped_box_body(const BodyLattice& l, unsigned clamp, int layers) {
  check_lattice(l, layers);
  if (clamp != x_low && clamp != x_high && clamp != y_low && clamp != y_high)
    throw std::invalid_argument("an elastic body is clamped at one face: x_low, x_high, y_low or y_high");
  const int i0 = clamp == x_low ? -layers : 0, i1 = clamp == x_high ? l.nx + layers : l.nx;
  const int j0 = clamp == y_low ? -layers : 0, j1 = clamp == y_high ? l.ny + layers : l.ny;
  ElasticBody body;
  body.spacing = l.spacing;
  for (int j = j0; j < j1; ++j)
    for (int i = i0; i < i1; ++i)
      body.add(l.x0 + (i + 0.5) * l.spacing, l.y0 + (j + 0.5) * l.spacing, l.spacing * l.spacing,
               i < 0 || i >= l.nx || j < 0 || j >= l.ny);
  return body;
}

ElasticBody cylinder_clamped_box_body(const BodyLattice& l, double cx, double cy, double radius, int layers) {
  check_lattice(l, layers);
  if (!(radius > 0) || !std::isfinite(radius) || !std::isfinite(cx) || !std::isfinite(cy))
    throw std::invalid_argument("a clamping cylinder needs a finite centre and a positive radius");
  const double depth = layers * l.spacing;
  ElasticBody body;
  body.spacing = l.spacing;
  for (int j = 0; j < l.ny; ++j) {
    const double y = l.y0 + (j + 0.5) * l.spacing, dy = y - cy;
    if (!(std::abs(dy) < radius))
      throw std::invalid_argument("the row of the elastic body at y = " + std::to_string(y) + " m misses its clamping "
                                  "cylinder: the body must be thinner than it, across its centre");
    const double arc = cx + std::sqrt(radius * radius - dy * dy);  // where the row leaves the cylinder
    auto x_at = [&](int i) { return l.x0 + (i + 0.5) * l.spacing; };
    int i = static_cast<int>(std::floor((arc - depth - l.x0) / l.spacing - 0.5)) - 1;
    while (!(x_at(i) > arc - depth)) ++i;
    for (; i < l.nx; ++i) body.add(x_at(i), y, l.spacing * l.spacing, !(x_at(i) > arc));
  }
  return body;
}

double cantilever_first_mode(double s, double length) {
  if (s <= 0) return 0.0;
  const double kl = 1.875104068711961, k = kl / length;
  auto f = [&](double z) {
    return (std::cos(kl) + std::cosh(kl)) * (std::cosh(k * z) - std::cos(k * z)) +
           (std::sin(kl) - std::sinh(kl)) * (std::sinh(k * z) - std::sin(k * z));
  };
  return f(s) / f(length);
}

double ElasticMaterial::lame_lambda() const {
  return youngs_modulus * poisson_ratio / ((1.0 + poisson_ratio) * (1.0 - 2.0 * poisson_ratio));
}
double ElasticMaterial::shear_modulus() const { return youngs_modulus / (2.0 * (1.0 + poisson_ratio)); }
double ElasticMaterial::bulk_modulus() const { return youngs_modulus / (3.0 * (1.0 - 2.0 * poisson_ratio)); }
double ElasticMaterial::p_wave_speed() const { return std::sqrt((lame_lambda() + 2.0 * shear_modulus()) / density); }

void ElasticMaterial::validate() const {
  if (!(density > 0) || !std::isfinite(density))
    throw std::invalid_argument("solid density must be positive and finite, got " + std::to_string(density));
  if (!(youngs_modulus > 0) || !std::isfinite(youngs_modulus))
    throw std::invalid_argument("Young's modulus must be positive and finite, got " + std::to_string(youngs_modulus));
  if (!(poisson_ratio > -1.0 && poisson_ratio < 0.5))
    throw std::invalid_argument("Poisson's ratio must lie in (-1, 0.5), got " + std::to_string(poisson_ratio) +
                                " (0.5 is incompressible: lambda is infinite)");
}

void ElasticConfig::validate() const {
  material.validate();
  if (!(radius >= 2.0 && radius <= 5.0))
    throw std::invalid_argument("elastic kernel radius must lie in [2, 5] spacings, got " + std::to_string(radius));
  if (!(cfl > 0.0 && cfl <= 2.0))
    throw std::invalid_argument("elastic CFL must lie in (0, 2], got " + std::to_string(cfl));
  if (!std::isfinite(gravity_x) || !std::isfinite(gravity_y))
    throw std::invalid_argument("gravity must be finite");
  if (!(hourglass >= 0.0 && hourglass <= 100.0))
    throw std::invalid_argument("hourglass coefficient must lie in [0, 100], got " + std::to_string(hourglass));
  if (!(guard_energy_fraction > 0.0) || !std::isfinite(guard_energy_fraction))
    throw std::invalid_argument("guard_energy_fraction must be positive and finite");
}

StressResult first_piola_stress(const std::array<double, 4>& f, const ElasticMaterial& material) {
  return first_piola_stress(f, material.lame_lambda(), material.shear_modulus(), material.model);
}

StressResult first_piola_stress(const std::array<double, 4>& f, double lambda, double mu, ElasticModel model) {
  StressResult r;
  double exx = 0, exy = 0, eyy = 0;
  if (model == ElasticModel::linear) {
    exx = f[0] - 1.0;
    eyy = f[3] - 1.0;
    exy = 0.5 * (f[1] + f[2]);
  } else {  // Green-Lagrange strain of F^T F
    exx = 0.5 * (f[0] * f[0] + f[2] * f[2] - 1.0);
    eyy = 0.5 * (f[1] * f[1] + f[3] * f[3] - 1.0);
    exy = 0.5 * (f[0] * f[1] + f[2] * f[3]);
  }
  const double tr = exx + eyy;
  const double sxx = lambda * tr + 2.0 * mu * exx, syy = lambda * tr + 2.0 * mu * eyy, sxy = 2.0 * mu * exy;
  r.energy_density = 0.5 * lambda * tr * tr + mu * (exx * exx + eyy * eyy + 2.0 * exy * exy);
  if (model == ElasticModel::linear) {
    r.p = {sxx, sxy, sxy, syy};
  } else {  // P = F S
    r.p = {f[0] * sxx + f[1] * sxy, f[0] * sxy + f[1] * syy, f[2] * sxx + f[3] * sxy, f[2] * sxy + f[3] * syy};
  }
  return r;
}

namespace {

// Wendland C2 in 2-D up to its constant (the correction divides it out): W(q) ~ (1 - q/2)^4 (1 + 2q), q = r/h.
double wendland(double r, double h) {
  const double q = r / h;
  if (q >= 2.0) return 0.0;
  const double a = 1.0 - 0.5 * q;
  return a * a * a * a * (1.0 + 2.0 * q);
}

NeighborList reference_neighbors(std::span<const double> x, std::span<const double> y, double radius) {
  Particles pts;
  pts.reserve(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) pts.add(x[i], y[i], Kind::fluid);
  const auto [xmin, xmax] = std::minmax_element(x.begin(), x.end());
  const auto [ymin, ymax] = std::minmax_element(y.begin(), y.end());
  const Domain domain{*xmin - radius, *xmax + radius, *ymin - radius, *ymax + radius};
  CellGrid grid(domain, radius);
  grid.bin(pts);
  return grid.neighbors(pts, radius);
}

}  // namespace

ReferenceFit quadratic_reference_fit(std::span<const double> x, std::span<const double> y,
                                    std::span<const double> volume, std::size_t rows, double radius) {
  if (x.size() != y.size() || x.size() != volume.size() || rows > x.size())
    throw std::invalid_argument("quadratic_reference_fit: array sizes do not match");
  const double h = 0.5 * radius;
  const NeighborList nl = reference_neighbors(x, y, radius);
  ReferenceFit fit;
  for (CsrMatrix* m : {&fit.gradient.x, &fit.gradient.y, &fit.hxx, &fit.hxy, &fit.hyy}) {
    m->rows = static_cast<int>(rows);
    m->cols = static_cast<int>(x.size());
    m->row_ptr.assign(rows + 1, 0);
  }
  std::vector<Eigen::Matrix<double, 5, 1>> basis;
  std::vector<double> w;
  for (std::size_t i = 0; i < rows; ++i) {
    const auto nb = nl.of(i);
    // Basis in units of h (conditioning): (dx, dy, dx^2/2, dx dy, dy^2/2) / (h, h, h^2, h^2, h^2).
    Eigen::Matrix<double, 5, 5> a = Eigen::Matrix<double, 5, 5>::Zero();
    basis.resize(nb.size());
    w.resize(nb.size());
    double total = 0.0;
    for (std::size_t k = 0; k < nb.size(); ++k) {
      const auto j = static_cast<std::size_t>(nb[k]);
      const double dx = (x[j] - x[i]) / h, dy = (y[j] - y[i]) / h, r2 = dx * dx + dy * dy;
      basis[k] << dx, dy, 0.5 * dx * dx, dx * dy, 0.5 * dy * dy;
      w[k] = volume[j] * wendland(std::sqrt(r2) * h, h) / r2;
      total += volume[j] * wendland(std::sqrt(r2) * h, h);
      a += w[k] * basis[k] * basis[k].transpose();
    }
    const Eigen::LDLT<Eigen::Matrix<double, 5, 5>> ldlt(a);
    const auto d = ldlt.vectorD();
    if (nb.size() < 5 || ldlt.info() != Eigen::Success || !(d.minCoeff() > 1e-10 * d.maxCoeff())) {
      std::ostringstream msg;
      msg << "solid particle " << i << " at (" << x[i] << ", " << y[i] << ") has " << nb.size()
          << " reference neighbours within " << radius
          << " m, too few or too one-sided to fit a quadratic: give the body at least 3 particles across its "
             "thinnest part or a larger kernel radius";
      throw std::invalid_argument(msg.str());
    }
    const double scale[5] = {1 / h, 1 / h, 1 / (h * h), 1 / (h * h), 1 / (h * h)};
    double sums[5] = {0, 0, 0, 0, 0};
    CsrMatrix* out[5] = {&fit.gradient.x, &fit.gradient.y, &fit.hxx, &fit.hxy, &fit.hyy};
    std::size_t diagonal_at = 0;
    bool diagonal_done = false;
    auto put_diagonal = [&] {
      diagonal_at = out[0]->val.size();
      for (CsrMatrix* m : out) {
        m->col.push_back(static_cast<int>(i));
        m->val.push_back(0.0);  // minus the row's sum, once known
      }
      fit.weight.push_back(0.0);
      diagonal_done = true;
    };
    for (std::size_t k = 0; k < nb.size(); ++k) {
      const auto j = static_cast<std::size_t>(nb[k]);
      if (!diagonal_done && j > i) put_diagonal();
      const Eigen::Matrix<double, 5, 1> c = ldlt.solve(basis[k]) * w[k];
      for (int m = 0; m < 5; ++m) {
        const double v = c[m] * scale[m];
        out[m]->col.push_back(static_cast<int>(j));
        out[m]->val.push_back(v);
        sums[m] += v;
      }
      const double r2 = (x[j] - x[i]) * (x[j] - x[i]) + (y[j] - y[i]) * (y[j] - y[i]);
      fit.weight.push_back(volume[j] * wendland(std::sqrt(r2), h) / (total * r2));
    }
    if (!diagonal_done) put_diagonal();
    for (int m = 0; m < 5; ++m) {
      out[m]->val[diagonal_at] = -sums[m];
      out[m]->row_ptr[i + 1] = static_cast<int>(out[m]->val.size());
    }
  }
  return fit;
}

CsrMatrix transpose(const CsrMatrix& a, std::vector<int>* source_entry) {
  CsrMatrix t;
  t.rows = a.cols;
  t.cols = a.rows;
  t.row_ptr.assign(static_cast<std::size_t>(a.cols) + 1, 0);
  for (int c : a.col) ++t.row_ptr[static_cast<std::size_t>(c) + 1];
  std::partial_sum(t.row_ptr.begin(), t.row_ptr.end(), t.row_ptr.begin());
  t.col.resize(a.nnz());
  t.val.resize(a.nnz());
  std::vector<int> next(t.row_ptr.begin(), t.row_ptr.end() - 1);
  if (source_entry) source_entry->assign(a.nnz(), 0);
  for (int i = 0; i < a.rows; ++i)  // rows in order: each transposed row gets its columns ascending
    for (int k = a.row_ptr[static_cast<std::size_t>(i)]; k < a.row_ptr[static_cast<std::size_t>(i) + 1]; ++k) {
      const auto slot = static_cast<std::size_t>(next[static_cast<std::size_t>(a.col[static_cast<std::size_t>(k)])]++);
      t.col[slot] = i;
      t.val[slot] = a.val[static_cast<std::size_t>(k)];
      if (source_entry) (*source_entry)[slot] = k;
    }
  return t;
}

ElasticSolid::ElasticSolid(const ElasticBody& body, const ElasticConfig& config) : config_(config) {
  config_.validate();
  const std::size_t n = body.size();
  if (n == 0) throw std::invalid_argument("the elastic body has no particles");
  if (body.y.size() != n || body.volume.size() != n || body.clamped.size() != n)
    throw std::invalid_argument("the elastic body's arrays differ in length");
  if (!(body.spacing > 0) || !std::isfinite(body.spacing))
    throw std::invalid_argument("the elastic body's spacing must be positive and finite");
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(body.x[i]) || !std::isfinite(body.y[i]) || !(body.volume[i] > 0) ||
        !std::isfinite(body.volume[i]))
      throw std::invalid_argument("solid particle " + std::to_string(i) +
                                  " has a non-finite position or a volume that is not positive");
  spacing_ = body.spacing;
  // Moving particles first: the gradient's rows are exactly them.
  for (std::size_t i = 0; i < n; ++i)
    if (!body.clamped[i]) id_.push_back(static_cast<int>(i));
  moving_ = id_.size();
  if (moving_ == 0) throw std::invalid_argument("every particle of the elastic body is clamped: nothing can move");
  for (std::size_t i = 0; i < n; ++i)
    if (body.clamped[i]) id_.push_back(static_cast<int>(i));
  for (int i : id_) {
    const auto k = static_cast<std::size_t>(i);
    x0_.push_back(body.x[k]);
    y0_.push_back(body.y[k]);
    volume_.push_back(body.volume[k]);
    mass_.push_back(body.volume[k] * config_.material.density);
  }
  x_ = x0_;
  y_ = y0_;
  u_.assign(n, 0.0);
  v_.assign(n, 0.0);
  ax_.assign(n, 0.0);
  ay_.assign(n, 0.0);
  fx_.assign(n, 0.0);
  fy_.assign(n, 0.0);
  for (auto& c : f_) c.assign(moving_, 0.0);
  for (auto& c : p_) c.assign(moving_, 0.0);
  for (auto& c : vp_) c.assign(moving_, 0.0);
  fit_ = quadratic_reference_fit(x0_, y0_, volume_, moving_, config_.radius * spacing_);
  grad_t_ = {transpose(fit_.gradient.x, &transposed_entry_), transpose(fit_.gradient.y)};
  // c_ij = alpha mu V_i times the fit's weight of the pair: proportional to it, so the fit's normal equations
  // cancel every term of the hourglass force but the pair terms.
  hg_coef_.resize(fit_.weight.size());
  const double alpha_mu = config_.hourglass * config_.material.shear_modulus();
  for (std::size_t i = 0; i < moving_; ++i)
    for (auto k = static_cast<std::size_t>(fit_.gradient.x.row_ptr[i]);
         k < static_cast<std::size_t>(fit_.gradient.x.row_ptr[i + 1]); ++k)
      hg_coef_[k] = alpha_mu * volume_[i] * fit_.weight[k];
  hg_xy_.assign(2 * hg_coef_.size(), 0.0);
  pair_dx_.assign(hg_coef_.size(), 0.0);
  pair_dy_.assign(hg_coef_.size(), 0.0);
  for (std::size_t i = 0; i < moving_; ++i)
    for (auto k = static_cast<std::size_t>(fit_.gradient.x.row_ptr[i]);
         k < static_cast<std::size_t>(fit_.gradient.x.row_ptr[i + 1]); ++k) {
      const auto j = static_cast<std::size_t>(fit_.gradient.x.col[k]);
      pair_dx_[k] = x0_[j] - x0_[i];
      pair_dy_[k] = y0_[j] - y0_[i];
    }
  disp_x_.assign(n, 0.0);
  disp_y_.assign(n, 0.0);
  hg_own_x_.assign(moving_, 0.0);
  hg_own_y_.assign(moving_, 0.0);
  strain_of_.assign(moving_, 0.0);
  hourglass_of_.assign(hg_coef_.size(), 0.0);
  dt_ = config_.cfl * spacing_ / config_.material.p_wave_speed();
  // Power iteration on M^-1 K, K v = -f(X + eps v) / eps (the body is unloaded at X), from a fixed start vector.
  {
    std::vector<double> vx(moving_), vy(moving_);
    for (std::size_t i = 0; i < moving_; ++i) {  // a deterministic, non-smooth start: every mode has a share
      vx[i] = std::sin(1.0 + 12.9898 * static_cast<double>(i));
      vy[i] = std::cos(2.0 + 78.233 * static_cast<double>(i));
    }
    const double eps = 1e-7 * spacing_;
    double omega2 = 0.0;
    for (int iteration = 0; iteration < 60; ++iteration) {
      double largest = 0.0;
      for (std::size_t i = 0; i < moving_; ++i) largest = std::max({largest, std::abs(vx[i]), std::abs(vy[i])});
      for (std::size_t i = 0; i < moving_; ++i) {
        vx[i] /= largest;
        vy[i] /= largest;
        x_[i] = x0_[i] + eps * vx[i];
        y_[i] = y0_[i] + eps * vy[i];
      }
      evaluate_forces();
      double vkv = 0.0, vmv = 0.0;
      for (std::size_t i = 0; i < moving_; ++i) {
        const double kx = -fx_[i] / eps, ky = -fy_[i] / eps;
        vkv += vx[i] * kx + vy[i] * ky;
        vmv += mass_[i] * (vx[i] * vx[i] + vy[i] * vy[i]);
        vx[i] = kx / mass_[i];
        vy[i] = ky / mass_[i];
      }
      omega2 = vkv / vmv;
    }
    x_ = x0_;
    y_ = y0_;
    // The Rayleigh quotient approaches omega_max^2 from below: 5 % margin.
    stable_cfl_ = 2.0 / (1.05 * std::sqrt(std::max(omega2, 1e-300)) * spacing_ / config_.material.p_wave_speed());
  }
  evaluate_forces();
  energy_ = measure_energy();
  start_energy_ = energy_.total() - external_work_;
  largest_mechanical_ = energy_.kinetic + energy_.strain + energy_.hourglass;
}

void ElasticSolid::set_velocity(std::span<const double> u, std::span<const double> v) {
  if (u.size() != size() || v.size() != size())
    throw std::invalid_argument("set_velocity: one value per solid particle is needed");
  for (std::size_t i = 0; i < moving_; ++i) {
    if (!std::isfinite(u[i]) || !std::isfinite(v[i]))
      throw std::invalid_argument("set_velocity: particle " + std::to_string(i) + " has a non-finite velocity");
    u_[i] = u[i];
    v_[i] = v[i];
  }
  energy_ = measure_energy();
  start_energy_ = energy_.total() - external_work_;
  largest_mechanical_ = std::max(largest_mechanical_, energy_.kinetic + energy_.strain + energy_.hourglass);
}

void ElasticSolid::set_external_force(std::span<const double> fx, std::span<const double> fy) {
  if (fx.size() != size() || fy.size() != size())
    throw std::invalid_argument("set_external_force: one value per solid particle is needed");
  for (std::size_t i = 0; i < size(); ++i)
    if (!std::isfinite(fx[i]) || !std::isfinite(fy[i]))
      throw std::invalid_argument("set_external_force: particle " + std::to_string(i) + " has a non-finite force");
  external_x_.assign(fx.begin(), fx.end());
  external_y_.assign(fy.begin(), fy.end());
  for (std::size_t i = 0; i < moving_; ++i) {  // the accelerations of the current positions follow at once
    ax_[i] = (fx_[i] + external_x_[i]) / mass_[i] + config_.gravity_x;
    ay_[i] = (fy_[i] + external_y_[i]) / mass_[i] + config_.gravity_y;
  }
}

void ElasticSolid::set_positions(std::span<const double> x, std::span<const double> y) {
  if (x.size() != size() || y.size() != size())
    throw std::invalid_argument("set_positions: one value per solid particle is needed");
  for (std::size_t i = 0; i < moving_; ++i)
    if (!std::isfinite(x[i]) || !std::isfinite(y[i]))
      throw std::invalid_argument("set_positions: particle " + std::to_string(i) + " has a non-finite position");
  std::copy(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(moving_), x_.begin());
  std::copy(y.begin(), y.begin() + static_cast<std::ptrdiff_t>(moving_), y_.begin());
  evaluate_forces();
  energy_ = measure_energy();
  start_energy_ = energy_.total() - external_work_;
  largest_mechanical_ = std::max(largest_mechanical_, energy_.kinetic + energy_.strain + energy_.hourglass);
}

void ElasticSolid::evaluate_forces() {
  const auto n = static_cast<std::ptrdiff_t>(size()), m = static_cast<std::ptrdiff_t>(moving_);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t j = 0; j < n; ++j) {
    const auto jj = static_cast<std::size_t>(j);
    disp_x_[jj] = x_[jj] - x0_[jj];
    disp_y_[jj] = y_[jj] - y0_[jj];
  }
  const CsrMatrix &gx = fit_.gradient.x, &gy = fit_.gradient.y;
  const bool with_hourglass = config_.hourglass > 0;
  const double lambda = config_.material.lame_lambda(), mu = config_.material.shear_modulus();
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < m; ++i) {
    const auto ii = static_cast<std::size_t>(i);
    const auto b = static_cast<std::size_t>(gx.row_ptr[ii]), e = static_cast<std::size_t>(gx.row_ptr[ii + 1]);
    // F = I + G u: the displacement keeps F exactly I at rest and loses no digits to the positions' size. The
    // second derivatives of u (xx, xy, yy) come in the same pass, for the hourglass term.
    std::array<double, 4> f{1.0, 0.0, 0.0, 1.0};
    double hx[3] = {0, 0, 0}, hy[3] = {0, 0, 0};
    for (std::size_t k = b; k < e; ++k) {
      const auto j = static_cast<std::size_t>(gx.col[k]);
      const double ux = disp_x_[j], uy = disp_y_[j];
      f[0] += gx.val[k] * ux;
      f[1] += gy.val[k] * ux;
      f[2] += gx.val[k] * uy;
      f[3] += gy.val[k] * uy;
      if (!with_hourglass) continue;
      const double cxx = fit_.hxx.val[k], cxy = fit_.hxy.val[k], cyy = fit_.hyy.val[k];
      hx[0] += cxx * ux;
      hx[1] += cxy * ux;
      hx[2] += cyy * ux;
      hy[0] += cxx * uy;
      hy[1] += cxy * uy;
      hy[2] += cyy * uy;
    }
    const StressResult s = first_piola_stress(f, lambda, mu, config_.material.model);
    double own_x = 0.0, own_y = 0.0;
    if (with_hourglass) {
      // delta_ij: the quadratic fit's prediction of the pair's relative displacement less the actual one.
      const double uxi = disp_x_[ii], uyi = disp_y_[ii];
      for (std::size_t k = b; k < e; ++k) {
        const double c = hg_coef_[k];
        if (c == 0.0) continue;
        const auto j = static_cast<std::size_t>(gx.col[k]);
        const double dx = pair_dx_[k], dy = pair_dy_[k];
        const double qxx = 0.5 * dx * dx, qxy = dx * dy, qyy = 0.5 * dy * dy;
        const double dex = (f[0] - 1.0) * dx + f[1] * dy + hx[0] * qxx + hx[1] * qxy + hx[2] * qyy -
                           (disp_x_[j] - uxi);
        const double dey = f[2] * dx + (f[3] - 1.0) * dy + hy[0] * qxx + hy[1] * qxy + hy[2] * qyy -
                           (disp_y_[j] - uyi);
        hg_xy_[2 * k] = c * dex;
        hg_xy_[2 * k + 1] = c * dey;
        own_x += c * dex;
        own_y += c * dey;
        hourglass_of_[k] = 0.5 * c * (dex * dex + dey * dey);
      }
    }
    hg_own_x_[ii] = own_x;
    hg_own_y_[ii] = own_y;
    for (std::size_t c = 0; c < 4; ++c) {
      f_[c][ii] = f[c];
      p_[c][ii] = s.p[c];
      vp_[c][ii] = volume_[ii] * s.p[c];
    }
    strain_of_[ii] = volume_[ii] * s.energy_density;
  }
  strain_energy_ = hourglass_energy_ = 0.0;
  for (std::size_t i = 0; i < moving_; ++i) strain_energy_ += strain_of_[i];
  if (with_hourglass)
    for (std::size_t k = 0; k < static_cast<std::size_t>(gx.row_ptr[moving_]); ++k) hourglass_energy_ += hourglass_of_[k];
  const CsrMatrix &tx = grad_t_.x, &ty = grad_t_.y;
  // f^a = -(Gx^T (V P^{a x}) + Gy^T (V P^{a y})) + sum_i c_ik delta_ik - sum_j c_kj delta_kj
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t r = 0; r < n; ++r) {
    const auto rr = static_cast<std::size_t>(r);
    double sx = 0.0, sy = 0.0, inx = 0.0, iny = 0.0;
    for (auto k = static_cast<std::size_t>(tx.row_ptr[rr]); k < static_cast<std::size_t>(tx.row_ptr[rr + 1]); ++k) {
      const auto i = static_cast<std::size_t>(tx.col[k]);
      sx += tx.val[k] * vp_[0][i] + ty.val[k] * vp_[1][i];
      sy += tx.val[k] * vp_[2][i] + ty.val[k] * vp_[3][i];
      if (with_hourglass) {
        const auto src = 2 * static_cast<std::size_t>(transposed_entry_[k]);
        inx += hg_xy_[src];
        iny += hg_xy_[src + 1];
      }
    }
    const bool moves = rr < moving_;
    fx_[rr] = -sx + inx - (moves ? hg_own_x_[rr] : 0.0);
    fy_[rr] = -sy + iny - (moves ? hg_own_y_[rr] : 0.0);
    const double ex = external_x_.empty() ? 0.0 : external_x_[rr], ey = external_y_.empty() ? 0.0 : external_y_[rr];
    ax_[rr] = moves ? (fx_[rr] + ex) / mass_[rr] + config_.gravity_x : 0.0;
    ay_[rr] = moves ? (fy_[rr] + ey) / mass_[rr] + config_.gravity_y : 0.0;
  }
}

ElasticEnergy ElasticSolid::measure_energy() const {
  ElasticEnergy e;
  e.strain = strain_energy_;
  e.hourglass = hourglass_energy_;
  for (std::size_t i = 0; i < moving_; ++i) {
    e.kinetic += 0.5 * mass_[i] * (u_[i] * u_[i] + v_[i] * v_[i]);
    e.gravity -= mass_[i] * (config_.gravity_x * (x_[i] - x0_[i]) + config_.gravity_y * (y_[i] - y0_[i]));
  }
  return e;
}

namespace {
// The components (xx, xy, yx, yy) of F and P in a checkpoint.
constexpr const char* kTensorNames[2][4] = {{"f_xx", "f_xy", "f_yx", "f_yy"}, {"p_xx", "p_xy", "p_yx", "p_yy"}};
}  // namespace

nlohmann::json ElasticSolid::save_state() const {
  nlohmann::json tensors = nlohmann::json::object();
  for (std::size_t c = 0; c < 4; ++c) {
    tensors[kTensorNames[0][c]] = pack_array(f_[c]);
    tensors[kTensorNames[1][c]] = pack_array(p_[c]);
  }
  return {{"time", time_}, {"steps", steps_}, {"x", pack_array(x_)}, {"y", pack_array(y_)}, {"u", pack_array(u_)},
          {"v", pack_array(v_)}, {"ax", pack_array(ax_)}, {"ay", pack_array(ay_)}, {"tensors", tensors},
          {"strain_energy", strain_energy_}, {"hourglass_energy", hourglass_energy_},
          {"energy", {energy_.kinetic, energy_.strain, energy_.hourglass, energy_.gravity}},
          {"start_energy", start_energy_}, {"largest_mechanical", largest_mechanical_},
          {"external_x", pack_array(external_x_)}, {"external_y", pack_array(external_y_)},
          {"external_work", external_work_}};
}

void ElasticSolid::restore_state(const nlohmann::json& state) {
  // Read into copies first: a checkpoint that does not fit leaves the solid as it was.
  std::array<std::vector<double>, 6> motion;
  const char* names[6] = {"x", "y", "u", "v", "ax", "ay"};
  for (std::size_t c = 0; c < 6; ++c) {
    unpack_array(state, names[c], motion[c]);
    if (motion[c].size() != x_.size())
      throw std::runtime_error("checkpoint: a solid of " + std::to_string(motion[c].size()) + " particles, this one has " +
                               std::to_string(x_.size()));
  }
  std::array<std::vector<double>, 4> f, p;
  const nlohmann::json& tensors = state_part(state, "tensors");
  for (std::size_t c = 0; c < 4; ++c) {
    unpack_array(tensors, kTensorNames[0][c], f[c]);
    unpack_array(tensors, kTensorNames[1][c], p[c]);
  }
  std::vector<double> external_x, external_y;
  unpack_array(state, "external_x", external_x);
  unpack_array(state, "external_y", external_y);
  const auto energy = unpack_value<std::vector<double>>(state, "energy");
  if (energy.size() != 4) throw std::runtime_error("checkpoint: the solid's energies are not four (a damaged file?)");
  x_ = std::move(motion[0]);
  y_ = std::move(motion[1]);
  u_ = std::move(motion[2]);
  v_ = std::move(motion[3]);
  ax_ = std::move(motion[4]);
  ay_ = std::move(motion[5]);
  f_ = std::move(f);
  p_ = std::move(p);
  external_x_ = std::move(external_x);
  external_y_ = std::move(external_y);
  energy_ = {energy[0], energy[1], energy[2], energy[3]};
  time_ = unpack_value<double>(state, "time");
  steps_ = unpack_value<int>(state, "steps");
  strain_energy_ = unpack_value<double>(state, "strain_energy");
  hourglass_energy_ = unpack_value<double>(state, "hourglass_energy");
  start_energy_ = unpack_value<double>(state, "start_energy");
  largest_mechanical_ = unpack_value<double>(state, "largest_mechanical");
  external_work_ = unpack_value<double>(state, "external_work");
}

void ElasticSolid::step() {
  // The state to go back to if the guard trips (assign reuses the buffers: no allocation per step).
  saved_[0].assign(x_.begin(), x_.end());
  saved_[1].assign(y_.begin(), y_.end());
  saved_[2].assign(u_.begin(), u_.end());
  saved_[3].assign(v_.begin(), v_.end());
  saved_[4].assign(ax_.begin(), ax_.end());
  saved_[5].assign(ay_.begin(), ay_.end());
  const double h = 0.5 * dt_;
  double largest_move = 0.0;
  for (std::size_t i = 0; i < moving_; ++i) {
    u_[i] += h * ax_[i];
    v_[i] += h * ay_[i];
    x_[i] += dt_ * u_[i];
    y_[i] += dt_ * v_[i];
    largest_move = std::max(largest_move, u_[i] * u_[i] + v_[i] * v_[i]);
  }
  largest_move = dt_ * std::sqrt(largest_move);
  double work = 0.0;  // the external force is constant over the step: its work is F . (x^{n+1} - x^n)
  if (!external_x_.empty())
    for (std::size_t i = 0; i < moving_; ++i)
      work += external_x_[i] * (x_[i] - saved_[0][i]) + external_y_[i] * (y_[i] - saved_[1][i]);
  evaluate_forces();
  for (std::size_t i = 0; i < moving_; ++i) {
    u_[i] += h * ax_[i];
    v_[i] += h * ay_[i];
  }
  const ElasticEnergy e = measure_energy();
  const double mechanical = e.kinetic + e.strain + e.hourglass;
  const double largest = std::max(largest_mechanical_, mechanical);
  const double drift = std::abs(e.total() - (external_work_ + work) - start_energy_);
  const bool finite = std::isfinite(e.total()) && std::isfinite(largest_move);
  if (!finite || largest_move > 0.5 * spacing_ || drift > config_.guard_energy_fraction * largest) {
    std::ostringstream msg;
    msg << "elastic solid unstable at step " << steps_ + 1 << " (t = " << time_ + dt_ << " s): ";
    if (!finite)
      msg << "the energy or a position is not finite";
    else if (largest_move > 0.5 * spacing_)
      msg << "a particle moved " << largest_move / spacing_ << " spacings in one step (the guard allows 0.5)";
    else
      msg << "the total energy less the external work moved from " << start_energy_ << " to "
          << e.total() - external_work_ - work << " J/m, more than "
          << config_.guard_energy_fraction << " of the largest kinetic + strain energy " << largest << " J/m";
    msg << "; dt = " << dt_ << " s at CFL " << config_.cfl << " (p-wave speed " << config_.material.p_wave_speed()
        << " m/s); this body is stable up to CFL ~" << stable_cfl_ << ": lower "
        << (config_.cfl_option.empty() ? std::string("the CFL") : config_.cfl_option);
    x_.swap(saved_[0]);
    y_.swap(saved_[1]);
    u_.swap(saved_[2]);
    v_.swap(saved_[3]);
    ax_.swap(saved_[4]);
    ay_.swap(saved_[5]);
    evaluate_forces();  // F, P, strain energy and the reaction of the restored state (energy_ is not yet updated)
    throw SimulationError(msg.str());
  }
  energy_ = e;
  external_work_ += work;
  largest_mechanical_ = largest;
  time_ += dt_;
  ++steps_;
}

int ElasticSolid::advance(double duration) {
  if (!(duration >= 0.0) || !std::isfinite(duration))
    throw std::invalid_argument("ElasticSolid::advance: the duration must be finite and not negative");
  if (duration == 0.0) return 0;
  const double own = dt_;
  const int n = static_cast<int>(std::ceil(duration / own - 1e-9));
  dt_ = duration / n;
  try {
    for (int k = 0; k < n; ++k) step();
  } catch (...) {
    dt_ = own;
    throw;
  }
  dt_ = own;
  return n;
}

std::array<double, 2> ElasticSolid::clamp_reaction() const {
  std::array<double, 2> r{0.0, 0.0};
  for (std::size_t i = moving_; i < size(); ++i) {
    r[0] -= fx_[i];
    r[1] -= fy_[i];
  }
  return r;
}

std::array<double, 2> ElasticSolid::displacement_at(double px, double py) const {
  const double radius = config_.radius * spacing_, h = 0.5 * radius;
  // Weighted least squares for u = a + b . (X - P): 3x3 normal equations, one right-hand side per component.
  double m[3][3] = {}, rx[3] = {}, ry[3] = {};
  for (std::size_t j = 0; j < size(); ++j) {
    const double dx = x0_[j] - px, dy = y0_[j] - py, r = std::hypot(dx, dy);
    if (r >= radius) continue;
    const double w = wendland(r, h), basis[3] = {1.0, dx, dy};
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) m[a][b] += w * basis[a] * basis[b];
      rx[a] += w * basis[a] * (x_[j] - x0_[j]);
      ry[a] += w * basis[a] * (y_[j] - y0_[j]);
    }
  }
  // Cramer's rule for the constant term.
  auto det3 = [](const double a[3][3]) {
    return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
           a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  };
  const double d = det3(m);
  if (!(std::abs(d) > 0.0))
    throw std::invalid_argument("displacement_at: too few solid particles near the point to fit a linear field");
  std::array<double, 2> out{};
  for (int c = 0; c < 2; ++c) {
    double a[3][3];
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) a[r][k] = m[r][k];
    for (int r = 0; r < 3; ++r) a[r][0] = c == 0 ? rx[r] : ry[r];
    out[static_cast<std::size_t>(c)] = det3(a) / d;
  }
  return out;
}

}  // namespace mps
