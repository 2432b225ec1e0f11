#include "mps/boundaries/geometry.hpp"

#include <sstream>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

namespace mps {
namespace {
void require_positive(double value, const char* what) {
  if (!(value > 0.0) || !std::isfinite(value))
    throw std::invalid_argument(std::string("geometry: ") + what + " must be positive and finite, got " +
                                std::to_string(value));
}
int cells(double length, double l0) { return static_cast<int>(std::lround(length / l0)); }
}  // namespace

void fill_rectangle(Particles& particles, Rect rect, double l0, Kind kind, int group) {
  require_positive(l0, "particle spacing l0");
  const int nx = cells(rect.x1 - rect.x0, l0);
  const int ny = cells(rect.y1 - rect.y0, l0);
  if (nx <= 0 || ny <= 0) {
    std::ostringstream m;
    m << "fill_rectangle: the rectangle [" << rect.x0 << ", " << rect.x1 << "] x [" << rect.y0 << ", " << rect.y1
      << "] holds no lattice point at spacing " << l0 << ": ";
    if (!(rect.x1 > rect.x0) || !(rect.y1 > rect.y0))
      m << "its upper corner (x1, y1) must lie above and right of (x0, y0)";
    else
      m << "it is less than half a spacing across; use a spacing of at most "
        << std::min(rect.x1 - rect.x0, rect.y1 - rect.y0);
    throw std::invalid_argument(m.str());
  }
  particles.reserve(particles.size() + static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny));
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      particles.add(rect.x0 + (i + 0.5) * l0, rect.y0 + (j + 0.5) * l0, kind, group);
}

void add_rectangle_walls(Particles& particles, Rect inner, double l0, unsigned sides, int wall_layers,
                         int dummy_layers, int group) {
  require_positive(l0, "particle spacing l0");
  if (wall_layers < 0 || dummy_layers < 0 || wall_layers + dummy_layers == 0)
    throw std::invalid_argument("add_rectangle_walls: need at least one wall or dummy layer");
  const int layers = wall_layers + dummy_layers;
  const int nx = cells(inner.x1 - inner.x0, l0);
  const int ny = cells(inner.y1 - inner.y0, l0);
  const auto walled = [&](Side s) { return (sides & s) != 0u; };
  const int i_lo = walled(left) ? -layers : 0, i_hi = walled(right) ? nx + layers : nx;
  const int j_lo = walled(bottom) ? -layers : 0, j_hi = walled(top) ? ny + layers : ny;
  for (int j = j_lo; j < j_hi; ++j) {
    for (int i = i_lo; i < i_hi; ++i) {
      // Chebyshev distance (in layers) outside the inner rectangle; 0 means inside.
      const int layer = std::max({-i, i - nx + 1, -j, j - ny + 1, 0});
      if (layer == 0) continue;
      particles.add(inner.x0 + (i + 0.5) * l0, inner.y0 + (j + 0.5) * l0,
                    layer <= wall_layers ? Kind::wall : Kind::dummy, group);
    }
  }
}

void fill_box(Particles3& particles, Box box, double l0, Kind kind, int group) {
  require_positive(l0, "particle spacing l0");
  const int nx = cells(box.x1 - box.x0, l0), ny = cells(box.y1 - box.y0, l0), nz = cells(box.z1 - box.z0, l0);
  if (nx <= 0 || ny <= 0 || nz <= 0)
    throw std::invalid_argument("fill_box: the box holds no lattice point at spacing " + std::to_string(l0) +
                                ": each side must be at least half a spacing long, upper corner above the lower");
  particles.reserve(particles.size() + static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny) *
                                           static_cast<std::size_t>(nz));
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        particles.add({box.x0 + (i + 0.5) * l0, box.y0 + (j + 0.5) * l0, box.z0 + (k + 0.5) * l0}, kind, group);
}

Particles3 extrude(const Particles& layer, double z0, double l0, int layers) {
  require_positive(l0, "particle spacing l0");
  if (layers < 1) throw std::invalid_argument("extrude: at least one layer, got " + std::to_string(layers));
  if (!std::isfinite(z0)) throw std::invalid_argument("extrude: z0 must be finite");
  Particles3 out;
  out.reserve(layer.size() * static_cast<std::size_t>(layers));
  for (int k = 0; k < layers; ++k)
    for (std::size_t i = 0; i < layer.size(); ++i)
      out.add({layer.x[i], layer.y[i], z0 + (k + 0.5) * l0}, layer.kind[i], layer.group[i], {layer.u[i], layer.v[i], 0.0});
  return out;
}

