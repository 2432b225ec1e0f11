// Solver benchmark: every backend on pressure Poisson systems assembled by the library from a jittered 2-D
// lattice with a free surface (a water tank, 4.1 l0 Laplacian), at several sizes, and on any Matrix Market
// files given on the command line. Per backend: setup and solve seconds, iterations, true relative residual,
// solve cost in SpMV-equivalents (solve seconds / one SpMV of the same matrix, timed in the same run, median
// of several) and peak memory. Every solve starts from x = 0. A spec with reuse=N is run twice: on the system
// (fresh setup) and on a perturbed system of the same size (the particles moved a little: reused setup).
//
//   bench_solvers --sizes 1e4,1e5,1e6 --limit "eigen-bicgstab=200000" --out bench/results/solvers.csv data/*.mtx
//   bench_solvers --files-only data/ppe/*.mtx.gz   (the sample PPEs of real scenes, scripts/make_sample_ppes.py)
//   bench_solvers --export-samples data      (writes the small sample PPEs kept in data/)
#include <malloc.h>
#include <omp.h>
#include <sys/utsname.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "mps/boundaries/geometry.hpp"
#include "solver_cli.hpp"
#include "mps/core/kernel.hpp"
#include "mps/core/neighbors.hpp"
#include "mps/io/io.hpp"
#include "mps/numerics/operators.hpp"
#include "mps/numerics/ppe.hpp"
#include "mps/solvers/solver.hpp"

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// ---------------------------------------------------------------------------------------------------------
// The systems.

struct System {
  std::string source;  // "tank" or a file name
  mps::CsrMatrix a;
  std::vector<double> b;
};

struct TankParams {
  int nx = 100, ny = 100;
  double radius = 4.1;   // Laplacian radius / l0
  double jitter = 0.02;  // uniform position noise, in l0 (0.05 already flags interior particles as free surface)
  // The source: the smooth part -(rho/dt^2) 1e-3 (1 + 0.5 cos(pi x/W) cos(pi y/H)) (a uniform compression
  // with a large-scale variation, as gravity loads a tank: the pressure it asks for is smooth and set by the
  // whole domain, the hard case for local preconditioners) plus `mixed` times the mixed source of the
  // lattice's own number-density noise and a smooth velocity field (gamma 0.99, as in the time loop).
  double mixed = 1.0;
  bool closed = false;  // walls on all four sides, no free surface (the gauge-fixed all-Neumann PPE)
  unsigned seed = 1;
};

// A water tank on a jittered lattice, particles in cell order as the time loop keeps them. `shift` moves
// the fluid by a smooth displacement of that amplitude (in l0) before the assembly while keeping the
// free-surface flags given in `surface` (if any): the next time step's system, same unknowns.
struct Tank {
  mps::Particles particles;
  mps::Domain domain;
  std::vector<char> surface;
  mps::PpeSystem ppe;
};

