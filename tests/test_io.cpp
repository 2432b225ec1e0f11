#include <gtest/gtest.h>
#include <unistd.h>
#include <sys/stat.h>

#include <signal.h>
#include <sys/resource.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <regex>
#include <sstream>
#include <vector>

#include <zlib.h>

#include "mps/boundaries/geometry.hpp"
#include "mps/io/io.hpp"

namespace {

namespace fs = std::filesystem;

// A folder per process: ctest runs these tests side by side, and several use the same file names.
fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("sparsemps_test_io_" + std::to_string(getpid()));
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

// A frame read back as VTK's reader does it: the XML part, then each appended array's zlib blocks after the
// UInt64 header [blocks, block size, last block's size if partial, compressed sizes].
struct Frame {
  std::string xml;                                                // up to <AppendedData>
  std::map<std::string, std::map<std::string, std::string>> tags;  // each DataArray's attributes, by Name
  std::map<std::string, std::vector<unsigned char>> bytes;         // each DataArray's decoded bytes, by Name
  std::map<std::string, std::uint64_t> blocks;                     // each DataArray's number of blocks

  template <class T>
  std::vector<T> values(const std::string& name) const {
    const auto& b = bytes.at(name);
    std::vector<T> out(b.size() / sizeof(T));
    if (!b.empty()) std::memcpy(out.data(), b.data(), b.size());  // an empty vector's data() may be null
    return out;
  }
};

Frame read_frame(const fs::path& path) {
  const std::string file = slurp(path);
  const std::string marker = "<AppendedData encoding=\"raw\">\n_";
  const std::size_t at = file.find(marker);
  if (at == std::string::npos) throw std::runtime_error("no appended data");
  Frame f;
  f.xml = file.substr(0, at);
  const auto* data = reinterpret_cast<const unsigned char*>(file.data() + at + marker.size());
  const std::regex element("<DataArray ([^>]*)/>"), attribute("(\\w+)=\"([^\"]*)\"");
  for (auto it = std::sregex_iterator(f.xml.begin(), f.xml.end(), element); it != std::sregex_iterator(); ++it) {
    std::map<std::string, std::string> a;
    const std::string attrs = (*it)[1];
    for (auto m = std::sregex_iterator(attrs.begin(), attrs.end(), attribute); m != std::sregex_iterator(); ++m)
      a[(*m)[1]] = (*m)[2];
    const std::string name = a.count("Name") ? a["Name"] : "Points";
    const unsigned char* header = data + std::stoul(a.at("offset"));
    std::uint64_t h[3];
    std::memcpy(h, header, sizeof h);
    std::vector<std::uint64_t> sizes(h[0]);
    if (!sizes.empty()) std::memcpy(sizes.data(), header + sizeof h, sizes.size() * sizeof(std::uint64_t));
    const unsigned char* block = header + sizeof h + sizes.size() * sizeof(std::uint64_t);
    std::vector<unsigned char>& out = f.bytes[name];
    for (std::uint64_t b = 0; b < h[0]; ++b) {
      uLongf length = b + 1 == h[0] && h[2] != 0 ? h[2] : h[1];
      const std::size_t start = out.size();
      out.resize(start + length);
      if (uncompress(out.data() + start, &length, block, sizes[b]) != Z_OK) throw std::runtime_error("bad block");
      block += sizes[b];
    }
    f.tags[name] = a;
    f.blocks[name] = h[0];
  }
  return f;
}

std::vector<std::uint64_t> bits(const std::vector<double>& v) {
  std::vector<std::uint64_t> out;
  for (double d : v) out.push_back(std::bit_cast<std::uint64_t>(d));
  return out;
}

// Values that a text format or a careless cast would change: signed zero, subnormals, thirds, huge exponents.
mps::Particles awkward_particles(std::size_t n) {
  mps::Particles p;
  for (std::size_t i = 0; i < n; ++i) {
    const double k = static_cast<double>(i);
    p.add(std::sin(k) * 1e3, 1.0 / (k + 3.0), static_cast<mps::Kind>(i % 3), static_cast<int>(i % 7) - 3,
          i == 0 ? -0.0 : k * 4.9e-324, std::ldexp(1.0 + k / 3.0, static_cast<int>(i % 2000) - 1000));
    p.p.back() = -k / 7.0;
    p.id.back() = static_cast<int>(n - i);  // not the index, so a dropped or shifted entry shows
  }
  return p;
}

TEST(Io, VtpArraysDecodeToTheWrittenValuesBitwiseWithTimeAndVectors) {
  mps::Particles p = awkward_particles(5001);
  p.kind[3] = mps::Kind::ghost;  // ghosts are not written
  std::vector<std::size_t> active;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (i != 3) active.push_back(i);
  const std::size_t n = active.size();  // 5000: the 3-component arrays take 120,000 bytes, 3 full blocks and a part
  std::vector<double> density(p.size()), fx(p.size()), fy(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    density[i] = 1.0 / (static_cast<double>(i) + 0.5);
    fx[i] = -static_cast<double>(i);
    fy[i] = 1e300 * static_cast<double>(i % 5);
  }
  const double time = 0.1 + 0.2;  // not 0.3: TIME must keep every bit
  const fs::path file = scratch("frame.vtp");
  mps::write_vtp(file, p, time, {.scalars = {{"number_density", density}}, .vectors = {{"force", {fx, fy}}}});
  EXPECT_FALSE(fs::exists(fs::path(file.string() + ".tmp")));  // written atomically
  const Frame f = read_frame(file);
  std::vector<std::pair<std::string, std::string>> ignored;
  ASSERT_TRUE(balanced_xml(f.xml + "</VTKFile>", ignored)) << "unbalanced tags";
  EXPECT_NE(f.xml.find("header_type=\"UInt64\" compressor=\"vtkZLibDataCompressor\""), std::string::npos);
  EXPECT_NE(f.xml.find("NumberOfPoints=\"" + std::to_string(n) + "\""), std::string::npos);
  EXPECT_NE(f.xml.find("<FieldData>\n<DataArray type=\"Float64\" Name=\"TIME\" NumberOfTuples=\"1\""), std::string::npos);

  std::vector<double> points, velocity, force, pressure, extra;
  std::vector<std::int32_t> kind, group, id;
  std::vector<std::int64_t> connectivity, offsets;
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = active[k];
    points.insert(points.end(), {p.x[i], p.y[i], 0.0});
    velocity.insert(velocity.end(), {p.u[i], p.v[i], 0.0});
    force.insert(force.end(), {fx[i], fy[i], 0.0});
    pressure.push_back(p.p[i]);
    extra.push_back(density[i]);
    kind.push_back(static_cast<std::int32_t>(p.kind[i]));
    group.push_back(p.group[i]);
    id.push_back(p.id[i]);
    connectivity.push_back(static_cast<std::int64_t>(k));
    offsets.push_back(static_cast<std::int64_t>(k + 1));
  }
  EXPECT_EQ(bits(f.values<double>("TIME")), bits({time}));
  EXPECT_EQ(bits(f.values<double>("Points")), bits(points));
  EXPECT_EQ(bits(f.values<double>("velocity")), bits(velocity));
  EXPECT_EQ(bits(f.values<double>("force")), bits(force));
  EXPECT_EQ(bits(f.values<double>("pressure")), bits(pressure));
  EXPECT_EQ(bits(f.values<double>("number_density")), bits(extra));
  EXPECT_EQ(f.values<std::int32_t>("kind"), kind);
  EXPECT_EQ(f.values<std::int32_t>("group"), group);
  EXPECT_EQ(f.values<std::int32_t>("id"), id);
  EXPECT_EQ(f.values<std::int64_t>("connectivity"), connectivity);
  EXPECT_EQ(f.values<std::int64_t>("offsets"), offsets);
  for (const char* name : {"Points", "velocity", "force"}) {
    EXPECT_EQ(f.tags.at(name).at("NumberOfComponents"), "3") << name;
    EXPECT_EQ(f.blocks.at(name), 4u) << name;  // 120,000 bytes in 32 KiB blocks
  }
  EXPECT_EQ(f.tags.at("pressure").count("NumberOfComponents"), 0u);
}

