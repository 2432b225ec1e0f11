#include "mps/core/neighbors.hpp"
#include "mps/core/threads.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace mps {

namespace {
constexpr double kMaxCells = 1e8;

std::string fmt_g(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", v);
  return text;
}
}  // namespace

template <int D>
BasicCellGrid<D>::BasicCellGrid(const BasicDomain<D>& domain, double cell_size)
    : BasicCellGrid(domain, cell_size, 0.0) {}

template <int D>
BasicCellGrid<D>::BasicCellGrid(const BasicDomain<D>& domain, double cell_size, double margin)
    : domain_(domain), cell_size_(cell_size + margin) {
  domain_.validate();
  if (!(cell_size > 0.0) || !std::isfinite(cell_size))
    throw std::invalid_argument("CellGrid: cell size (the largest search radius) must be positive, got " +
                                std::to_string(cell_size));
  if (!(margin >= 0.0) || !std::isfinite(margin))
    throw std::invalid_argument("CellGrid: the search margin must be finite and >= 0, got " + std::to_string(margin));
  // A periodic axis shorter than three radii would let a particle meet two images of the same neighbour.
  const auto periodic = domain_.periodic();
  for (std::size_t a = 0; a < D; ++a)
    if (periodic[a] && domain_.extent(static_cast<int>(a)) < 3.0 * cell_size_)
      throw std::invalid_argument("CellGrid: a periodic axis must be at least 3 search radii long");
  // Half-radius cells: the runs scanned for a radius-r search cover (2r + h)^2 = 6.25 r^2 instead of the
  // 9 r^2 of radius-wide cells, so a third fewer distance tests.
  Vec<D> cells;
  double total = 1.0;
  for (std::size_t a = 0; a < D; ++a) {
    cells[a] = std::floor(domain_.extent(static_cast<int>(a)) / (0.5 * cell_size));
    total *= std::max(cells[a], 1.0);
  }
  // A domain far larger than its particles' spacing (a particle far from the rest) would need more memory than the
  // particles themselves.
  if (!(total <= kMaxCells)) {
    std::string size = fmt_g(domain_.extent(0));
    for (std::size_t a = 1; a < D; ++a) size += " m x " + fmt_g(domain_.extent(static_cast<int>(a)));
    throw std::invalid_argument("CellGrid: the domain, " + size + " m, would hold " + fmt_g(total) +
                                " cells of half the search radius (" + fmt_g(cell_size) +
                                " m), more than the 1e8 a grid may hold: is a particle far from the others?");
  }
  const auto lower = domain_.lower();
  for (std::size_t a = 0; a < D; ++a) {
    n_[a] = std::max(1, static_cast<int>(cells[a]));
    h_[a] = domain_.extent(static_cast<int>(a)) / n_[a];
    // Far above the few ulps of a coordinate by which floor((x - lower) / h) can disagree with the cell's bounds.
    edge_margin_[a] = 1e-6 * h_[a] + 1e-13 * (std::abs(lower[a]) + domain_.extent(static_cast<int>(a)));
  }
}

template <int D>
int BasicCellGrid<D>::cell_of(const Vec<D>& r) const {
  // Clamping keeps escaped particles binned (at the edge) so the search stays correct; the guard reports them.
  const auto lower = domain_.lower();
  int index = 0;
  for (std::size_t a = D; a-- > 0;) {
    const int c = static_cast<int>(std::floor((r[a] - lower[a]) / h_[a]));
    index = index * n_[a] + std::clamp(c, 0, n_[a] - 1);
  }
  return index;
}

