#include "mps/numerics/ppe.hpp"
#include "mps/numerics/row_pairs.hpp"
#include "mps/core/threads.hpp"
#include "mps/core/vec.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace mps {
namespace {

using Index = std::ptrdiff_t;

bool in_ppe_sum(Kind k) { return k == Kind::fluid || k == Kind::wall; }

int find_root(std::vector<int>& parent, int a) {
  while (parent[static_cast<std::size_t>(a)] != a) {
    parent[static_cast<std::size_t>(a)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(a)])];
    a = parent[static_cast<std::size_t>(a)];
  }
  return a;
}

// Connected groups of unknowns; those without a Dirichlet neighbour (anchored) are singular and get the gauge
// described in ppe.hpp: their right-hand side's mean removed and one member's diagonal doubled.
void gauge_floating_groups(PpeSystem& sys, std::span<const char> anchored) {
  CsrMatrix& a = sys.matrix;
  const auto m = static_cast<Index>(sys.particle.size());
  std::vector<int> parent(static_cast<std::size_t>(m));
  std::iota(parent.begin(), parent.end(), 0);
  for (int r = 0; r < m; ++r) {
    int ra = find_root(parent, r);  // kept current through the row's unions: one find per edge, not two
    for (int k = a.row_ptr[static_cast<std::size_t>(r)]; k < a.row_ptr[static_cast<std::size_t>(r) + 1]; ++k) {
      const int col = a.col[static_cast<std::size_t>(k)];
      if (col >= r) break;  // the pattern is symmetric: the lower triangle holds every edge once
      if (parent[static_cast<std::size_t>(col)] == ra) continue;  // the common case once the region is joined
      const int rb = find_root(parent, col);
      if (ra == rb) continue;
      parent[static_cast<std::size_t>(std::max(ra, rb))] = std::min(ra, rb);
      ra = std::min(ra, rb);
    }
  }
  std::vector<char> root_anchored(static_cast<std::size_t>(m), 0);
  for (int r = 0; r < m; ++r)
    if (anchored[static_cast<std::size_t>(r)]) root_anchored[static_cast<std::size_t>(find_root(parent, r))] = 1;
  sys.group.assign(static_cast<std::size_t>(m), -1);
  std::vector<int> group_of_root(static_cast<std::size_t>(m), -1);
  for (int r = 0; r < m; ++r) {
    const int root = find_root(parent, r);
    if (root_anchored[static_cast<std::size_t>(root)]) continue;
    int& g = group_of_root[static_cast<std::size_t>(root)];
    if (g < 0) {
      g = static_cast<int>(sys.floating.size());
      sys.floating.push_back({r, 0, 0.0});  // roots are the lowest member, met first
    }
    sys.group[static_cast<std::size_t>(r)] = g;
    ++sys.floating[static_cast<std::size_t>(g)].size;
    sys.floating[static_cast<std::size_t>(g)].removed_rhs_mean += sys.rhs[static_cast<std::size_t>(r)];
  }
  for (auto& g : sys.floating) {
    g.removed_rhs_mean /= g.size;
    const int pin = g.pinned;
    for (int k = a.row_ptr[static_cast<std::size_t>(pin)]; k < a.row_ptr[static_cast<std::size_t>(pin) + 1]; ++k)
      if (a.col[static_cast<std::size_t>(k)] == pin) a.val[static_cast<std::size_t>(k)] *= 2.0;
  }
  for (Index r = 0; r < m; ++r) {
    const int g = sys.group[static_cast<std::size_t>(r)];
    if (g >= 0) sys.rhs[static_cast<std::size_t>(r)] -= sys.floating[static_cast<std::size_t>(g)].removed_rhs_mean;
  }
}

}  // namespace

std::vector<double> mixed_source(std::span<const double> n_star, double n0, std::span<const double> div_u_star,
                                 double rho, double dt, double gamma) {
  std::vector<double> s;
  mixed_source(n_star, n0, div_u_star, rho, dt, gamma, s);
  return s;
}