// A frame whose arrays fill their last block exactly, and a frame with no particles, read back whole.
TEST(Io, VtpBlocksEndingExactlyAndEmptyFramesDecode) {
  const mps::Particles p = awkward_particles(4096);  // 8 x 4096 bytes: exactly one 32 KiB block
  mps::write_vtp(scratch("exact.vtp"), p, 1.0);
  const Frame f = read_frame(scratch("exact.vtp"));
  EXPECT_EQ(f.blocks.at("pressure"), 1u);
  EXPECT_EQ(bits(f.values<double>("pressure")), bits(p.p));
  EXPECT_EQ(f.blocks.at("velocity"), 3u);
  EXPECT_EQ(f.values<std::int32_t>("id"), std::vector<std::int32_t>(p.id.begin(), p.id.end()));

  mps::Particles ghosts = awkward_particles(3);
  ghosts.kind.assign(3, mps::Kind::ghost);
  mps::write_vtp(scratch("empty.vtp"), ghosts, 2.0);
  const Frame e = read_frame(scratch("empty.vtp"));
  EXPECT_NE(e.xml.find("NumberOfPoints=\"0\""), std::string::npos);
  EXPECT_TRUE(e.bytes.at("Points").empty());
  EXPECT_EQ(e.blocks.at("velocity"), 0u);
  EXPECT_EQ(bits(e.values<double>("TIME")), bits({2.0}));
}