template <int D>
void BasicCellGrid<D>::bin(const BasicParticles<D>& particles) {
  const std::size_t n = particles.size();
  const auto positions = particles.positions();
  n_particles_ = n;
  std::vector<int> cell(n, -1);
  std::size_t cells = 1;
  for (std::size_t a = 0; a < D; ++a) cells *= static_cast<std::size_t>(n_[a]);
  cell_start_.assign(cells + 1, 0);
  ghosts_.clear();
  for (std::size_t i = 0; i < n; ++i) {
    if (particles.kind[i] == Kind::ghost) {
      ghosts_.push_back(static_cast<int>(i));
      continue;
    }
    Vec<D> r;
    for (std::size_t a = 0; a < D; ++a) {
      r[a] = (*positions[a])[i];
      if (!std::isfinite(r[a]))
        throw std::runtime_error("CellGrid: particle " + std::to_string(i) + " has a non-finite position");
    }
    domain_.wrap(r);
    cell[i] = cell_of(r);
    ++cell_start_[static_cast<std::size_t>(cell[i]) + 1];
  }
  for (std::size_t c = 1; c < cell_start_.size(); ++c) cell_start_[c] += cell_start_[c - 1];
  const std::size_t binned = n - ghosts_.size();
  ids_.resize(binned);
  for (auto& c : coords_) c.resize(binned);
  std::vector<int> fill(cell_start_.begin(), cell_start_.end() - 1);
  for (std::size_t i = 0; i < n; ++i) {
    if (cell[i] < 0) continue;
    const auto k = static_cast<std::size_t>(fill[static_cast<std::size_t>(cell[i])]++);
    ids_[k] = static_cast<int>(i);
    Vec<D> r;
    for (std::size_t a = 0; a < D; ++a) r[a] = (*positions[a])[i];
    domain_.wrap(r);
    for (std::size_t a = 0; a < D; ++a) coords_[a][k] = r[a];
  }
}

template <int D>
NeighborList BasicCellGrid<D>::neighbors(const BasicParticles<D>& particles, double radius) const {
  NeighborList list;
  neighbors(particles, radius, list);
  return list;
}

template <int D>
void BasicCellGrid<D>::neighbors(const BasicParticles<D>& particles, double radius, NeighborList& list,
                                 std::span<const char> rows) const {
  search(particles, radius, list, nullptr, nullptr, rows);
}

template <int D>
void BasicCellGrid<D>::neighbors(const BasicParticles<D>& particles, double radius, NeighborList& list,
                                 double inner_radius, NeighborList& inner, std::span<const char> rows) const {
  if (!(inner_radius > 0.0) || inner_radius > radius)
    throw std::invalid_argument("CellGrid::neighbors: the inner radius must be in (0, radius]");
  if (&inner == &list) throw std::invalid_argument("CellGrid::neighbors: the inner list must be another list");
  inner.radius = inner_radius;
  search(particles, radius, list, &inner, nullptr, rows);
}

template <int D>
void BasicCellGrid<D>::neighbors(const BasicParticles<D>& particles, double radius, NeighborList& list,
                                 double inner_radius, NeighborList* inner, double fringe_radius,
                                 NeighborList& fringe, std::span<const char> rows) const {
  if (inner && (!(inner_radius > 0.0) || inner_radius > radius))
    throw std::invalid_argument("CellGrid::neighbors: the inner radius must be in (0, radius]");
  if (!(fringe_radius > radius))
    throw std::invalid_argument("CellGrid::neighbors: the fringe's outer radius must be above the radius");
  if (&fringe == &list || &fringe == inner || inner == &list)
    throw std::invalid_argument("CellGrid::neighbors: the inner, fringe and main lists must be three lists");
  if (inner) inner->radius = inner_radius;
  fringe.radius = fringe_radius;
  search(particles, radius, list, inner, &fringe, rows);
}

