#include <gtest/gtest.h>

#include <signal.h>
#include <sys/resource.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <vector>

#include "mps/geometry.hpp"
#include "mps/io.hpp"

namespace {

namespace fs = std::filesystem;

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "sparsemps_test_io";
  fs::create_directories(dir);
  return dir / name;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Minimal XML check: every start tag is closed in order; returns the text inside each <DataArray Name=...>.
bool balanced_xml(const std::string& xml, std::vector<std::pair<std::string, std::string>>& arrays) {
  std::vector<std::string> stack;
  std::size_t pos = 0;
  std::string current_array;
  std::size_t array_body = 0;
  while ((pos = xml.find('<', pos)) != std::string::npos) {
    const std::size_t end = xml.find('>', pos);
    if (end == std::string::npos) return false;
    std::string tag = xml.substr(pos + 1, end - pos - 1);
    if (tag.starts_with("?")) {
      pos = end + 1;
      continue;
    }
    if (tag.starts_with("/")) {
      const std::string name = tag.substr(1);
      if (stack.empty() || stack.back() != name) return false;
      if (name == "DataArray") arrays.emplace_back(current_array, xml.substr(array_body, pos - array_body));
      stack.pop_back();
    } else if (!tag.ends_with("/")) {
      const std::string name = tag.substr(0, tag.find(' '));
      stack.push_back(name);
      if (name == "DataArray") {
        std::smatch m;
        current_array = std::regex_search(tag, m, std::regex("Name=\"([^\"]*)\"")) ? m[1].str() : "Points";
        array_body = end + 1;
      }
    }
    pos = end + 1;
  }
  return stack.empty();
}

std::size_t count_numbers(const std::string& text) {
  std::istringstream in(text);
  std::size_t n = 0;
  for (double v; in >> v;) ++n;
  return n;
}

TEST(Io, VtpIsWellFormedXmlWithOneEntryPerActiveParticle) {
  mps::Particles p;
  mps::fill_rectangle(p, {0, 0, 1, 0.5}, 0.1, mps::Kind::fluid);
  mps::add_rectangle_walls(p, {0, 0, 1, 0.5}, 0.1, mps::left | mps::bottom, 1, 2);
  p.kind[3] = mps::Kind::ghost;  // ghosts are not written
  const std::size_t active = p.size() - 1;
  std::vector<double> extra(p.size(), 2.5);
  const fs::path file = scratch("frame.vtp");
  mps::write_vtp(file, p, {{"number_density", extra}});
  const std::string xml = slurp(file);
  std::vector<std::pair<std::string, std::string>> arrays;
  ASSERT_TRUE(balanced_xml(xml, arrays)) << "unbalanced tags";
  EXPECT_NE(xml.find("NumberOfPoints=\"" + std::to_string(active) + "\""), std::string::npos);
  std::map<std::string, std::size_t> counts;
  for (const auto& [name, body] : arrays) counts[name] = count_numbers(body);
  EXPECT_EQ(counts["Points"], 3 * active);
  EXPECT_EQ(counts["velocity"], 3 * active);
  EXPECT_EQ(counts["pressure"], active);
  EXPECT_EQ(counts["kind"], active);
  EXPECT_EQ(counts["id"], active);
  EXPECT_EQ(counts["number_density"], active);
  EXPECT_EQ(counts["connectivity"], active);
  EXPECT_FALSE(fs::exists(fs::path(file.string() + ".tmp")));  // written atomically
}

TEST(Io, PvdIndexListsEveryFrameRelativeToItself) {
  const fs::path dir = scratch("series");
  fs::remove_all(dir);
  mps::Particles p;
  mps::fill_rectangle(p, {0, 0, 0.2, 0.2}, 0.1, mps::Kind::fluid);
  mps::PvdSeries series(dir / "run.pvd");
  for (int k = 0; k < 3; ++k) {
    const fs::path frame = dir / "frames" / ("f" + std::to_string(k) + ".vtp");
    mps::write_vtp(frame, p);
    series.add(0.1 * k, frame);
  }
  const std::string xml = slurp(dir / "run.pvd");
  std::vector<std::pair<std::string, std::string>> arrays;
  EXPECT_TRUE(balanced_xml(xml, arrays));
  for (int k = 0; k < 3; ++k) EXPECT_NE(xml.find("file=\"frames/f" + std::to_string(k) + ".vtp\""), std::string::npos);
}

TEST(Io, MatrixMarketRoundTripsExactly) {
  mps::CsrMatrix a;
  a.rows = 3;
  a.cols = 4;
  a.row_ptr = {0, 2, 2, 5};
  a.col = {0, 3, 1, 2, 3};
  a.val = {1.0 / 3.0, -2e-17, 6.02214076e23, -1.0, 0.1};
  const fs::path file = scratch("a.mtx");
  mps::write_matrix_market(file, a);
  const mps::CsrMatrix b = mps::read_matrix_market(file);
  EXPECT_EQ(b.rows, a.rows);
  EXPECT_EQ(b.cols, a.cols);
  EXPECT_EQ(b.row_ptr, a.row_ptr);
  EXPECT_EQ(b.col, a.col);
  EXPECT_EQ(b.val, a.val);  // bitwise: 17 significant digits
  const std::vector<double> v{1.0 / 7.0, -0.0, 1e-300};
  mps::write_matrix_market(scratch("v.mtx"), v);
  EXPECT_EQ(mps::read_matrix_market_vector(scratch("v.mtx")), v);
}

TEST(Io, MatrixMarketReaderExpandsSymmetricStorageAndRejectsBrokenFiles) {
  std::ofstream(scratch("sym.mtx")) << "%%MatrixMarket matrix coordinate real symmetric\n% c\n2 2 2\n1 1 4\n2 1 -1\n";
  const mps::CsrMatrix s = mps::read_matrix_market(scratch("sym.mtx"));
  EXPECT_EQ(s.nnz(), 3u);
  EXPECT_EQ(s.at(0, 1), -1.0);
  EXPECT_EQ(s.at(1, 0), -1.0);
  std::ofstream(scratch("bad1.mtx")) << "not a matrix\n";
  std::ofstream(scratch("bad2.mtx")) << "%%MatrixMarket matrix coordinate real general\n2 2 3\n1 1 1\n";
  std::ofstream(scratch("bad3.mtx")) << "%%MatrixMarket matrix coordinate real general\n2 2 1\n3 1 1\n";
  std::ofstream(scratch("bad4.mtx")) << "%%MatrixMarket matrix coordinate real general\n2 2 2\n1 1 1\n1 1 2\n";
  for (const char* name : {"bad1.mtx", "bad2.mtx", "bad3.mtx", "bad4.mtx", "missing.mtx"})
    EXPECT_THROW((void)mps::read_matrix_market(scratch(name)), std::runtime_error) << name;
}

TEST(Io, CsvAndJsonAreWrittenWholeOrNotAtAll) {
  mps::write_csv(scratch("t.csv"), {"a", "b"}, {{1, 2}, {3, 4}});
  EXPECT_EQ(slurp(scratch("t.csv")), "a,b\n1,3\n2,4\n");
  EXPECT_THROW(mps::write_csv(scratch("u.csv"), {"a", "b"}, {{1, 2}, {3}}), std::invalid_argument);
  EXPECT_FALSE(fs::exists(scratch("u.csv")));
  mps::write_json(scratch("s.json"), {{"x", 1.5}});
  EXPECT_EQ(nlohmann::json::parse(slurp(scratch("s.json")))["x"], 1.5);
}

// Each broken file is refused with a message naming the file, the line and the defect.
TEST(Io, MatrixMarketReaderNamesTheLineAndTheDefectOfEveryBrokenFile) {
  const std::string head = "%%MatrixMarket matrix coordinate real general\n";
  const std::vector<std::pair<std::string, std::string>> cases{
      {head + "2 2 1\n1 1 nan\n", "line 3: value 'nan' is not a finite number"},
      {head + "2 2 1\n1 1 inf\n", "value 'inf' is not a finite number"},
      {head + "2 2 1\n1 1 1e999\n", "value '1e999' is not a finite number"},
      {head + "2 2 1000000000000000000\n1 1 1\n", "entry count (bounded by the file size)"},
      {head + "2 2 1\n1 1 1\n2 2 1\n", "more entries than the 1"},
      {head + "2 2 2\n1 1 1\n", "expected 2 entries, found 1"},
      {head + "2 2 1\n3 1 1\n", "row '3' is not a whole number in [1, 2]"},
      {head + "2 2 1\n1 1.5 1\n", "column '1.5'"},
      {head + "2 -2 1\n", "column count '-2'"},
      {head + "3000000000 2 1\n1 1 1\n", "row count '3000000000'"},
      {head + "2 2 1\n1 1 1 7\n", "expected 'row column value'"},
  };
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const fs::path file = scratch("broken" + std::to_string(k) + ".mtx");
    std::ofstream(file) << cases[k].first;
    try {
      (void)mps::read_matrix_market(file);
      ADD_FAILURE() << "accepted: " << cases[k].first;
    } catch (const std::runtime_error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(cases[k].second), std::string::npos) << msg;
      EXPECT_NE(msg.find(file.string()), std::string::npos) << msg;
    }
  }
  std::ofstream(scratch("v_extra.mtx")) << "%%MatrixMarket matrix array real general\n2 1\n1\n2\n3\n";
  std::ofstream(scratch("v_nan.mtx")) << "%%MatrixMarket matrix array real general\n2 1\n1\nnan\n";
  EXPECT_THROW((void)mps::read_matrix_market_vector(scratch("v_extra.mtx")), std::runtime_error);
  EXPECT_THROW((void)mps::read_matrix_market_vector(scratch("v_nan.mtx")), std::runtime_error);
}

