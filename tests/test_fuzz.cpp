// Seeded random sweeps over the inputs a user hands the library (a bounded number of cases in every test run, the
// same cases each time): each input must give a valid result or the library's own exception, never a crash, a
// hang or a silent garbage result. Run under the sanitizer build they also catch memory errors.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "mps/io/io.hpp"
#include "mps/solvers/solver.hpp"

namespace {

namespace fs = std::filesystem;

std::string pick(std::mt19937& rng, const std::vector<std::string>& pool) {
  return pool[std::uniform_int_distribution<std::size_t>(0, pool.size() - 1)(rng)];
}

const std::vector<std::string>& odd_tokens() {
  static const std::vector<std::string> t{"0", "1", "2", "3", "-1", "4", "1e999", "nan", "inf", "-inf", "1.5", "abc",
                                          "", "2147483648", "1e18", "%", "%%MatrixMarket", "0x10", "1e-320", "7 7"};
  return t;
}

// Reads back what it parsed: a valid CSR with finite values, or a std::runtime_error.
TEST(Fuzz, MatrixMarketReaderParsesOrRefusesEveryMutatedFile) {
  const std::vector<std::string> lines{"%%MatrixMarket matrix coordinate real general", "% comment", "3 3 5",
                                       "1 1 4", "2 2 4", "3 3 4", "1 2 -1", "2 1 -1"};
  std::mt19937 rng(2026);
  const fs::path file = fs::temp_directory_path() / "sparsemps_fuzz.mtx";
  int parsed = 0, refused = 0;
  for (int c = 0; c < 2000; ++c) {
    std::vector<std::string> mutated = lines;
    const int edits = std::uniform_int_distribution<int>(1, 3)(rng);
    for (int e = 0; e < edits; ++e) {
      auto& line = mutated[std::uniform_int_distribution<std::size_t>(0, mutated.size() - 1)(rng)];
      switch (std::uniform_int_distribution<int>(0, 4)(rng)) {
        case 0:
          line = pick(rng, odd_tokens());
          for (int w = 0; w < 2; ++w) line.append(" ").append(pick(rng, odd_tokens()));
          break;
        case 1: line.append(" ").append(pick(rng, odd_tokens())); break;
        case 2: line = line.substr(0, line.size() / 2); break;
        case 3: mutated.push_back(line); break;
        default: line.clear();
      }
    }
    if (rng() % 4 == 0) mutated[0] = "%%MatrixMarket matrix coordinate real symmetric";
    {
      std::ofstream out(file);
      for (const auto& l : mutated) out << l << '\n';
    }
    try {
      const mps::CsrMatrix a = mps::read_matrix_market(file);
      EXPECT_NO_THROW(a.validate());
      for (double v : a.val) ASSERT_TRUE(std::isfinite(v));
      ++parsed;
    } catch (const std::runtime_error&) {
      ++refused;
    }
  }
  EXPECT_GT(parsed, 0);
  EXPECT_GT(refused, 0);
}

// A mutated particle file reads as particles with every value finite and every array of one length, or is refused
// with std::runtime_error.
TEST(Fuzz, ParticleFileReaderParsesOrRefusesEveryMutatedFile) {
  const std::vector<std::string> lines{"# a tank", "x,y,kind,u,v,p,group", "0.5,0.5,fluid,0,0,0,0",
                                       "1.5,0.5,fluid,1,0,0,0",   "0.5,-0.5,wall,0,0,0,1", "1.5,-0.5,dummy,0,0,0,1",
                                       "2.5,0.5,2,0,0,0,0"};
  const std::vector<std::string> tokens{"0",  "1",    "2", "3",   "-1", "nan", "inf", "1e999", "1e-320", "fluid", "wall",
                                        "", ",",  "x",   "kind", "#", "1.5", "0x10", "2147483648", " ", "y,x"};
  std::mt19937 rng(26);
  const fs::path file = fs::temp_directory_path() / "sparsemps_fuzz_particles.csv";
  int parsed = 0, refused = 0;
  for (int c = 0; c < 2000; ++c) {
    std::vector<std::string> mutated = lines;
    const int edits = std::uniform_int_distribution<int>(1, 3)(rng);
    for (int e = 0; e < edits; ++e) {
      auto& line = mutated[std::uniform_int_distribution<std::size_t>(0, mutated.size() - 1)(rng)];
      switch (std::uniform_int_distribution<int>(0, 4)(rng)) {
        case 0: {  // one field replaced
          std::size_t at = line.find(',');
          line = pick(rng, tokens) + (at == std::string::npos ? "" : line.substr(at));
          break;
        }
        case 1: line.append(",").append(pick(rng, tokens)); break;
        case 2: line = line.substr(0, line.size() / 2); break;
        case 3: mutated.push_back(line); break;
        default: line.clear();
      }
    }
    {
      std::ofstream out(file);
      for (const auto& l : mutated) out << l << '\n';
    }
    try {
      const mps::Particles p = mps::read_particles_csv(file);
      ASSERT_FALSE(p.empty());
      for (const auto* values : {&p.x, &p.y, &p.u, &p.v, &p.p}) {
        ASSERT_EQ(values->size(), p.size());
        for (double v : *values) ASSERT_TRUE(std::isfinite(v));
      }
      ASSERT_EQ(p.kind.size(), p.size());
      for (mps::Kind k : p.kind) ASSERT_NE(k, mps::Kind::ghost);
      ++parsed;
    } catch (const std::runtime_error&) {
      ++refused;
    }
  }
  EXPECT_GT(parsed, 0);
  EXPECT_GT(refused, 0);
}

// A frame with bytes changed, cut short or with a header number rewritten reads as particles with finite values, or
// is refused with std::runtime_error: never a read past the file's end (the sanitizer build checks that).
TEST(Fuzz, FrameReaderReadsOrRefusesEveryDamagedFrame) {
  mps::Particles p;
  for (int i = 0; i < 300; ++i) p.add(0.01 * (i % 20), 0.01 * (i / 20), static_cast<mps::Kind>(i % 3), i % 2, 0.5, -0.5);
  const fs::path good = fs::temp_directory_path() / "sparsemps_fuzz_good.vtp";
  mps::write_vtp(good, p, 0.25);
  std::string bytes;
  {
    std::ifstream in(good, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  std::mt19937 rng(31);
  const fs::path file = fs::temp_directory_path() / "sparsemps_fuzz_frame.vtp";
  int parsed = 0, refused = 0;
  for (int c = 0; c < 1500; ++c) {
    std::string damaged = bytes;
    const std::size_t data = damaged.find("<AppendedData");
    switch (c % 4) {
      case 0:  // bytes of the appended data changed
        for (int k = 0; k < 4; ++k)
          damaged[std::uniform_int_distribution<std::size_t>(data, damaged.size() - 1)(rng)] =
              static_cast<char>(rng() & 0xff);
        break;
      case 1:  // cut short
        damaged.resize(std::uniform_int_distribution<std::size_t>(0, damaged.size() - 1)(rng));
        break;
      case 2: {  // a number in the XML rewritten
        const std::size_t quote = damaged.find("=\"", std::uniform_int_distribution<std::size_t>(0, data)(rng));
        if (quote < data) damaged.insert(quote + 2, pick(rng, odd_tokens()));
        break;
      }
      default:  // an array's header word (block counts, sizes) set to a random value
        for (int k = 0; k < 8; ++k)
          damaged[data + 40 + std::uniform_int_distribution<std::size_t>(0, 200)(rng)] = static_cast<char>(rng() & 0xff);
    }
    std::ofstream(file, std::ios::binary) << damaged;
    try {
      const mps::Particles q = mps::read_vtp(file);
      for (std::size_t i = 0; i < q.size(); ++i) ASSERT_TRUE(std::isfinite(q.x[i]) && std::isfinite(q.p[i]));
      ++parsed;
    } catch (const std::runtime_error&) {
      ++refused;
    }
  }
  EXPECT_GT(parsed, 0);
  EXPECT_GT(refused, 0);
}

// A spec is either a solver whose spec() rebuilds an equal solver, or std::invalid_argument.
TEST(Fuzz, SolverSpecsBuildOrAreRefused) {
  const std::vector<std::string> names{"eigen-cg", "eigen-bicgstab", "cholmod", "hypre-amg", "hypre-pcg", "petsc",
                                       "cg", ""};
  const std::vector<std::string> keys{"tol", "max_iter", "precond", "reuse", "ordering", "droptol", "fill", "sweeps",
                                      "p_max", "strong_threshold", "coarsen_type", "bogus", "", "ksp_type", "pc_type",
                                      "pc_gamg_threshold", "-ksp_type"};
  const std::vector<std::string> values{"1e-8", "0", "-1", "ic", "jacobi", "ilut", "amd", "nan", "inf", "10", "1e6",
                                        "0.5", "", "3", "99999999999", "cg", "gamg", "icc", "gmres"};
  std::mt19937 rng(7);
  int built = 0, refused = 0;
  for (int c = 0; c < 2000; ++c) {
    std::string spec = pick(rng, names);
    const int items = std::uniform_int_distribution<int>(0, 3)(rng);
    if (items > 0 || rng() % 5 == 0) spec += ":";
    for (int k = 0; k < items; ++k) {
      if (k > 0 || rng() % 10 == 0) spec.append(",");
      spec.append(pick(rng, keys));
      if (rng() % 8 != 0) spec.append("=").append(pick(rng, values));
    }
    try {
      const auto solver = mps::make_solver(spec);
      EXPECT_EQ(mps::make_solver(solver->spec())->spec(), solver->spec()) << spec;
      ++built;
    } catch (const std::invalid_argument&) {
      ++refused;
    }
  }
  EXPECT_GT(built, 0);
  EXPECT_GT(refused, 0);
}

// Random small CSR arrays, valid or not: every backend solves (and the residual says so) or throws SolverError.
TEST(Fuzz, EveryBackendSolvesOrRefusesRandomSmallMatrices) {
  std::mt19937 rng(11);
  int solved = 0, refused = 0;
  for (const std::string spec : {"eigen-cg", "eigen-cg:precond=jacobi", "eigen-bicgstab", "cholmod", "hypre-pcg",
                                 "petsc", "petsc:pc_type=jacobi"}) {
    for (int c = 0; c < 300; ++c) {
      mps::CsrMatrix a;
      const int n = std::uniform_int_distribution<int>(0, 5)(rng);
      a.rows = a.cols = n;
      a.row_ptr.assign(1, 0);
      const bool broken = rng() % 3 == 0;
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j)
          if (i == j ? rng() % 8 != 0 : std::abs(i - j) == 1 && rng() % 2 == 0) {
            a.col.push_back(j);
            a.val.push_back(i == j ? 4.0 : -1.0);
          }
        a.row_ptr.push_back(static_cast<int>(a.col.size()));
      }
      if (broken && !a.col.empty()) {
        const auto k = std::uniform_int_distribution<std::size_t>(0, a.col.size() - 1)(rng);
        switch (rng() % 4) {
          case 0: a.col[k] = std::uniform_int_distribution<int>(-3, n + 3)(rng); break;
          case 1: a.row_ptr.pop_back(); break;
          case 2: a.val[k] = std::nan(""); break;
          default: a.val[k] = -a.val[k]; break;
        }
      }
      const std::vector<double> b(static_cast<std::size_t>(n), 1.0);
      std::vector<double> x(b.size(), 0.0);
      try {
        const mps::SolveReport r = mps::make_solver(spec)->solve(a, b, x);
        EXPECT_LT(r.relative_residual, 1e-6) << spec;
        ++solved;
      } catch (const mps::SolverError&) {
        ++refused;
      }
    }
  }
  EXPECT_GT(solved, 0);
  EXPECT_GT(refused, 0);
}

}  // namespace