namespace {

// Appends row[0 .. count) to out, sorted. Runs come in cell order, so once particles have been permuted into
// cell order a row is nearly sorted and insertion sort finishes it in about one pass; a row far from sorted
// (particles never reordered) is handed to std::sort instead of costing count^2 moves.
void append_sorted(const std::vector<int>& row, std::size_t count, std::vector<int>& out) {
  const auto last = row.begin() + static_cast<std::ptrdiff_t>(count);
  if (std::is_sorted(row.begin(), last)) {  // the common case right after a reordering: one copy
    out.insert(out.end(), row.begin(), last);
    return;
  }
  const std::size_t start = out.size();
  std::size_t moves = 0;
  for (std::size_t a = 0; a < count; ++a) {
    const int v = row[a];
    out.push_back(v);
    std::size_t b = start + a;
    for (; b > start && out[b - 1] > v; --b) out[b] = out[b - 1];
    out[b] = v;
    moves += start + a - b;
    if (moves > 4 * count) {
      out.insert(out.end(), row.begin() + static_cast<std::ptrdiff_t>(a + 1),
                 row.begin() + static_cast<std::ptrdiff_t>(count));
      std::sort(out.begin() + static_cast<std::ptrdiff_t>(start), out.end());
      return;
    }
  }
}

// The first row of each of `threads` shares of rows [0, n) holding equally many rows with searched(i), and n.
template <class Searched>
std::vector<std::ptrdiff_t> first_rows_of_shares(std::ptrdiff_t n, std::ptrdiff_t threads, Searched&& searched) {
  std::vector<std::ptrdiff_t> start(static_cast<std::size_t>(threads) + 1, n);
  start[0] = 0;
  if (threads == 1) return start;
  std::ptrdiff_t total = 0;
  for (std::ptrdiff_t i = 0; i < n; ++i) total += searched(i) ? 1 : 0;
  std::ptrdiff_t seen = 0, share = 1;
  for (std::ptrdiff_t i = 0; i < n && share < threads; ++i) {
    while (share < threads && seen >= total * share / threads) start[static_cast<std::size_t>(share++)] = i;
    seen += searched(i) ? 1 : 0;
  }
  return start;
}

}  // namespace

template <int D>
void BasicCellGrid<D>::search(const BasicParticles<D>& particles, double radius, NeighborList& list,
                              NeighborList* inner, NeighborList* fringe, std::span<const char> searched_rows) const {
  if (!searched_rows.empty() && searched_rows.size() != particles.size())
    throw std::invalid_argument("CellGrid::neighbors: " + std::to_string(searched_rows.size()) + " row flags for " +
                                std::to_string(particles.size()) + " particles");
  if (inner && fringe) search_lists<true, true>(particles, radius, list, inner, fringe, searched_rows);
  else if (inner) search_lists<true, false>(particles, radius, list, inner, fringe, searched_rows);
  else if (fringe) search_lists<false, true>(particles, radius, list, inner, fringe, searched_rows);
  else search_lists<false, false>(particles, radius, list, inner, fringe, searched_rows);
}