TEST(Io, VtpRefusesFieldsOfTheWrongLengthOrNameAndATimeThatIsNotFinite) {
  const mps::Particles p = awkward_particles(4);
  const std::vector<double> short_field(3), ok(4);
  EXPECT_THROW(mps::write_vtp(scratch("bad.vtp"), p, 0.0, {.scalars = {{"s", short_field}}}), std::invalid_argument);
  EXPECT_THROW(mps::write_vtp(scratch("bad.vtp"), p, 0.0, {.vectors = {{"v", {ok, short_field}}}}), std::invalid_argument);
  EXPECT_THROW(mps::write_vtp(scratch("bad.vtp"), p, 0.0, {.scalars = {{"a\"b", ok}}}), std::invalid_argument);
  EXPECT_THROW(mps::write_vtp(scratch("bad.vtp"), p, 0.0, {.scalars = {{"pressure", ok}}}), std::invalid_argument);
  EXPECT_THROW(mps::write_vtp(scratch("bad.vtp"), p, 0.0, {.scalars = {{"f", ok}}, .vectors = {{"f", {ok, ok}}}}),
               std::invalid_argument);
  EXPECT_THROW(mps::write_vtp(scratch("bad.vtp"), p, std::nan("")), std::invalid_argument);
  EXPECT_FALSE(fs::exists(scratch("bad.vtp")));
}

