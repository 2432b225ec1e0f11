// Neighbour search and PPE assembly cost against N (jittered 2-D water tank with a free surface).
// Writes CSV (N, phase, seconds, ns per particle) and prints the fitted slope of log time against log N.
// Lists and the PPE are refilled in place, as the time loop does, so repeats after the first reuse memory.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

#include "mps/boundaries/geometry.hpp"
#include "mps/io/io.hpp"
#include "mps/numerics/ppe.hpp"

namespace {

using Clock = std::chrono::steady_clock;

template <class F>
double median_seconds(int repeats, F&& f) {
  std::vector<double> t;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = Clock::now();
    f();
    t.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

double fitted_slope(const std::vector<double>& n, const std::vector<double>& t) {
  double mx = 0, my = 0;
  for (std::size_t i = 0; i < n.size(); ++i) {
    mx += std::log(n[i]);
    my += std::log(t[i]);
  }
  mx /= static_cast<double>(n.size());
  my /= static_cast<double>(n.size());
  double sxy = 0, sxx = 0;
  for (std::size_t i = 0; i < n.size(); ++i) {
    sxy += (std::log(n[i]) - mx) * (std::log(t[i]) - my);
    sxx += (std::log(n[i]) - mx) * (std::log(n[i]) - mx);
  }
  return sxy / sxx;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<double> sizes{1e4, 1e5, 1e6};
  std::string out = "bench/results/core.csv";
  int repeats = 5;
  CLI::App app{"SparseMPS core benchmark: neighbour search and PPE assembly against particle count"};
  app.add_option("--sizes", sizes, "approximate fluid particle counts")->capture_default_str();
  app.add_option("--repeats", repeats, "timed repetitions per phase (median reported)")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--out", out, "CSV output")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  const std::vector<std::string> phases{"bin", "neighbors_4.1", "neighbors_2.1", "number_density", "assemble_ppe", "reorder",
                                        "neighbors_4.1+2.1"};
  std::vector<double> col_n, col_phase, col_seconds, col_ns;
  std::map<std::string, std::vector<double>> times;
  std::vector<double> counts;
  std::printf("%10s  %-16s %12s %14s\n", "particles", "phase", "seconds", "ns/particle");
  for (double target : sizes) {
    const double l0 = 1.0;
    const int side = static_cast<int>(std::lround(std::sqrt(target)));
    mps::Particles p;
    mps::fill_rectangle(p, {0, 0, side * l0, side * l0}, l0, mps::Kind::fluid);
    mps::add_rectangle_walls(p, {0, 0, side * l0, side * l0 * 1.05}, l0, mps::left | mps::right | mps::bottom, 1, 4);
    std::mt19937 rng(42);
    std::uniform_real_distribution<double> jitter(-0.1 * l0, 0.1 * l0);
    for (std::size_t i = 0; i < p.size(); ++i)
      if (p.kind[i] == mps::Kind::fluid) {
        p.x[i] += jitter(rng);
        p.y[i] += jitter(rng);
      }
    const mps::Domain d{-6 * l0, (side + 6) * l0, -6 * l0, 1.2 * side * l0};
    const mps::Kernel small = mps::make_kernel(2.1, l0), lap = mps::make_kernel(4.1, l0);
    mps::CellGrid grid(d, lap.re);
    const double n = static_cast<double>(p.size());
    counts.push_back(n);
    mps::NeighborList near, close;
    std::vector<double> nd;
    std::vector<char> surface;
    std::vector<double> source(p.size(), 1.0);
    mps::PpeSystem sys;
    std::map<std::string, double> t;
    t["reorder"] = median_seconds(repeats, [&] {
      grid.bin(p);
      p.permute(grid.cell_order());
    });
    t["bin"] = median_seconds(repeats, [&] { grid.bin(p); });
    t["neighbors_4.1"] = median_seconds(repeats, [&] { grid.neighbors(p, lap.re, near); });
    t["neighbors_2.1"] = median_seconds(repeats, [&] { mps::restrict_radius(near, p, d, small.re, close); });
    // The time loop's form: one search filling both lists.
    t["neighbors_4.1+2.1"] = median_seconds(repeats, [&] { grid.neighbors(p, lap.re, near, small.re, close); });
    t["number_density"] = median_seconds(repeats, [&] { nd = mps::number_density({p, d, close, small}); });
    surface = mps::detect_free_surface(p, nd, small.n0, 0.97, &close, small.lattice_neighbors, 0.85);
    t["assemble_ppe"] = median_seconds(repeats, [&] { mps::assemble_ppe({p, d, near, lap}, surface, source, sys); });
    for (std::size_t k = 0; k < phases.size(); ++k) {
      const double s = t[phases[k]];
      times[phases[k]].push_back(s);
      col_n.push_back(n);
      col_phase.push_back(static_cast<double>(k));
      col_seconds.push_back(s);
      col_ns.push_back(1e9 * s / n);
      std::printf("%10.0f  %-16s %12.5f %14.1f\n", n, phases[k].c_str(), s, 1e9 * s / n);
    }
    std::printf("%10s  (PPE: %zu unknowns, %zu nonzeros)\n", "", sys.size(), sys.matrix.nnz());
  }
  mps::write_csv(out, {"particles", "phase_index", "seconds", "ns_per_particle"}, {col_n, col_phase, col_seconds, col_ns});
  std::printf("\nphase index: ");
  for (std::size_t k = 0; k < phases.size(); ++k) std::printf("%zu=%s ", k, phases[k].c_str());
  std::printf("\n");
  if (counts.size() >= 2) {  // one size has no slope
    std::printf("fitted slope of log(time) against log(N) (1 = linear):\n");
    for (const auto& ph : phases) std::printf("  %-16s %.3f\n", ph.c_str(), fitted_slope(counts, times[ph]));
  }
  std::printf("CSV: %s\n", out.c_str());
  return 0;
}