template <int D>
template <bool with_inner, bool with_fringe>
void BasicCellGrid<D>::search_lists(const BasicParticles<D>& particles, double radius, NeighborList& list,
                                    NeighborList* inner, NeighborList* fringe,
                                    std::span<const char> searched_rows) const {
  if (particles.size() != n_particles_) throw std::logic_error("CellGrid::neighbors: bin() the particles first");
  const double scan_radius = with_fringe ? fringe->radius : radius;
  if (!(radius > 0.0) || scan_radius > cell_size_ * (1.0 + 1e-12))
    throw std::invalid_argument("CellGrid::neighbors: radius must be in (0, cell size]");
  const auto n = static_cast<std::ptrdiff_t>(particles.size());
  std::array<NeighborList*, 3> lists{&list, inner, fringe};
  std::array<std::size_t, 3> expected{};
  for (std::size_t s = 0; s < 3; ++s)
    if (lists[s]) {
      expected[s] = lists[s]->index.size();
      lists[s]->offsets.assign(particles.size() + 1, 0);
    }
  list.radius = radius;
  const double r2 = radius * radius, scan_r2 = scan_radius * scan_radius;
  const double inner_r2 = with_inner ? inner->radius * inner->radius : 0.0;

  // One pass: each thread fills its contiguous share of the rows, then copies it into place; the first share is
  // written straight into the kept lists, so one thread copies and allocates nothing after the first step. The
  // loops write every candidate and advance the count of kept ones: no branch to mispredict. With a fringe, the
  // scan keeps the pairs within its outer radius with their squared distances, and they are dealt to the list and
  // the fringe afterwards (a skin of a fortieth of the radius gives the fringe 5 % of them in 2-D, 7.5 % in 3-D).
  const auto positions = particles.positions();
  std::array<const double*, D> coords;
  for (std::size_t a = 0; a < D; ++a) coords[a] = coords_[a].data();
  auto scan = [&](std::ptrdiff_t i, auto&& run_kernel) {
    const auto si = static_cast<std::size_t>(i);
    Vec<D> r;
    for (std::size_t a = 0; a < D; ++a) r[a] = (*positions[a])[si];
    domain_.wrap(r);
    for_each_run(r, scan_radius, [&](int begin, int end, const Vec<D>& shift) {
      Vec<D> at;
      for (std::size_t a = 0; a < D; ++a) at[a] = r[a] - shift[a];
      run_kernel(static_cast<std::size_t>(begin), static_cast<std::size_t>(end), at);
    });
  };
  const auto searched = [&](std::ptrdiff_t i) {
    const auto si = static_cast<std::size_t>(i);
    return particles.kind[si] != Kind::ghost && (searched_rows.empty() || searched_rows[si]);
  };
  std::vector<std::ptrdiff_t> share_start;  // with threads: the first row of each thread's share
#pragma omp parallel if (detail::worth_threads(n))
  {
#ifdef _OPENMP
    const std::ptrdiff_t threads = omp_get_num_threads(), thread = omp_get_thread_num();
#else
    const std::ptrdiff_t threads = 1, thread = 0;
#endif
    // Shares of equally many searched rows: the rows skipped (a tank's dummies) lie together in cell order.
#pragma omp single
    share_start = first_rows_of_shares(n, threads, searched);
    const auto share = static_cast<std::size_t>(thread);
    const std::ptrdiff_t first_row = share_start[share], end_row = share_start[share + 1];
    std::array<std::vector<int>, 3> own_rows;
    std::array<std::vector<int>*, 3> rows{};
    for (std::size_t s = 0; s < 3; ++s) {
      if (!lists[s]) continue;
      rows[s] = thread == 0 ? &lists[s]->index : &own_rows[s];
      if (thread == 0) rows[s]->clear();
      else  // about the previous list's share, read before any thread writes it
        rows[s]->reserve(expected[s] / static_cast<std::size_t>(threads) + expected[s] / 32);
    }
    std::vector<int> row, inner_row, near_row, fringe_row;
    std::vector<double> row_d2;
    for (std::ptrdiff_t i = first_row; i < end_row; ++i) {
      if (!searched(i)) continue;
      std::size_t kept = 0, inner_kept = 0, scanned = 0;
      const int self = static_cast<int>(i);
      scan(i, [&](std::size_t first, std::size_t last, const Vec<D>& at) {
        scanned += last - first;
        if (row.size() < scanned) {
          row.resize(2 * scanned);
          if (with_inner) inner_row.resize(row.size());
          if (with_fringe) row_d2.resize(row.size());
        }
        // Locals the compiler keeps in registers: through the captured references it reloaded them every candidate.
        int* const out = row.data();
        int* const inner_out = inner_row.data();
        double* const out_d2 = row_d2.data();
        const int* const id = ids_.data();
        const std::array<const double*, D> c = coords;
        const Vec<D> centre = at;
        const double limit2 = scan_r2, inner_limit2 = inner_r2;
        const int me = self;
        std::size_t n_kept = kept, n_inner = inner_kept;
        for (std::size_t k = first; k < last; ++k) {
          const double dx = c[0][k] - centre[0];
          double d2 = dx * dx;
          for (std::size_t a = 1; a < D; ++a) {
            const double da = c[a][k] - centre[a];
            d2 += da * da;
          }
          const int j = id[k];
          out[n_kept] = j;
          if constexpr (with_fringe) out_d2[n_kept] = d2;
          n_kept += (d2 < limit2) & (j != me) ? 1 : 0;
          if constexpr (with_inner) {
            inner_out[n_inner] = j;
            n_inner += (d2 < inner_limit2) & (j != me) ? 1 : 0;
          }
        }
        kept = n_kept;
        inner_kept = n_inner;
      });
      std::size_t near_kept = kept, fringe_kept = 0;
      if constexpr (with_fringe) {
        if (near_row.size() < kept) {
          near_row.resize(2 * kept);
          fringe_row.resize(near_row.size());
        }
        near_kept = 0;
        for (std::size_t t = 0; t < kept; ++t) {
          near_row[near_kept] = fringe_row[fringe_kept] = row[t];
          const bool near = row_d2[t] < r2;
          near_kept += near ? 1 : 0;
          fringe_kept += near ? 0 : 1;
        }
        append_sorted(near_row, near_kept, *rows[0]);
        append_sorted(fringe_row, fringe_kept, *rows[2]);
        fringe->offsets[static_cast<std::size_t>(i) + 1] = static_cast<int>(fringe_kept);
      } else {
        append_sorted(row, kept, *rows[0]);
      }
      list.offsets[static_cast<std::size_t>(i) + 1] = static_cast<int>(near_kept);
      if constexpr (with_inner) {
        append_sorted(inner_row, inner_kept, *rows[1]);
        inner->offsets[static_cast<std::size_t>(i) + 1] = static_cast<int>(inner_kept);
      }
    }
#pragma omp barrier
#pragma omp single
    {
      // resize keeps the first thread's share, already in place
      for (NeighborList* l : lists) {
        if (!l) continue;
        for (std::size_t i = 1; i < l->offsets.size(); ++i) l->offsets[i] += l->offsets[i - 1];
        l->index.resize(static_cast<std::size_t>(l->offsets.back()));
      }
    }  // implicit barrier
    if (thread > 0)
      for (std::size_t s = 0; s < 3; ++s)
        if (lists[s])
          std::copy(own_rows[s].begin(), own_rows[s].end(),
                    lists[s]->index.begin() + lists[s]->offsets[static_cast<std::size_t>(first_row)]);
  }
}