Tank make_tank(const TankParams& t, double shift = 0.0, const std::vector<char>* keep_surface = nullptr,
               const mps::Particles* base = nullptr) {
  const double l0 = 0.01, w = t.nx * l0, h = t.ny * l0;
  Tank tank;
  mps::Particles& p = tank.particles;
  tank.domain = {-6 * l0, w + 6 * l0, -6 * l0, 1.2 * h + 6 * l0};
  if (base != nullptr) {
    p = *base;
  } else {
    mps::fill_rectangle(p, {0.0, 0.0, w, h}, l0, mps::Kind::fluid);
    std::mt19937 rng(t.seed);
    std::uniform_real_distribution<double> noise(-t.jitter * l0, t.jitter * l0);
    for (std::size_t i = 0; i < p.size(); ++i) {
      p.x[i] += noise(rng);
      p.y[i] += noise(rng);
      p.u[i] = 0.01 * std::sin(M_PI * p.x[i] / w) * std::cos(M_PI * p.y[i] / h);
      p.v[i] = -0.01 * std::cos(M_PI * p.x[i] / w) * std::sin(2.0 * M_PI * p.y[i] / h);
    }
    const mps::Rect inner{0.0, 0.0, w, t.closed ? h : 1.2 * h};
    mps::add_rectangle_walls(
        p, inner, l0,
        t.closed ? (mps::left | mps::right | mps::bottom | mps::top) : (mps::left | mps::right | mps::bottom), 1, 4);
    mps::CellGrid grid(tank.domain, t.radius * l0);
    grid.bin(p);
    p.permute(grid.cell_order());
  }
  if (shift != 0.0)
    for (std::size_t i = 0; i < p.size(); ++i)
      if (p.kind[i] == mps::Kind::fluid) {
        p.x[i] += shift * l0 * std::sin(2.0 * M_PI * p.y[i] / h);
        p.y[i] += shift * l0 * std::sin(2.0 * M_PI * p.x[i] / w);
      }
  const auto list = mps::find_neighbors(p, tank.domain, t.radius * l0);
  const mps::Kernel lap = mps::make_kernel(t.radius, l0), den = mps::make_kernel(2.1, l0);
  const std::vector<double> n = mps::number_density({p, tank.domain, list, den});
  std::vector<double> div(p.size());
  mps::divergence({p, tank.domain, list, den}, p.u, p.v, div);
  if (keep_surface != nullptr)
    tank.surface = *keep_surface;
  else if (t.closed)
    tank.surface.assign(p.size(), 0);
  else
    tank.surface = mps::detect_free_surface(p, n, den.n0, 0.97);
  const double rho = 1000.0, dt = 1e-3;
  std::vector<double> source = mps::mixed_source(n, den.n0, div, rho, dt, 0.99);
  for (std::size_t i = 0; i < p.size(); ++i)
    source[i] = t.mixed * source[i] -
                rho / (dt * dt) * 1e-3 * (1.0 + 0.5 * std::cos(M_PI * p.x[i] / w) * std::cos(M_PI * p.y[i] / h));
  tank.ppe = mps::assemble_ppe({p, tank.domain, list, lap}, tank.surface, source);
  return tank;
}

// NAME of NAME.mtx or NAME.mtx.gz (data/ppe/ keeps its samples compressed).
std::string matrix_name(const fs::path& path) {
  std::string name = path.filename().string();
  for (const char* suffix : {".gz", ".mtx"})
    if (name.ends_with(suffix)) name.resize(name.size() - std::string(suffix).size());
  return name;
}

System from_file(const fs::path& path) {
  System s;
  s.source = path.filename().string();
  s.a = mps::read_matrix_market(path);
  s.a.validate();
  const bool gz = path.extension() == ".gz";
  const fs::path rhs = path.parent_path() / (matrix_name(path) + (gz ? "_rhs.mtx.gz" : "_rhs.mtx"));
  if (fs::exists(rhs)) {
    s.b = mps::read_matrix_market_vector(rhs);
  } else {  // b = A 1: the exact solution is all ones
    const std::vector<double> ones(static_cast<std::size_t>(s.a.cols), 1.0);
    s.b.resize(static_cast<std::size_t>(s.a.rows));
    s.a.multiply(ones, s.b);
  }
  return s;
}

// ---------------------------------------------------------------------------------------------------------
// Measurements.

// Lets worker threads of the previous run park before the next timing: OpenBLAS (CHOLMOD) and OpenMP workers
// spin for a while after their last task, and on two cores a spinning thread delays the next parallel region
// by a scheduler tick.
void settle() { std::this_thread::sleep_for(std::chrono::milliseconds(300)); }