TEST(Io, PvdIndexListsEveryFrameRelativeToItself) {
  const fs::path dir = scratch("series");
  fs::remove_all(dir);
  mps::Particles p;
  mps::fill_rectangle(p, {0, 0, 0.2, 0.2}, 0.1, mps::Kind::fluid);
  mps::PvdSeries series(dir / "run.pvd");
  for (int k = 0; k < 3; ++k) {
    const fs::path frame = dir / "frames" / ("f" + std::to_string(k) + ".vtp");
    mps::write_vtp(frame, p, 0.1 * k);
    series.add(0.1 * k, frame);
  }
  const std::string xml = slurp(dir / "run.pvd");
  std::vector<std::pair<std::string, std::string>> arrays;
  EXPECT_TRUE(balanced_xml(xml, arrays));
  for (int k = 0; k < 3; ++k) EXPECT_NE(xml.find("file=\"frames/f" + std::to_string(k) + ".vtp\""), std::string::npos);
  EXPECT_NE(xml.find("timestep=\"0.20000000000000001\""), std::string::npos);  // 17 digits: the double itself
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
  mps::fill_rectangle(p, {0, 0, 1, 1}, 0.01, mps::Kind::fluid);  // 10,000 particles: about 79 kB of VTP
  const fs::path file = scratch("limited.vtp");
  std::ofstream(file) << "previous";
  rlimit old{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
  const auto old_handler = signal(SIGXFSZ, SIG_IGN);  // a write past the limit fails with EFBIG instead
  rlimit small = old;
  small.rlim_cur = 10000;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  std::string message;
  try {
    mps::write_vtp(file, p, 0.0);
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
  EXPECT_THROW(mps::write_matrix_market(dir, a), std::invalid_argument);
  EXPECT_FALSE(fs::exists(scratch("a_directory.tmp")));
}

// A path that exists and is not a regular file is refused before anything is written, and stays what it was: a
// write-then-rename once replaced /dev/full with a CSV file.
TEST(Io, WritersRefuseAPathThatIsNotARegularFileAndLeaveItAlone) {
  const fs::path fifo = scratch("a_fifo");
  fs::remove(fifo);
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const fs::path dir = scratch("a_folder");
  fs::create_directories(dir);
  for (const fs::path& path : {fifo, dir}) {
    try {
      mps::write_text(path, "text");
      ADD_FAILURE() << "wrote over " << path;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("not a regular file"), std::string::npos) << e.what();
    }
  }
  EXPECT_TRUE(fs::is_fifo(fifo));
  EXPECT_TRUE(fs::is_directory(dir));
  EXPECT_THROW(mps::write_text("", "text"), std::invalid_argument);
  EXPECT_THROW(mps::require_directory_path(fifo), std::invalid_argument);
  fs::remove(fifo);
}

// The temporary file is made afresh: a killed run's leftover is replaced, a FIFO in its place refused (opening it
// for writing would wait for a reader forever), and a link to a file is written through, the link kept.
TEST(Io, TheTemporaryFileIsNewAndALinkIsWrittenThrough) {
  const fs::path file = scratch("leftover.csv"), tmp = scratch("leftover.csv.tmp");
  fs::remove(file);
  std::ofstream(tmp) << "a killed run's half";
  mps::write_text(file, "whole\n");
  EXPECT_EQ(slurp(file), "whole\n");
  EXPECT_FALSE(fs::exists(tmp));

  ASSERT_EQ(mkfifo(tmp.c_str(), 0600), 0);
  EXPECT_THROW(mps::write_text(file, "again\n"), std::runtime_error);
  EXPECT_EQ(slurp(file), "whole\n");
  EXPECT_TRUE(fs::is_fifo(tmp));
  fs::remove(tmp);

  const fs::path link = scratch("link.csv");
  fs::remove(link);
  fs::create_symlink(file, link);
  mps::write_text(link, "through\n");
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_EQ(slurp(file), "through\n");
}

// A .mtx.gz (as data/ppe/ keeps the sample PPEs) reads as the same matrix and vector as the plain file; a damaged
// stream is refused.
TEST(Io, MatrixMarketReadsGzipCompressedFiles) {
  mps::CsrMatrix a;
  a.rows = a.cols = 3;
  a.row_ptr = {0, 2, 3, 5};
  a.col = {0, 2, 1, 0, 2};
  a.val = {4.0, -1.0 / 3.0, 5.0, -1.0 / 3.0, 6.0};
  mps::write_matrix_market(scratch("g.mtx"), a, {"a comment"}, true);
  const std::vector<double> b{0.1, -2.5e-300, 7.0};
  mps::write_matrix_market(scratch("g_rhs.mtx"), b);
  auto gzip = [](const fs::path& from, const fs::path& to) {
    const std::string text = slurp(from);
    gzFile out = gzopen(to.c_str(), "wb9");
    ASSERT_NE(out, nullptr);
    ASSERT_EQ(gzwrite(out, text.data(), static_cast<unsigned>(text.size())), static_cast<int>(text.size()));
    gzclose(out);
  };
  gzip(scratch("g.mtx"), scratch("g.mtx.gz"));
  gzip(scratch("g_rhs.mtx"), scratch("g_rhs.mtx.gz"));
  const mps::CsrMatrix plain = mps::read_matrix_market(scratch("g.mtx")), packed = mps::read_matrix_market(scratch("g.mtx.gz"));
  EXPECT_EQ(packed.row_ptr, a.row_ptr);
  EXPECT_EQ(packed.col, a.col);
  EXPECT_EQ(packed.val, a.val);
  EXPECT_EQ(plain.val, packed.val);
  EXPECT_EQ(mps::read_matrix_market_vector(scratch("g_rhs.mtx.gz")), b);
  std::string bytes = slurp(scratch("g.mtx.gz"));
  std::ofstream(scratch("cut.mtx.gz"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  EXPECT_THROW((void)mps::read_matrix_market(scratch("cut.mtx.gz")), std::runtime_error);
}

// Every value of every particle survives a write and a read, bit for bit; the ids are the rows' order.
TEST(Io, ParticleCsvRoundTripsEveryBit) {
  mps::Particles p;
  mps::fill_rectangle(p, {0, 0, 0.146, 0.292}, 0.146 / 20, mps::Kind::fluid);
  mps::add_rectangle_walls(p, {0, 0, 0.584, 0.438}, 0.146 / 20, mps::left | mps::right | mps::bottom, 1, 4, 3);
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.u[i] = std::sin(static_cast<double>(i)) / 3.0;
    p.v[i] = -1e-300 * static_cast<double>(i);
    p.p[i] = std::exp(static_cast<double>(i % 50)) / 7.0;
    p.group[i] = static_cast<int>(i % 5) - 2;
  }
  mps::write_particles_csv(scratch("p.csv"), p, {"a comment", "another"});
  EXPECT_EQ(slurp(scratch("p.csv")).rfind("# a comment\n# another\nx,y,kind,u,v,p,group\n", 0), 0u);
  const mps::Particles q = mps::read_particles_csv(scratch("p.csv"));
  ASSERT_EQ(q.size(), p.size());
  EXPECT_EQ(q.x, p.x);
  EXPECT_EQ(q.y, p.y);
  EXPECT_EQ(q.u, p.u);
  EXPECT_EQ(q.v, p.v);
  EXPECT_EQ(q.p, p.p);
  EXPECT_EQ(q.kind, p.kind);
  EXPECT_EQ(q.group, p.group);
  EXPECT_EQ(q.id, p.id);
}

// Columns in any order and case, kinds by name or number, comments, blank lines and CRLF line ends; what is not given
// is 0.
TEST(Io, ParticleCsvTakesColumnsInAnyOrderAndDefaultsTheRest) {
  std::ofstream(scratch("any.csv")) << "# made by hand\r\n\r\n Kind , Y,x\r\n0, 0.5, 1.5\r\n# a wall\r\nwall,0.5,0.5\r\n"
                                       "2 ,-0.5,0.5\r\nDUMMY,-0.5,1.5\r\n";
  const mps::Particles p = mps::read_particles_csv(scratch("any.csv"));
  ASSERT_EQ(p.size(), 4u);
  EXPECT_EQ(p.x, (std::vector<double>{1.5, 0.5, 0.5, 1.5}));
  EXPECT_EQ(p.y, (std::vector<double>{0.5, 0.5, -0.5, -0.5}));
  EXPECT_EQ(p.kind, (std::vector<mps::Kind>{mps::Kind::fluid, mps::Kind::wall, mps::Kind::dummy, mps::Kind::dummy}));
  EXPECT_EQ(p.u, std::vector<double>(4, 0.0));
  EXPECT_EQ(p.p, std::vector<double>(4, 0.0));
  EXPECT_EQ(p.group, std::vector<int>(4, 0));
}

// Each broken file is refused with a message naming the file, the line and what to change.
TEST(Io, ParticleCsvNamesTheLineAndTheDefectOfEveryBrokenFile) {
  const std::string head = "# a tank\nx,y,kind\n";
  const std::vector<std::pair<std::string, std::string>> cases{
      {"x,y\n0,0\n", ":1: the header has no column 'kind'"},
      {"x,y,kind,presure\n", ":1: unknown column 'presure' in the header"},
      {"0.5,0.5,fluid\n", ":1: unknown column '0.5'"},
      {"x,y,kind,x\n", "column 'x' named twice"},
      {head + "0,0,fluid\n1,0\n", ":4: expected 3 comma-separated fields, as the header names, found 2"},
      {head + "0,0,fluid\n1,nan,fluid\n", ":4: column 'y': 'nan' is not a finite number"},
      {head + "1e999,0,fluid\n", ":3: column 'x': '1e999' is not a finite number"},
      {head + "0,0,fluid\n1,,fluid\n", ":4: column 'y': '' is not a finite number"},
      {head + "0,0,solid\n", ":3: kind 'solid' is not fluid, wall or dummy (or 0, 1, 2)"},
      {head + "0,0,3\n", ":3: kind '3': ghosts"},
      {"x,y,kind,group\n0,0,fluid,1.5\n", ":2: group '1.5' is not a whole number"},
      {head, "no particles after the header"},
      {"# nothing\n\n", "no header line"},
      {head + "0,0,fluid\n1,0,fluid\n2,0,fluid\n1,0,wall\n", "lines 4 and 6: two particles at the same position (1, 0)"},
      {head + "0,0,fluid\n1,0,fluid\n2,0,fluid\n3,0,fluid\n3.2,0,fluid\n",
       "lines 6 and 7: two particles 0.2 m apart, less than half the file's spacing (1 m"},
  };
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const fs::path file = scratch("broken" + std::to_string(k) + ".csv");
    std::ofstream(file) << cases[k].first;
    try {
      (void)mps::read_particles_csv(file);
      ADD_FAILURE() << "accepted: " << cases[k].first;
    } catch (const std::runtime_error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(cases[k].second), std::string::npos) << msg;
      EXPECT_NE(msg.find(file.string()), std::string::npos) << msg;
    }
  }
  try {
    (void)mps::read_particles_csv(scratch("no_such_file.csv"));
    ADD_FAILURE() << "a missing file was read";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot read the particle file"), std::string::npos) << e.what();
  }
}