template <int D>
std::vector<int> BasicCellGrid<D>::cell_order() const {
  std::vector<int> order(ids_);
  order.insert(order.end(), ghosts_.begin(), ghosts_.end());
  return order;
}

template <int D>
NeighborList restrict_radius(const NeighborList& list, const BasicParticles<D>& particles, const BasicDomain<D>& domain,
                             double radius) {
  NeighborList out;
  restrict_radius(list, particles, domain, radius, out);
  return out;
}

template <int D>
void restrict_radius(const NeighborList& list, const BasicParticles<D>& particles, const BasicDomain<D>& domain,
                     double radius, NeighborList& out) {
  if (!(radius > 0.0) || radius > list.radius * (1.0 + 1e-12))
    throw std::invalid_argument("restrict_radius: radius must be in (0, the list's radius]");
  if (&out == &list) throw std::invalid_argument("restrict_radius: out must not be the input list");
  const double r2 = radius * radius;
  const auto n = static_cast<std::ptrdiff_t>(list.particles());
  out.radius = radius;
  out.offsets.assign(list.offsets.size(), 0);
  auto distance2 = [&](std::size_t i, int j) {
    const Vec<D> d = domain.displacement(particles.position(i), particles.position(static_cast<std::size_t>(j)));
    double s = d[0] * d[0];
    for (std::size_t a = 1; a < D; ++a) s += d[a] * d[a];
    return s;
  };
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (std::ptrdiff_t ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    int count = 0;
    for (int j : list.of(i)) count += distance2(i, j) < r2 ? 1 : 0;
    out.offsets[i + 1] = count;
  }
  for (std::size_t i = 1; i < out.offsets.size(); ++i) out.offsets[i] += out.offsets[i - 1];
  out.index.resize(static_cast<std::size_t>(out.offsets.back()));
#pragma omp parallel if (detail::worth_threads(n))
  {
    std::vector<int> row;  // written unconditionally, kept ones counted: no branch to mispredict
#pragma omp for schedule(static)
    for (std::ptrdiff_t ii = 0; ii < n; ++ii) {
      const auto i = static_cast<std::size_t>(ii);
      const auto candidates = list.of(i);
      if (row.size() < candidates.size()) row.resize(2 * candidates.size());
      std::size_t kept = 0;
      for (int j : candidates) {
        row[kept] = j;
        kept += distance2(i, j) < r2 ? 1 : 0;
      }
      // stays sorted: a subsequence of a sorted row
      std::copy_n(row.begin(), kept, out.index.begin() + out.offsets[i]);
    }
  }
}