void mixed_source(std::span<const double> n_star, double n0, std::span<const double> div_u_star, double rho,
                  double dt, double gamma, std::vector<double>& s) {
  if (!(gamma >= 0.0 && gamma <= 1.0))
    throw std::invalid_argument("mixed source: gamma must be in [0, 1], got " + std::to_string(gamma));
  if (!(dt > 0.0)) throw std::invalid_argument("mixed source: time step must be positive");
  if (n_star.size() != div_u_star.size()) throw std::invalid_argument("mixed source: n* and div u* differ in length");
  s.resize(n_star.size());
  for (std::size_t i = 0; i < s.size(); ++i)
    s[i] = (1.0 - gamma) * rho / dt * div_u_star[i] - gamma * rho / (dt * dt) * (n_star[i] - n0) / n0;
}

template <int D>
std::vector<char> detect_free_surface(const BasicParticles<D>& particles, std::span<const double> n_star, double n0,
                                      double beta, const NeighborList* neighbors, int lattice_neighbors, double theta) {
  std::vector<char> surface;
  detect_free_surface(particles, n_star, n0, beta, neighbors, lattice_neighbors, theta, surface);
  return surface;
}

template <int D>
void detect_free_surface(const BasicParticles<D>& particles, std::span<const double> n_star, double n0, double beta,
                         const NeighborList* neighbors, int lattice_neighbors, double theta,
                         std::vector<char>& surface) {
  if (!(beta > 0.0 && beta < 1.0)) throw std::invalid_argument("free surface: beta must be in (0, 1)");
  if (theta > 0.0 && !neighbors) throw std::invalid_argument("free surface: the count test needs the neighbour list");
  const double max_count = theta * lattice_neighbors;
  surface.assign(particles.size(), 0);
  for (std::size_t i = 0; i < surface.size(); ++i)
    surface[i] = in_ppe_sum(particles.kind[i]) && n_star[i] < beta * n0 &&
                 (theta <= 0.0 || particles.kind[i] == Kind::wall ||
                  static_cast<double>(neighbors->of(i).size()) < max_count);
}

template <int D>
PpeSystem assemble_ppe(const BasicStencil<D>& s, std::span<const char> free_surface, std::span<const double> source,
                       std::span<const double> dirichlet, double shift, ClosedGroups closed, OpenSupport open,
                       PpeRows rows) {
  PpeSystem sys;
  assemble_ppe(s, free_surface, source, sys, dirichlet, shift, closed, open, rows);
  return sys;
}