double median_spmv_seconds(const mps::CsrMatrix& a, int repeats) {
  settle();
  std::vector<double> x(static_cast<std::size_t>(a.cols), 1.0), y(static_cast<std::size_t>(a.rows));
  a.multiply(x, y);  // warm up (page in, spin up threads)
  std::vector<double> t;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = Clock::now();
    a.multiply(x, y);
    t.push_back(seconds_since(t0));
  }
  std::nth_element(t.begin(), t.begin() + static_cast<std::ptrdiff_t>(t.size() / 2), t.end());
  return t[t.size() / 2];
}

long status_kb(const char* field, const char* file = "/proc/self/status") {
  std::ifstream in(file);
  std::string line;
  const std::string key = std::string(field) + ":";
  while (std::getline(in, line))
    if (line.rfind(key, 0) == 0) return std::stol(line.substr(key.size()));
  return -1;
}

// Peak resident memory of what runs between begin() and end(), in MB: the high-water mark is reset through
// /proc/self/clear_refs (Linux >= 4.0) and freed heap is handed back first, so earlier runs do not count.
struct PeakMemory {
  long baseline_kb = 0;
  bool reset_ok = false;
  void begin() {
    malloc_trim(0);
    std::ofstream clear("/proc/self/clear_refs");
    clear << "5";
    clear.close();
    reset_ok = static_cast<bool>(clear);
    baseline_kb = status_kb("VmRSS");
  }
  [[nodiscard]] double end_mb() const {
    if (!reset_ok) return std::nan("");
    return static_cast<double>(status_kb("VmHWM") - baseline_kb) / 1024.0;
  }
};

struct Row {
  std::string source;
  long long n = 0, nnz = 0;
  std::string spec, phase, status = "ok";
  double setup_s = 0, solve_s = 0, residual = 0, spmv_s = 0, spmv1_s = 0, mem_mb = 0;
  int iterations = 0;
  bool reused = false;
};

std::string csv_escape(std::string s) {
  std::replace(s.begin(), s.end(), '"', '\'');
  return "\"" + s + "\"";
}

void write_csv(const fs::path& path, const std::vector<Row>& rows, const std::string& header_comment) {
  if (path.has_parent_path()) fs::create_directories(path.parent_path());
  std::ofstream out(path);
  out << "# " << header_comment << "\n";
  out << "source,n,nnz,backend,phase,setup_s,solve_s,total_s,iterations,rel_residual,spmv_s,spmv_1thread_s,"
         "spmv_equiv,spmv_equiv_1thread,peak_mem_mb,setup_reused,status\n";
  out << std::setprecision(6);
  for (const Row& r : rows)
    out << r.source << "," << r.n << "," << r.nnz << "," << csv_escape(r.spec) << "," << r.phase << "," << r.setup_s
        << "," << r.solve_s << "," << r.setup_s + r.solve_s << "," << r.iterations << "," << r.residual << ","
        << r.spmv_s << "," << r.spmv1_s << "," << r.solve_s / r.spmv_s << "," << r.solve_s / r.spmv1_s << ","
        << r.mem_mb << "," << (r.reused ? 1 : 0) << "," << csv_escape(r.status) << "\n";
}

void print_row(const Row& r) {
  std::cout << std::left << std::setw(10) << r.source.substr(0, 10) << std::right << std::setw(9) << r.n << "  "
            << std::left << std::setw(34) << r.spec.substr(0, 34) << std::setw(7) << r.phase << std::right << std::fixed
            << std::setprecision(3) << std::setw(9) << r.setup_s << std::setw(9) << r.solve_s << std::setw(7)
            << r.iterations << std::scientific << std::setprecision(1) << std::setw(9) << r.residual << std::fixed
            << std::setprecision(0) << std::setw(8) << r.solve_s / r.spmv_s << std::setw(8) << r.mem_mb << "  "
            << (r.status == "ok" ? "" : r.status.substr(0, 60)) << std::endl;
}