// The grid search finds each particle's nearest neighbour: its median agrees bitwise with the brute-force one on a
// tank and on a cloud with clusters, a row of particles and an isolated one.
TEST(Io, MedianSpacingIsTheLatticeSpacingAndMatchesBruteForce) {
  auto brute = [](const mps::Particles& p) {
    std::vector<double> d;
    for (std::size_t i = 0; i < p.size(); ++i) {
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t j = 0; j < p.size(); ++j)
        if (j != i) best = std::min(best, std::hypot(p.x[j] - p.x[i], p.y[j] - p.y[i]));
      d.push_back(best);
    }
    std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
    return d[d.size() / 2];
  };
  mps::Particles tank;
  mps::fill_rectangle(tank, {0, 0, 0.3, 0.2}, 0.01, mps::Kind::fluid);
  mps::add_rectangle_walls(tank, {0, 0, 0.6, 0.4}, 0.01, mps::left | mps::right | mps::bottom, 1, 4);
  EXPECT_NEAR(mps::median_spacing(tank), 0.01, 1e-15);
  EXPECT_EQ(mps::median_spacing(tank), brute(tank));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    mps::Particles cloud;
    const int n = 50 + 40 * trial;
    for (int k = 0; k < n; ++k) {
      const double cluster = (k % 3 == 0) ? 0.01 : 1.0;  // a third packed near the origin
      cloud.add(cluster * unit(rng), cluster * unit(rng) * (trial % 4 == 0 ? 1e-9 : 1.0), mps::Kind::fluid);
    }
    cloud.add(1e3, -1e3, mps::Kind::wall);  // far from everything
    EXPECT_EQ(mps::median_spacing(cloud), brute(cloud)) << "trial " << trial;
  }
  mps::Particles one;
  one.add(0, 0, mps::Kind::fluid);
  EXPECT_TRUE(std::isinf(mps::median_spacing(one)));
}