template <int D>
void assemble_ppe(const BasicStencil<D>& s, std::span<const char> free_surface, std::span<const double> source,
                  PpeSystem& sys, std::span<const double> dirichlet, double shift, ClosedGroups closed,
                  OpenSupport open, PpeRows rows) {
  const BasicParticles<D>& p = s.particles;
  const std::size_t n = p.size();
  if (free_surface.size() != n || source.size() != n || (!dirichlet.empty() && dirichlet.size() != n) ||
      (!open.weight.empty() && (open.weight.size() != n || open.value.size() != n)))
    throw std::invalid_argument(
        "assemble_ppe: free-surface flags, source, Dirichlet values and open weights must have one entry per particle");
  if (!(shift >= 0.0) || !std::isfinite(shift)) throw std::invalid_argument("assemble_ppe: shift must be >= 0");
  const double c = s.kernel.laplacian_scale(D);

  // Who enters a Laplacian sum: fluid particles (free-surface ones as Dirichlet P = 0) and wet walls. A dry
  // wall (a wall flagged free surface: above the water line) is a zero-flux boundary like a dummy, not a
  // P = 0 neighbour: were it Dirichlet, fluid at a contact line would see more P = 0 neighbours than fluid
  // at the open surface, and the low-pressure pocket this makes draws the fluid up the wall.
  auto in_sum = [&](std::size_t j) { return p.kind[j] == Kind::fluid || (p.kind[j] == Kind::wall && !free_surface[j]); };
  // Every listed pair is closer than the list's radius; when that is within the kernel's, every pair has w > 0
  // and the passes that only need to know which pairs count skip the distance and the kernel.
  const bool all_in_kernel = s.neighbors.radius <= s.kernel.re;
  const Displacement<D> displacement(s.domain);
  std::array<const double*, D> X;
  for (std::size_t a = 0; a < D; ++a) X[a] = p.positions()[a]->data();
  auto at = [&](std::size_t i) {
    Vec<D> r;
    for (std::size_t a = 0; a < D; ++a) r[a] = X[a][i];
    return r;
  };
  auto coupled = [&](std::size_t i, std::size_t j) {
    if (!in_sum(j)) return false;
    if (all_in_kernel) return true;
    return s.kernel.w(std::sqrt(norm2<D>(displacement(at(i), at(j))))) > 0.0;
  };
  // A candidate whose sum is empty has nothing coupling it to the rest and is left out (pressure 0).
  sys.unknown.assign(n, -1);
  sys.particle.clear();
  sys.floating.clear();
  std::vector<char> candidate(n, 0);
#pragma omp parallel for schedule(static) if (detail::worth_threads(static_cast<Index>(n)))
  for (Index ii = 0; ii < static_cast<Index>(n); ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    if (!in_ppe_sum(p.kind[i]) || free_surface[i]) continue;
    for (int j : s.neighbors.of(i))
      if (coupled(i, static_cast<std::size_t>(j))) {
        candidate[i] = 1;
        break;
      }
  }
  const bool every_particle = rows == PpeRows::every_particle;
  for (std::size_t i = 0; i < n; ++i) {
    if (!candidate[i] && !(every_particle && in_ppe_sum(p.kind[i]))) continue;
    sys.unknown[i] = static_cast<int>(sys.particle.size());
    sys.particle.push_back(static_cast<int>(i));
  }
  const auto m = static_cast<Index>(sys.particle.size());
  auto solved = [&](std::size_t j) { return candidate[j] != 0; };  // not a held row (PpeRows::every_particle)
  sys.held.assign(static_cast<std::size_t>(m), 0);
  sys.held_rows = 0;
  for (Index r = 0; r < m; ++r)
    if (!solved(static_cast<std::size_t>(sys.particle[static_cast<std::size_t>(r)]))) {
      sys.held[static_cast<std::size_t>(r)] = 1;
      ++sys.held_rows;
    }
  CsrMatrix& a = sys.matrix;
  a.rows = a.cols = static_cast<int>(m);
  a.row_ptr.assign(static_cast<std::size_t>(m) + 1, 0);
  sys.rhs.resize(static_cast<std::size_t>(m));
  std::vector<char>& anchored = sys.anchored;
  anchored.assign(static_cast<std::size_t>(m), shift > 0.0 ? 1 : 0);
  std::vector<double> diagonal(sys.held_rows > 0 ? static_cast<std::size_t>(m) : 0);  // the held rows' scale reads it

  // Each particle's part in a row's sum, read once per pair from one array: its column where solved, outside_sum
  // where it is in no sum, dirichlet_neighbour where its pressure is known.
  constexpr int dirichlet_neighbour = -1, outside_sum = -2;
  std::vector<int> column_of(n);
  for (std::size_t j = 0; j < n; ++j)
    column_of[j] = solved(j) ? sys.unknown[j] : in_sum(j) ? dirichlet_neighbour : outside_sum;

#pragma omp parallel for schedule(static) if (detail::worth_threads(m))
  for (Index r = 0; r < m; ++r) {
    const auto i = static_cast<std::size_t>(sys.particle[static_cast<std::size_t>(r)]);
    int entries = 1;
    if (solved(i))
      for (int jj : s.neighbors.of(i)) {
        const auto j = static_cast<std::size_t>(jj);
        entries += column_of[j] >= 0 && (all_in_kernel || coupled(i, j)) ? 1 : 0;
      }
    a.row_ptr[static_cast<std::size_t>(r) + 1] = entries;
  }
  for (std::size_t r = 1; r < a.row_ptr.size(); ++r) a.row_ptr[r] += a.row_ptr[r - 1];
  a.col.resize(static_cast<std::size_t>(a.row_ptr.back()));
  a.val.resize(a.col.size());

  // Unknowns are numbered in particle order and neighbour lists are sorted, so columns come out sorted
  // once the diagonal is slotted in at its place.
#pragma omp parallel if (detail::worth_threads(m))
  {
    detail::RowPairs<D> pairs;
#pragma omp for schedule(static)
    for (Index r = 0; r < m; ++r) {
      const auto i = static_cast<std::size_t>(sys.particle[static_cast<std::size_t>(r)]);
      if (!solved(i)) continue;
      auto k = static_cast<std::size_t>(a.row_ptr[static_cast<std::size_t>(r)]);
      std::size_t diag_slot = 0;
      bool placed = false;
      double known = 0.0;  // sum of w P_j over the Dirichlet neighbours
      double diag = 0.0;
      const std::size_t pair_count = pairs.fill(p, s.domain, s.neighbors, i);
      pairs.weigh_laplacian(s.kernel);
      const int* id = s.neighbors.of(i).data();
      const double* weight = pairs.w();
      for (std::size_t t = 0; t < pair_count; ++t) {
        const auto j = static_cast<std::size_t>(id[t]);
        const int col = column_of[j];
        const double w = weight[t];
        if (col == outside_sum || w <= 0.0) continue;
        diag += w;
        if (col == dirichlet_neighbour) {
          anchored[static_cast<std::size_t>(r)] = 1;
          if (!dirichlet.empty()) known += w * dirichlet[j];
          continue;
        }
        if (!placed && col > r) {
          diag_slot = k++;
          placed = true;
        }
        a.col[k] = col;
        a.val[k++] = -c * w;
      }
      if (!placed) diag_slot = k++;
      const double empty = open.weight.empty() ? 0.0 : open.weight[i];
      if (empty > 0.0) {
        anchored[static_cast<std::size_t>(r)] = 1;
        known += empty * open.value[i];
      }
      a.col[diag_slot] = static_cast<int>(r);
      a.val[diag_slot] = c * (diag + empty) + shift;
      if (!diagonal.empty()) diagonal[static_cast<std::size_t>(r)] = a.val[diag_slot];
      sys.rhs[static_cast<std::size_t>(r)] = -source[i] + c * known;
    }
  }
  if (sys.held_rows > 0) {
    // A held row stands alone, x = its value; its diagonal is the solved rows' mean, to leave A's scale as it was.
    double sum = 0.0;
    for (Index r = 0; r < m; ++r)
      if (!sys.held[static_cast<std::size_t>(r)]) sum += diagonal[static_cast<std::size_t>(r)];
    const auto solved_rows = static_cast<double>(static_cast<std::size_t>(m) - sys.held_rows);
    const double scale = solved_rows > 0 ? sum / solved_rows : 1.0;
    for (Index r = 0; r < m; ++r) {
      if (!sys.held[static_cast<std::size_t>(r)]) continue;
      const auto i = static_cast<std::size_t>(sys.particle[static_cast<std::size_t>(r)]);
      const auto k = static_cast<std::size_t>(a.row_ptr[static_cast<std::size_t>(r)]);
      a.col[k] = static_cast<int>(r);
      a.val[k] = scale;
      sys.rhs[static_cast<std::size_t>(r)] = scale * (dirichlet.empty() ? 0.0 : dirichlet[i]);
      anchored[static_cast<std::size_t>(r)] = 1;
    }
  }

  if (closed == ClosedGroups::gauge) {
    gauge_floating_groups(sys, anchored);
  } else {
    sys.group.assign(static_cast<std::size_t>(m), -1);
  }
}