// A write that fails (here at a file-size limit, as on a full disk) leaves the previous file as it was and no
// temporary file, and says why; so does a target that is a directory.
TEST(Io, AFailedWriteKeepsThePreviousFileRemovesItsTemporaryAndSaysWhy) {
  mps::Particles p;
  mps::fill_rectangle(p, {0, 0, 1, 1}, 0.01, mps::Kind::fluid);  // 10,000 particles: about 1 MB of VTP
  const fs::path file = scratch("limited.vtp");
  std::ofstream(file) << "previous";
  rlimit old{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
  const auto old_handler = signal(SIGXFSZ, SIG_IGN);  // a write past the limit fails with EFBIG instead
  rlimit small = old;
  small.rlim_cur = 100000;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  std::string message;
  try {
    mps::write_vtp(file, p);
  } catch (const std::runtime_error& e) {
    message = e.what();
  }
  setrlimit(RLIMIT_FSIZE, &old);
  signal(SIGXFSZ, old_handler);
  EXPECT_NE(message.find("File too large"), std::string::npos) << message;
  EXPECT_EQ(slurp(file), "previous");
  EXPECT_FALSE(fs::exists(scratch("limited.vtp.tmp")));

  const fs::path dir = scratch("a_directory");
  fs::create_directories(dir);
  mps::CsrMatrix a;
  EXPECT_THROW(mps::write_matrix_market(dir, a), std::runtime_error);
  EXPECT_FALSE(fs::exists(scratch("a_directory.tmp")));
}

}  // namespace