// read_vtp gives back every bit write_vtp wrote (arrays over several zlib blocks, ghosts left out) and the frame's
// time; an empty frame reads as no particles.
TEST(Io, VtpReadsBackWhatWriteVtpWrote) {
  mps::Particles p;
  std::mt19937 rng(9);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int i = 0; i < 5000; ++i) {  // 120 kB of points: four 32 KiB blocks
    p.add(normal(rng), normal(rng), static_cast<mps::Kind>(i % 4), i % 7 - 3, normal(rng), -0.0);
    p.p.back() = i == 5 ? 4.9e-324 : normal(rng) * 1e5;
  }
  mps::write_vtp(scratch("r.vtp"), p, 0.125);
  double time = 0;
  const mps::Particles q = mps::read_vtp(scratch("r.vtp"), &time);
  EXPECT_EQ(time, 0.125);
  std::vector<double> x, y, u, v, pressure;
  std::vector<mps::Kind> kind;
  std::vector<int> group;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.kind[i] == mps::Kind::ghost) continue;
    x.push_back(p.x[i]), y.push_back(p.y[i]), u.push_back(p.u[i]), v.push_back(p.v[i]), pressure.push_back(p.p[i]);
    kind.push_back(p.kind[i]), group.push_back(p.group[i]);
  }
  EXPECT_EQ(q.x, x);
  EXPECT_EQ(q.y, y);
  EXPECT_EQ(q.u, u);
  EXPECT_EQ(q.v, v);
  EXPECT_EQ(q.p, pressure);
  EXPECT_EQ(q.kind, kind);
  EXPECT_EQ(q.group, group);
  EXPECT_TRUE(std::signbit(q.v[0]));  // -0.0 kept
  mps::write_vtp(scratch("empty.vtp"), mps::Particles{}, 0.0);
  EXPECT_EQ(mps::read_vtp(scratch("empty.vtp")).size(), 0u);
}