void add_box_walls(Particles3& particles, Box inner, double l0, unsigned faces, int wall_layers, int dummy_layers,
                   int group) {
  require_positive(l0, "particle spacing l0");
  if (wall_layers < 0 || dummy_layers < 0 || wall_layers + dummy_layers == 0)
    throw std::invalid_argument("add_box_walls: need at least one wall or dummy layer");
  const int layers = wall_layers + dummy_layers;
  const int n[3] = {cells(inner.x1 - inner.x0, l0), cells(inner.y1 - inner.y0, l0), cells(inner.z1 - inner.z0, l0)};
  int lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = (faces & (1u << (2 * a))) != 0u ? -layers : 0;
    hi[a] = (faces & (1u << (2 * a + 1))) != 0u ? n[a] + layers : n[a];
  }
  for (int k = lo[2]; k < hi[2]; ++k)
    for (int j = lo[1]; j < hi[1]; ++j)
      for (int i = lo[0]; i < hi[0]; ++i) {
        // Chebyshev distance (in layers) outside the inner box; 0 means inside.
        const int layer = std::max({-i, i - n[0] + 1, -j, j - n[1] + 1, -k, k - n[2] + 1, 0});
        if (layer == 0) continue;
        particles.add({inner.x0 + (i + 0.5) * l0, inner.y0 + (j + 0.5) * l0, inner.z0 + (k + 0.5) * l0},
                      layer <= wall_layers ? Kind::wall : Kind::dummy, group);
      }
}

void fill_annular_sector(Particles& particles, double r0, double r1, double theta0, double theta1, double l0,
                         Kind kind, Lattice lattice, int group, double cx, double cy) {
  require_positive(l0, "particle spacing l0");
  if (!(r1 > r0) || r0 < 0.0) throw std::invalid_argument("fill_annular_sector: need 0 <= r0 < r1");
  const double span = theta1 - theta0;
  if (!(span > 0.0) || span > 2.0 * std::numbers::pi + 1e-12)
    throw std::invalid_argument("fill_annular_sector: need 0 < theta1 - theta0 <= 2 pi");
  if (lattice == Lattice::rings) {
    const int rings = cells(r1 - r0, l0);
    for (int k = 0; k < rings; ++k) {
      const double r = r0 + (k + 0.5) * l0;
      const int m = std::max(1, static_cast<int>(std::lround(r * span / l0)));
      for (int q = 0; q < m; ++q) {
        const double th = theta0 + (q + 0.5) * span / m;
        particles.add(cx + r * std::cos(th), cy + r * std::sin(th), kind, group);
      }
    }
    return;
  }
  const int n = static_cast<int>(std::ceil(r1 / l0)) + 1;
  const double two_pi = 2.0 * std::numbers::pi;
  for (int j = -n; j < n; ++j) {
    for (int i = -n; i < n; ++i) {
      const double px = (i + 0.5) * l0, py = (j + 0.5) * l0;
      const double r = std::hypot(px, py);
      if (r < r0 || r >= r1) continue;
      double th = std::atan2(py, px);
      // Bring the angle into [theta0, theta0 + 2 pi) before testing the span.
      th = theta0 + std::fmod(std::fmod(th - theta0, two_pi) + two_pi, two_pi);
      if (th >= theta1) continue;
      particles.add(cx + px, cy + py, kind, group);
    }
  }
}

int annulus_ring_count(double r, double span, double l0) {
  return std::max(1, static_cast<int>(std::lround(r * span / l0)));
}

void fill_walled_annulus(Particles& particles, double r_inner, int rings, double l0, int wall_layers, int dummy_layers,
                         double span, double centre, AnnulusGroups groups) {
  require_positive(l0, "particle spacing l0");
  if (!(r_inner > 0.0) || rings < 1 || wall_layers < 1 || dummy_layers < 0)
    throw std::invalid_argument(
        "fill_walled_annulus: need r_inner > 0, rings >= 1, wall_layers >= 1, dummy_layers >= 0");
  if (!(span > 0.0) || span > 2.0 * std::numbers::pi)
    throw std::invalid_argument("fill_walled_annulus: need 0 < span <= 2 pi");
  const int layers = wall_layers + dummy_layers;
  if (r_inner - layers * l0 < 0.5 * l0)
    throw std::invalid_argument("fill_walled_annulus: the inner wall's rings reach past the centre: r_inner must "
                                "exceed (wall_layers + dummy_layers + 1/2) l0");
  const auto kind = [&](int layer) {
    return layer == 0 ? Kind::fluid : layer <= wall_layers ? Kind::wall : Kind::dummy;
  };
  const bool full = span >= 2.0 * std::numbers::pi;
  for (int k = -layers; k < rings + layers; ++k) {
    const double r = r_inner + (k + 0.5) * l0;
    const int layer_r = k < 0 ? -k : k >= rings ? k - rings + 1 : 0;
    if (full) {
      fill_annular_sector(particles, r - 0.5 * l0, r + 0.5 * l0, 0.0, 2.0 * std::numbers::pi, l0, kind(layer_r),
                          Lattice::rings, k < 0 ? groups.inner : k >= rings ? groups.outer : groups.fluid);
      continue;
    }
    // Layers count outwards from the fluid, the larger of the radial and the angular count, so the corners are
    // filled; the corner blocks beyond the outer wall are outer wall, those inside the inner wall inner wall.
    const double theta0 = centre - 0.5 * span;
    const int m = annulus_ring_count(r, span, l0);
    const double dq = span / m;
    for (int q = -layers; q < m + layers; ++q) {
      const int layer_q = q < 0 ? -q : q >= m ? q - m + 1 : 0;
      const int layer = std::max(layer_r, layer_q);
      const double th = theta0 + (q + 0.5) * dq;
      const int group = layer == 0 ? groups.fluid : k >= rings ? groups.outer : k < 0 ? groups.inner : groups.flights;
      particles.add(r * std::cos(th), r * std::sin(th), kind(layer), group);
    }
  }
}

}  // namespace mps