void add_fringe(NeighborList& list, const NeighborList& fringe) {
  if (fringe.particles() != list.particles() || !(fringe.radius > list.radius))
    throw std::invalid_argument("add_fringe: the fringe must have the list's rows and a larger radius");
  std::vector<int>& index = list.index;
  std::vector<int>& offsets = list.offsets;
  index.resize(index.size() + fringe.index.size());
  // Backwards, last row first: a row's merged entries land at or after its old ones and after every earlier row's
  // old ones, so nothing is overwritten before it is read. Rows before the first fringe entry stay where they are.
  std::size_t write = index.size();
  for (std::size_t i = list.particles(); i-- > 0 && fringe.offsets[i + 1] > 0;) {
    auto a = static_cast<std::size_t>(offsets[i + 1]), b = static_cast<std::size_t>(fringe.offsets[i + 1]);
    const auto a0 = static_cast<std::size_t>(offsets[i]), b0 = static_cast<std::size_t>(fringe.offsets[i]);
    offsets[i + 1] = static_cast<int>(write);
    while (b > b0) {  // branch-free: which side gives the next entry is data, not a jump to mispredict
      const int from_list = a > a0 ? index[a - 1] : -1, from_fringe = fringe.index[b - 1];
      const bool take_list = from_list > from_fringe;
      index[--write] = take_list ? from_list : from_fringe;
      a -= take_list ? 1 : 0;
      b -= take_list ? 0 : 1;
    }
    const auto at = [&](std::size_t k) { return index.begin() + static_cast<std::ptrdiff_t>(k); };
    if (write != a) std::copy_backward(at(a0), at(a), at(write));  // else in place (copy_backward may not self-copy)
    write -= a - a0;
  }
  list.radius = fringe.radius;
}

template <int D>
NeighborList find_neighbors(const BasicParticles<D>& particles, const BasicDomain<D>& domain, double radius) {
  BasicCellGrid<D> grid(domain, radius);
  grid.bin(particles);
  return grid.neighbors(particles, radius);
}

template class BasicCellGrid<2>;
template class BasicCellGrid<3>;
template NeighborList restrict_radius(const NeighborList&, const Particles&, const Domain&, double);
template NeighborList restrict_radius(const NeighborList&, const Particles3&, const Domain3&, double);
template void restrict_radius(const NeighborList&, const Particles&, const Domain&, double, NeighborList&);
template void restrict_radius(const NeighborList&, const Particles3&, const Domain3&, double, NeighborList&);
template NeighborList find_neighbors(const Particles&, const Domain&, double);
template NeighborList find_neighbors(const Particles3&, const Domain3&, double);

}  // namespace mps