// A file that is not such a frame is refused naming the file and the reason.
TEST(Io, VtpReaderNamesWhatAFrameLacks) {
  mps::Particles p;
  mps::fill_rectangle(p, {0, 0, 0.2, 0.2}, 0.01, mps::Kind::fluid);
  mps::write_vtp(scratch("good.vtp"), p, 1.0);
  const std::string good = slurp(scratch("good.vtp"));
  auto edited = [&](const std::string& from, const std::string& to) {
    std::string text = good;
    text.replace(text.find(from), from.size(), to);
    return text;
  };
  const std::vector<std::pair<std::string, std::string>> cases{
      {"x,y,kind\n", "not a VTK XML PolyData file"},
      {edited("Name=\"pressure\"", "Name=\"pressura\""), "no point array 'pressure'"},
      {edited("compressor=\"vtkZLibDataCompressor\"", "compressor=\"vtkLZ4DataCompressor\""), "only zlib"},
      {edited("encoding=\"raw\"", "encoding=\"base64\""), "only raw is read"},
      {edited("Name=\"kind\" format=\"appended\"", "Name=\"kind\" format=\"ascii\""), "is not appended raw data"},
      {good.substr(0, good.size() / 2) + "\n</AppendedData>\n</VTKFile>\n", "runs past the end of the file"},
      {good.substr(0, good.size() / 2), "the file was cut short"},
      {good.substr(0, good.size() - 28), "the file was cut short"},  // every array whole, the closing tags gone
      {good.substr(0, good.size() - 30), "the file was cut short"},
      {edited("NumberOfPoints=\"400\"", "NumberOfPoints=\"401\""), "array 'points' holds 9600 bytes, not the 9624 its 1203 values need"},
  };
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const fs::path file = scratch("broken" + std::to_string(k) + ".vtp");
    std::ofstream(file, std::ios::binary) << cases[k].first;
    try {
      (void)mps::read_vtp(file);
      ADD_FAILURE() << "accepted case " << k;
    } catch (const std::runtime_error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(cases[k].second), std::string::npos) << msg;
      EXPECT_NE(msg.find(file.string()), std::string::npos) << msg;
    }
  }
}

}  // namespace