template <int D>
std::vector<double> PpeSystem::gather(const BasicParticles<D>& particles, std::span<const double> offset) const {
  std::vector<double> x;
  gather(particles, x, offset);
  return x;
}

template <int D>
void PpeSystem::gather(const BasicParticles<D>& particles, std::vector<double>& x, std::span<const double> offset) const {
  x.resize(particle.size());
  for (std::size_t r = 0; r < x.size(); ++r) {
    const auto i = static_cast<std::size_t>(particle[r]);
    x[r] = held[r] ? rhs[r] / matrix.val[static_cast<std::size_t>(matrix.row_ptr[r])]
                   : particles.p[i] - (offset.empty() ? 0.0 : offset[i]);
  }
}

template <int D>
void PpeSystem::scatter(std::span<const double> solution, BasicParticles<D>& particles, bool clamp_negative,
                        std::span<const double> offset) const {
  if (solution.size() != particle.size()) throw std::invalid_argument("PpeSystem::scatter: wrong solution length");
  if (!offset.empty() && offset.size() != particles.size())
    throw std::invalid_argument("PpeSystem::scatter: offset must have one entry per particle");
  std::vector<double> mean(floating.size(), 0.0);
  for (std::size_t r = 0; r < solution.size(); ++r)
    if (group[r] >= 0) mean[static_cast<std::size_t>(group[r])] += solution[r];
  for (std::size_t g = 0; g < mean.size(); ++g) mean[g] /= floating[g].size;
  for (std::size_t i = 0; i < particles.size(); ++i)
    if (in_ppe_sum(particles.kind[i])) particles.p[i] = 0.0;
  for (std::size_t r = 0; r < solution.size(); ++r) {
    if (held[r]) continue;  // stays 0 as a particle left out would
    const auto i = static_cast<std::size_t>(particle[r]);
    const double base = offset.empty() ? 0.0 : offset[i];
    double& pr = particles.p[i];
    if (group[r] >= 0) pr = solution[r] - mean[static_cast<std::size_t>(group[r])] + base;
    else pr = clamp_negative ? std::max(0.0, solution[r] + base) : solution[r] + base;
  }
}