std::string machine_line() {
  std::string cpu = "unknown cpu";
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) {
      cpu = line.substr(line.find(':') + 2);
      break;
    }
  utsname u{};
  uname(&u);
  std::ostringstream s;
  s << cpu << ", " << omp_get_num_procs() << " cores, "
    << std::lround(static_cast<double>(status_kb("MemTotal", "/proc/meminfo")) / 1048576.0) << " GB RAM, Linux "
    << u.release;
  return s.str();
}

std::string loaded_blas() {
  std::ifstream in("/proc/self/maps");
  for (std::string line; std::getline(in, line);)
    if (line.find("openblas") != std::string::npos) return "OpenBLAS (" + line.substr(line.find('/')) + ")";
  return "no OpenBLAS mapped";
}

std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string one, five, fifteen;
  in >> one >> five >> fifteen;
  return one + " " + five + " " + fifteen;
}

std::string today() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%d", std::localtime(&t));
  return buf;
}

bool has_reuse(const std::string& spec) {
  const mps::SolverSpec s = mps::parse_solver_spec(spec);
  const auto it = s.options.find("reuse");
  return it != s.options.end() && it->second != "0";
}

// Runs one spec on a system, from x = 0; fills the timing columns of row.
void run_one(const std::string& spec, const mps::CsrMatrix& a, const std::vector<double>& b, mps::LinearSolver& solver,
             Row& row) {
  std::vector<double> x(b.size(), 0.0);
  try {
    const mps::SolveReport r = solver.solve(a, b, x);
    row.setup_s = r.setup_seconds;
    row.solve_s = r.solve_seconds;
    row.iterations = r.iterations;
    row.residual = r.relative_residual;
    row.reused = r.setup_reused;
  } catch (const mps::SolverError& e) {
    const mps::SolveReport& r = e.report();
    row.setup_s = r.setup_seconds;
    row.solve_s = r.solve_seconds;
    row.iterations = r.iterations;
    row.residual = r.relative_residual;
    row.status = std::string("failed: ") + e.what();
  }
  (void)spec;
}