template <int D>
std::vector<char> set_dummy_pressure(const BasicStencil<D>& s, BasicParticles<D>& p, std::span<const char> free_surface,
                                     double rho, const std::type_identity_t<Vec<D>>& f) {
  std::vector<char> carrier;
  set_dummy_pressure(s, p, free_surface, rho, f, carrier);
  return carrier;
}

template <int D>
void set_dummy_pressure(const BasicStencil<D>& s, BasicParticles<D>& p, std::span<const char> free_surface, double rho,
                        const std::type_identity_t<Vec<D>>& f, std::vector<char>& carrier) {
  carrier.assign(p.size(), 0);
  // Read from the wet walls' rows, not the dummies': the step searches no dummy's row (the dummies are most of a
  // tank's boundary), and a nearest wall is the same whichever side finds the pair.
  std::vector<double> best_r2(p.size(), s.kernel.re * s.kernel.re);
  std::vector<int> best_id(p.size(), -1);
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.kind[i] == Kind::fluid || (p.kind[i] == Kind::wall && !free_surface[i])) carrier[i] = 1;
    if (p.kind[i] == Kind::dummy) p.p[i] = 0.0;
  }
  for (std::size_t j = 0; j < p.size(); ++j) {
    if (p.kind[j] != Kind::wall || free_surface[j]) continue;
    for (int ii : s.neighbors.of(j)) {
      const auto i = static_cast<std::size_t>(ii);
      if (p.kind[i] != Kind::dummy) continue;
      const Vec<D> d = s.domain.displacement(p.position(j), p.position(i));  // r_dummy - r_wall
      const double r2 = norm2<D>(d);
      // Of equally near walls the one of lowest id wins: the choice depends neither on the order the walls come in
      // (cell order serially, id order and halo copies on ranks) nor on the threads.
      if (r2 < best_r2[i] || (r2 == best_r2[i] && p.id[j] < best_id[i])) {
        best_r2[i] = r2;
        best_id[i] = p.id[j];
        p.p[i] = p.p[j] + rho * dot<D>(f, d);
        carrier[i] = 1;
      }
    }
  }
}

#define MPS_PPE_FOR(D)                                                                                                \
  template std::vector<char> detect_free_surface(const BasicParticles<D>&, std::span<const double>, double, double,  \
                                                 const NeighborList*, int, double);                                   \
  template void detect_free_surface(const BasicParticles<D>&, std::span<const double>, double, double,                \
                                    const NeighborList*, int, double, std::vector<char>&);                            \
  template PpeSystem assemble_ppe(const BasicStencil<D>&, std::span<const char>, std::span<const double>,             \
                                  std::span<const double>, double, ClosedGroups, OpenSupport, PpeRows);                \
  template void assemble_ppe(const BasicStencil<D>&, std::span<const char>, std::span<const double>, PpeSystem&,      \
                             std::span<const double>, double, ClosedGroups, OpenSupport, PpeRows);                     \
  template std::vector<double> PpeSystem::gather(const BasicParticles<D>&, std::span<const double>) const;            \
  template void PpeSystem::gather(const BasicParticles<D>&, std::vector<double>&, std::span<const double>) const;     \
  template void PpeSystem::scatter(std::span<const double>, BasicParticles<D>&, bool, std::span<const double>) const; \
  template std::vector<char> set_dummy_pressure<D>(const BasicStencil<D>&, BasicParticles<D>&, std::span<const char>,   \
                                                double, const Vec<D>&);                                               \
  template void set_dummy_pressure<D>(const BasicStencil<D>&, BasicParticles<D>&, std::span<const char>, double,         \
                                   const Vec<D>&, std::vector<char>&);
MPS_PPE_FOR(2)
MPS_PPE_FOR(3)
#undef MPS_PPE_FOR

}  // namespace mps