void export_samples(const fs::path& dir) {
  fs::create_directories(dir);
  struct Sample {
    const char* name;
    TankParams t;
  };
  auto params = [](int nx, int ny, double radius, bool closed, unsigned seed) {
    TankParams t;
    t.nx = nx;
    t.ny = ny;
    t.radius = radius;
    t.closed = closed;
    t.seed = seed;
    return t;
  };
  const TankParams tank41 = params(24, 16, 4.1, false, 3), box41 = params(20, 20, 4.1, true, 4),
                   tank31 = params(40, 24, 3.1, false, 5);
  for (const Sample& s :
       {Sample{"ppe_tank_re4.1", tank41}, Sample{"ppe_closed_box_re4.1", box41}, Sample{"ppe_tank_re3.1", tank31}}) {
    const Tank tank = make_tank(s.t);
    const fs::path m = dir / (std::string(s.name) + ".mtx"), r = dir / (std::string(s.name) + "_rhs.mtx");
    mps::write_matrix_market(m, tank.ppe.matrix);
    mps::write_matrix_market(r, tank.ppe.rhs);
    std::cout << m.string() << ": " << tank.ppe.matrix.rows << " unknowns, " << tank.ppe.matrix.nnz() << " nonzeros, "
              << fs::file_size(m) / 1024 << " kB (+ " << r.filename().string() << ")\n";
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<double> sizes{1e4, 1e5, 1e6};
  std::vector<std::string> specs{"eigen-cg:precond=ic",
                                 "eigen-cg:precond=jacobi",
                                 "eigen-bicgstab:precond=jacobi",
                                 "eigen-bicgstab:precond=ilut",
                                 "cholmod",
                                 "hypre-amg",
                                 "hypre-pcg",
                                 "hypre-pcg:reuse=10",
                                 "petsc"};
  std::vector<std::string> limits;  // "spec-prefix=N": skip that spec above N unknowns
  std::vector<std::string> files;
  std::string tol = "1e-8", out = "bench/results/solvers.csv", export_dir;
  double radius = 4.1, jitter = 0.02, shift = 0.02, mixed = 1.0;
  int repeats = 11;
  CLI::App app{"SparseMPS solver benchmark: every backend on PPEs from a jittered lattice and on Matrix Market files"};
  app.add_option("--sizes", sizes, "approximate unknown counts of the generated tank PPEs")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--solvers", specs, "solver specs (';'-separated); tol is appended to iterative ones")
      ->delimiter(';')
      ->capture_default_str();
  app.add_option("--tol", tol, "relative residual tolerance for the iterative backends")->capture_default_str();
  app.add_option("--limit", limits, "SPEC=N: skip specs starting with SPEC above N unknowns (';'-separated)")
      ->delimiter(';');
  app.add_option("--radius", radius, "Laplacian radius in l0")->capture_default_str();
  app.add_option("--jitter", jitter, "lattice jitter in l0")->capture_default_str();
  app.add_option("--mixed", mixed, "weight of the (noisy) mixed source added to the smooth source")
      ->capture_default_str();
  app.add_option("--shift", shift, "fluid displacement (in l0) between the two systems of a reuse run")
      ->capture_default_str();
  app.add_option("--spmv-repeats", repeats, "SpMV timings whose median is the SpMV-equivalent unit")
      ->capture_default_str();
  app.add_option("--out", out, "CSV output")->capture_default_str();
  app.add_option("--export-samples", export_dir, "write the small sample PPEs (Matrix Market) to DIR and exit");
  bool files_only = false;
  app.add_flag("--files-only", files_only, "time the Matrix Market files alone, no generated tank");
  app.add_option("matrices", files,
                 "Matrix Market matrices (.mtx or .mtx.gz) to time as well (b from NAME_rhs.mtx[.gz] if present, "
                 "else A*1)");
  add_list_solvers_flag(app);
  CLI11_PARSE(app, argc, argv);
  if (!export_dir.empty()) {
    export_samples(export_dir);
    return 0;
  }

  auto with_tol = [&](const std::string& spec) {
    const mps::SolverSpec s = mps::parse_solver_spec(spec);
    if (s.name == "cholmod" || s.options.contains("tol")) return spec;
    return spec + (spec.find(':') == std::string::npos ? ":" : ",") + "tol=" + tol;
  };
  for (auto& s : specs) {
    s = with_tol(s);
    (void)mps::make_solver(s);  // reject a bad spec before hours of work
  }
  auto skipped = [&](const std::string& spec, long long n) {
    for (const auto& l : limits) {
      const auto eq = l.find('=');
      if (eq != std::string::npos && spec.rfind(l.substr(0, eq), 0) == 0 && n > std::stoll(l.substr(eq + 1)))
        return true;
    }
    return false;
  };

  const std::string machine = machine_line();
  const std::string load_at_start = load_average();
  std::cout << "SparseMPS solver benchmark, " << today() << "\n"
            << machine << ", OpenMP threads " << omp_get_max_threads() << ", load average at start " << load_at_start
            << "\n\n";
  std::vector<Row> rows;
  auto csv_header = [&] {
    return "SparseMPS bench_solvers " + today() + "; " + machine + "; " + loaded_blas() + "; load average at start " +
           load_at_start + ", now " + load_average() + "; tol " + tol + ", x0 = 0";
  };
  auto bench_system = [&](const std::string& source, const mps::CsrMatrix& a, const std::vector<double>& b,
                          const mps::CsrMatrix* a2, const std::vector<double>* b2) {
    const double spmv = median_spmv_seconds(a, repeats);
    const int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    const double spmv1 = median_spmv_seconds(a, repeats);
    omp_set_num_threads(threads);
    std::cout << source << ": " << a.rows << " unknowns, " << a.nnz() << " nonzeros (" << std::fixed
              << std::setprecision(1) << static_cast<double>(a.nnz()) / a.rows << "/row); SpMV " << std::setprecision(2)
              << spmv * 1e3 << " ms (" << threads << " threads), " << spmv1 * 1e3 << " ms (1 thread)\n";
    std::cout << "source          n  backend                           phase    setup_s  solve_s  iters resid   "
                 "spmv-eq  mem_MB\n";
    for (const auto& spec : specs) {
      Row row;
      row.source = source;
      row.n = a.rows;
      row.nnz = static_cast<long long>(a.nnz());
      row.spec = spec;
      row.phase = "fresh";
      row.spmv_s = spmv;
      row.spmv1_s = spmv1;
      if (skipped(spec, a.rows)) {
        row.status = "skipped (--limit)";
        rows.push_back(row);
        print_row(row);
        continue;
      }
      settle();
      PeakMemory mem;
      mem.begin();
      auto solver = mps::make_solver(spec);
      run_one(spec, a, b, *solver, row);
      row.mem_mb = mem.end_mb();
      rows.push_back(row);
      print_row(row);
      // Second solve with the setup kept: hypre with reuse=N on the moved system (same unknowns, new values
      // and pattern); CHOLMOD on the same pattern (numeric refactorisation with the symbolic analysis kept).
      const bool is_cholmod = mps::parse_solver_spec(spec).name == "cholmod";
      if (((has_reuse(spec) && a2 != nullptr) || is_cholmod) && row.status == "ok") {
        Row again = row;
        again.phase = "reused";
        again.status = "ok";
        settle();
        mem.begin();
        if (is_cholmod)
          run_one(spec, a, b, *solver, again);
        else
          run_one(spec, *a2, *b2, *solver, again);
        again.mem_mb = mem.end_mb();
        rows.push_back(again);
        print_row(again);
      }
      write_csv(out, rows, csv_header());
    }
    std::cout << std::endl;
  };

  const bool any_reuse = std::any_of(specs.begin(), specs.end(), has_reuse);
  if (files_only) sizes.clear();
  for (double target : sizes) {
    TankParams t;
    t.nx = t.ny = std::max(8, static_cast<int>(std::lround(std::sqrt(target))));
    t.radius = radius;
    t.jitter = jitter;
    t.mixed = mixed;
    const auto t0 = Clock::now();
    Tank tank = make_tank(t);
    std::size_t surface = 0, deep = 0;
    for (std::size_t i = 0; i < tank.surface.size(); ++i) {
      surface += tank.surface[i] != 0;
      deep +=
          tank.surface[i] != 0 && tank.particles.kind[i] == mps::Kind::fluid && tank.particles.y[i] < 0.01 * (t.ny - 4);
    }
    std::cout << "tank " << t.nx << " x " << t.ny << " fluid particles, " << tank.particles.size() << " particles, "
              << surface << " on the free surface (" << deep << " of them deeper than 4 l0), assembled in "
              << std::setprecision(2) << std::fixed << seconds_since(t0) << " s\n";
    Tank next;
    if (any_reuse) next = make_tank(t, shift, &tank.surface, &tank.particles);
    const bool same_size = any_reuse && next.ppe.size() == tank.ppe.size();
    if (any_reuse && !same_size) std::cout << "(the moved system changed its unknown count: no reuse row)\n";
    tank.particles = {};
    next.particles = {};
    bench_system("tank", tank.ppe.matrix, tank.ppe.rhs, same_size ? &next.ppe.matrix : nullptr,
                 same_size ? &next.ppe.rhs : nullptr);
  }
  for (const auto& f : files) {
    if (matrix_name(f).ends_with("_rhs")) continue;  // a right-hand side, read with its matrix
    const System s = from_file(f);
    bench_system(s.source, s.a, s.b, nullptr, nullptr);
  }
  write_csv(out, rows, csv_header());
  std::cout << "BLAS: " << loaded_blas() << "\nload average at the end " << load_average() << "\nwrote " << out << "\n";
  return 0;
}
