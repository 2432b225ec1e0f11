#include "mps/io.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <numeric>
#include <set>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include <zlib.h>

namespace mps {
namespace {

namespace fs = std::filesystem;

// What the system said about the last failed call (errno), for messages: "No space left on device".
std::string system_reason() { return errno != 0 ? std::string(": ") + std::strerror(errno) : std::string(); }

// Writes through a temporary file in the same directory, then renames it over the target; on any failure the
// temporary file is removed, the target left as it was, and the message says why (errno).
template <class Body>
void write_atomically(const fs::path& path, Body&& body) {
  if (fs::is_directory(path)) throw std::runtime_error("cannot write " + path.string() + ": it is a directory");
  if (path.has_parent_path()) fs::create_directories(path.parent_path());
  fs::path tmp = path;
  tmp += ".tmp";
  auto fail = [&](const std::string& what) {
    const std::string reason = system_reason();
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw std::runtime_error(what + reason);
  };
  errno = 0;
  {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) fail("cannot open " + tmp.string() + " for writing");
    out.precision(17);
    try {
      body(out);
    } catch (...) {
      std::error_code ignored;
      fs::remove(tmp, ignored);
      throw;
    }
    out.close();
    if (!out) fail("failed while writing " + tmp.string());
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    errno = ec.value();
    fail("cannot rename " + tmp.string() + " to " + path.string());
  }
}

[[noreturn]] void read_error(const fs::path& path, const std::string& what) {
  throw std::runtime_error("Matrix Market file " + path.string() + ": " + what);
}

void check_field_name(const std::string& name, std::set<std::string>& taken) {
  for (char ch : name)
    if (ch == '"' || ch == '<' || ch == '>' || ch == '&') throw std::invalid_argument("write_vtp: bad field name " + name);
  if (name.empty() || !taken.insert(name).second)
    throw std::invalid_argument("write_vtp: field name '" + name + "' is empty or used twice");
}

// The binary section of a frame: each array compressed the way vtkZLibDataCompressor does it, so VTK's own reader
// reads it. Per array, with header_type UInt64: [number of blocks, block size, size of the last block if it is
// partial (else 0), compressed size of each block], then the compressed blocks one after another.
class AppendedData {
 public:
  explicit AppendedData(const fs::path& path) : path_(path) {}

  // Compresses one array's values; returns its offset in the section, which the array's XML element names.
  template <class T>
  std::size_t add(const std::string& name, std::span<const T> values) {
    const auto* raw = reinterpret_cast<const unsigned char*>(values.data());
    const std::size_t bytes = values.size_bytes();
    const std::size_t blocks = (bytes + kBlockBytes - 1) / kBlockBytes;
    std::vector<std::uint64_t> header{blocks, kBlockBytes, bytes % kBlockBytes};
    const std::size_t offset = data_.size();
    data_.resize(offset + (3 + blocks) * sizeof(std::uint64_t));  // filled in once the sizes are known
    for (std::size_t b = 0; b < blocks; ++b) {
      const std::size_t begin = b * kBlockBytes, length = std::min(kBlockBytes, bytes - begin);
      uLongf compressed = compressBound(static_cast<uLong>(length));
      const std::size_t at = data_.size();
      data_.resize(at + compressed);
      const int rc = compress2(data_.data() + at, &compressed, raw + begin, static_cast<uLong>(length), kLevel);
      if (rc != Z_OK)
        throw std::runtime_error("write_vtp: zlib could not compress array '" + (name.empty() ? "points" : name) +
                                 "' of " + path_.string() +
                                 ": " + zError(rc));
      data_.resize(at + compressed);
      header.push_back(compressed);
    }
    std::memcpy(data_.data() + offset, header.data(), header.size() * sizeof(std::uint64_t));
    return offset;
  }
  [[nodiscard]] const std::vector<unsigned char>& bytes() const { return data_; }

 private:
  static constexpr std::size_t kBlockBytes = std::size_t{1} << 15;  // VTK's default: any reader's buffers suit it
  // Fastest: level 6 wrote frames under 1 % smaller in three times the time (docs/library.md#frames).
  static constexpr int kLevel = Z_BEST_SPEED;
  fs::path path_;
  std::vector<unsigned char> data_;
};

}  // namespace

void write_vtp(const fs::path& path, const Particles& p, double time, const PointFields& extra) {
  if (!std::isfinite(time)) throw std::invalid_argument("write_vtp: the time of " + path.string() + " is not finite");
  std::set<std::string> names{"velocity", "pressure", "kind", "group", "id"};
  for (const auto& [name, field] : extra.scalars) {
    check_field_name(name, names);
    if (field.size() != p.size()) throw std::invalid_argument("write_vtp: field " + name + " has the wrong length");
  }
  for (const auto& [name, field] : extra.vectors) {
    check_field_name(name, names);
    if (field[0].size() != p.size() || field[1].size() != p.size())
      throw std::invalid_argument("write_vtp: field " + name + " has the wrong length");
  }
  std::vector<std::size_t> active;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] != Kind::ghost) active.push_back(i);
  const std::size_t n = active.size();

  AppendedData data(path);
  std::ostringstream xml;  // the XML part, written after the arrays, whose offsets it names
  auto element = [&](const char* type, const std::string& name, int components, std::size_t offset) {
    xml << "<DataArray type=\"" << type << '"' << (name.empty() ? "" : " Name=\"" + name + '"');
    if (components > 1) xml << " NumberOfComponents=\"" << components << '"';
    xml << " format=\"appended\" offset=\"" << offset << "\"/>\n";
  };
  auto scalar = [&](const std::string& name, std::span<const double> field) {
    std::vector<double> out(n);
    for (std::size_t k = 0; k < n; ++k) out[k] = field[active[k]];
    element("Float64", name, 1, data.add<double>(name, out));
  };
  auto vector = [&](const std::string& name, std::span<const double> fx, std::span<const double> fy) {
    std::vector<double> out(3 * n, 0.0);
    for (std::size_t k = 0; k < n; ++k) {
      out[3 * k] = fx[active[k]];
      out[3 * k + 1] = fy[active[k]];
    }
    element("Float64", name, 3, data.add<double>(name, out));
  };
  auto integers = [&](const std::string& name, auto value_of) {
    std::vector<std::int32_t> out(n);
    for (std::size_t k = 0; k < n; ++k) out[k] = static_cast<std::int32_t>(value_of(active[k]));
    element("Int32", name, 1, data.add<std::int32_t>(name, out));
  };

  xml << "<PolyData>\n<FieldData>\n<DataArray type=\"Float64\" Name=\"TIME\" NumberOfTuples=\"1\" format=\"appended\" "
      << "offset=\"" << data.add<double>("TIME", std::span<const double>(&time, 1)) << "\"/>\n</FieldData>\n"
      << "<Piece NumberOfPoints=\"" << n << "\" NumberOfVerts=\"" << n
      << "\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">\n<Points>\n";
  vector("", p.x, p.y);
  xml << "</Points>\n<Verts>\n";  // one vertex cell per point, so that ParaView draws the points
  std::vector<std::int64_t> connectivity(n), offsets(n);
  std::iota(connectivity.begin(), connectivity.end(), 0);
  std::iota(offsets.begin(), offsets.end(), 1);
  element("Int64", "connectivity", 1, data.add<std::int64_t>("connectivity", connectivity));
  element("Int64", "offsets", 1, data.add<std::int64_t>("offsets", offsets));
  xml << "</Verts>\n<PointData Scalars=\"pressure\" Vectors=\"velocity\">\n";
  vector("velocity", p.u, p.v);
  scalar("pressure", p.p);
  integers("kind", [&](std::size_t i) { return static_cast<int>(p.kind[i]); });
  integers("group", [&](std::size_t i) { return p.group[i]; });
  integers("id", [&](std::size_t i) { return p.id[i]; });
  for (const auto& [name, field] : extra.vectors) vector(name, field[0], field[1]);
  for (const auto& [name, field] : extra.scalars) scalar(name, field);
  xml << "</PointData>\n</Piece>\n</PolyData>\n";

  write_atomically(path, [&](std::ofstream& out) {
    out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\""
        << (std::endian::native == std::endian::little ? "LittleEndian" : "BigEndian")
        << "\" header_type=\"UInt64\" compressor=\"vtkZLibDataCompressor\">\n"
        << xml.str() << "<AppendedData encoding=\"raw\">\n_";
    out.write(reinterpret_cast<const char*>(data.bytes().data()), static_cast<std::streamsize>(data.bytes().size()));
    out << "\n</AppendedData>\n</VTKFile>\n";
  });
}

PvdSeries::PvdSeries(fs::path pvd_path) : path_(std::move(pvd_path)) {}

void PvdSeries::add(double time, const fs::path& frame_path) {
  // Paths relative to the .pvd, so the output folder can be moved as a whole.
  frames_.emplace_back(time, fs::relative(fs::absolute(frame_path), fs::absolute(path_).parent_path()).string());
  write_atomically(path_, [&](std::ofstream& out) {
    out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\" byte_order=\"LittleEndian\">\n"
        << "<Collection>\n";
    for (const auto& [t, file] : frames_)
      out << "<DataSet timestep=\"" << t << "\" group=\"\" part=\"0\" file=\"" << file << "\"/>\n";
    out << "</Collection>\n</VTKFile>\n";
  });
}

void write_csv(const fs::path& path, const std::vector<std::string>& header,
               const std::vector<std::vector<double>>& columns) {
  if (header.size() != columns.size()) throw std::invalid_argument("write_csv: header and columns differ in count");
  const std::size_t rows = columns.empty() ? 0 : columns.front().size();
  for (const auto& c : columns)
    if (c.size() != rows) throw std::invalid_argument("write_csv: columns differ in length");
  write_atomically(path, [&](std::ofstream& out) {
    out.precision(10);
    for (std::size_t c = 0; c < header.size(); ++c) out << (c ? "," : "") << header[c];
    out << '\n';
    for (std::size_t r = 0; r < rows; ++r) {
      for (std::size_t c = 0; c < columns.size(); ++c) out << (c ? "," : "") << columns[c][r];
      out << '\n';
    }
  });
}

void write_json(const fs::path& path, const nlohmann::json& value) {
  write_atomically(path, [&](std::ofstream& out) { out << value.dump(2) << '\n'; });
}

void write_text(const fs::path& path, const std::string& text) {
  write_atomically(path, [&](std::ofstream& out) { out << text; });
}

void write_matrix_market(const fs::path& path, const CsrMatrix& a) { write_matrix_market(path, a, {}, false); }

void write_matrix_market(const fs::path& path, const CsrMatrix& a, const std::vector<std::string>& comments,
                         bool symmetric) {
  if (symmetric && !a.is_symmetric(0.0))
    throw std::invalid_argument("write_matrix_market: " + path.string() + " asked for as symmetric, but A is not");
  std::size_t entries = 0;
  for (int i = 0; i < a.rows; ++i)
    for (int k = a.row_ptr[static_cast<std::size_t>(i)]; k < a.row_ptr[static_cast<std::size_t>(i) + 1]; ++k)
      entries += !symmetric || a.col[static_cast<std::size_t>(k)] <= i ? 1 : 0;
  write_atomically(path, [&](std::ofstream& out) {
    out << "%%MatrixMarket matrix coordinate real " << (symmetric ? "symmetric" : "general")
        << "\n% written by SparseMPS\n";
    for (const std::string& line : comments) out << "% " << line << '\n';
    out << a.rows << ' ' << a.cols << ' ' << entries << '\n';
    for (int i = 0; i < a.rows; ++i)  // symmetric: the lower triangle, row by row
      for (int k = a.row_ptr[static_cast<std::size_t>(i)]; k < a.row_ptr[static_cast<std::size_t>(i) + 1]; ++k)
        if (!symmetric || a.col[static_cast<std::size_t>(k)] <= i)
          out << i + 1 << ' ' << a.col[static_cast<std::size_t>(k)] + 1 << ' ' << a.val[static_cast<std::size_t>(k)]
              << '\n';
  });
}

void write_matrix_market(const fs::path& path, std::span<const double> vector) {
  write_atomically(path, [&](std::ofstream& out) {
    out << "%%MatrixMarket matrix array real general\n% written by SparseMPS\n" << vector.size() << " 1\n";
    for (double v : vector) out << v << '\n';
  });
}

namespace {
// The data lines of a Matrix Market file after its banner and comments, with line numbers for messages, and
// strict numbers: every token must be a whole number or a finite value ("nan", "inf" and "1e999" are errors).
// Read through zlib, which reads a gzip file decompressed and any other file as it is.
class MatrixMarketLines {
 public:
  explicit MatrixMarketLines(const fs::path& path) : path_(path) {
    errno = 0;
    in_ = gzopen(path.c_str(), "rb");
    if (in_ == nullptr) read_error(path, std::string("cannot open") + system_reason());
    gzbuffer(in_, 1u << 17);
    std::error_code ec;
    const std::uintmax_t bytes = fs::file_size(path, ec);
    // deflate expands at most 1032-fold: the bound on what a compressed file can hold
    size_ = ec ? 0 : gzdirect(in_) != 0 ? bytes : bytes * 1032;
  }
  MatrixMarketLines(const MatrixMarketLines&) = delete;
  MatrixMarketLines& operator=(const MatrixMarketLines&) = delete;
  ~MatrixMarketLines() { gzclose(in_); }
  [[nodiscard]] std::uintmax_t file_size() const { return size_; }
  [[noreturn]] void fail(const std::string& what) const {
    read_error(path_, (line_ > 0 ? "line " + std::to_string(line_) + ": " : std::string()) + what);
  }
  // The banner's words, lower case.
  std::vector<std::string> banner() {
    std::string line;
    ++line_;
    if (!getline(line) || line.rfind("%%MatrixMarket", 0) != 0) fail("missing %%MatrixMarket banner");
    std::istringstream words(line);
    std::vector<std::string> out;
    for (std::string w; words >> w;) {
      std::transform(w.begin(), w.end(), w.begin(), [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
      out.push_back(w);
    }
    return out;
  }
  // The next line that is neither a comment nor blank, split into words; false at the end of the file.
  bool next(std::vector<std::string>& words) {
    for (std::string line; getline(line);) {
      ++line_;
      if (line.empty() || line[0] == '%') continue;
      std::istringstream split(line);
      words.clear();
      for (std::string w; split >> w;) words.push_back(w);
      if (!words.empty()) return true;
    }
    return false;
  }
  long whole(const std::string& word, long min, long max, const char* what) const {
    long value = 0;
    const auto [end, ec] = std::from_chars(word.data(), word.data() + word.size(), value);
    if (ec != std::errc() || end != word.data() + word.size() || value < min || value > max)
      fail(std::string(what) + " '" + word + "' is not a whole number in [" + std::to_string(min) + ", " +
           std::to_string(max) + "]");
    return value;
  }
  double finite(const std::string& word) const {
    char* end = nullptr;
    errno = 0;
    const double value = std::strtod(word.c_str(), &end);
    if (end != word.c_str() + word.size() || !std::isfinite(value) || errno == ERANGE)
      fail("value '" + word + "' is not a finite number");
    return value;
  }

 private:
  // One line without its '\n'; false at the end of the file. A read error (a damaged gzip stream) is an error.
  bool getline(std::string& line) {
    line.clear();
    char chunk[4096];
    while (gzgets(in_, chunk, sizeof chunk) != nullptr) {
      line += chunk;
      if (!line.empty() && line.back() == '\n') {
        line.pop_back();
        return true;
      }
    }
    int code = Z_OK;
    const char* message = gzerror(in_, &code);
    if (code != Z_OK && code != Z_BUF_ERROR) fail(std::string("cannot read on: ") + message);
    return !line.empty();
  }

  fs::path path_;
  gzFile in_ = nullptr;
  std::uintmax_t size_ = 0;
  long line_ = 0;
};

constexpr long kMaxIndex = std::numeric_limits<int>::max();

}  // namespace

CsrMatrix read_matrix_market(const fs::path& path) {
  MatrixMarketLines in(path);
  const auto banner = in.banner();
  if (banner.size() < 5 || banner[1] != "matrix" || banner[2] != "coordinate" || banner[3] != "real")
    in.fail("only 'matrix coordinate real' is supported");
  const bool symmetric = banner[4] == "symmetric";
  if (!symmetric && banner[4] != "general") in.fail("only general or symmetric storage is supported");
  std::vector<std::string> w;
  if (!in.next(w) || w.size() != 3) in.fail("expected the size line 'rows columns entries'");
  const long rows = in.whole(w[0], 0, kMaxIndex, "row count"), cols = in.whole(w[1], 0, kMaxIndex, "column count");
  // Each entry takes at least 6 bytes ("1 1 1\n"): a count beyond that is a broken header, not a big matrix.
  const long entries = in.whole(w[2], 0, static_cast<long>(in.file_size() / 6), "entry count (bounded by the file size)");
  std::vector<std::tuple<int, int, double>> triplets;
  // Capped: a compressed file's bound above is loose, and a broken header must not allocate gigabytes.
  triplets.reserve(static_cast<std::size_t>(std::min(symmetric ? 2 * entries : entries, 1L << 24)));
  for (long e = 0; e < entries; ++e) {
    if (!in.next(w)) in.fail("expected " + std::to_string(entries) + " entries, found " + std::to_string(e));
    if (w.size() != 3) in.fail("expected 'row column value'");
    const long i = in.whole(w[0], 1, rows, "row"), j = in.whole(w[1], 1, cols, "column");
    const double v = in.finite(w[2]);
    triplets.emplace_back(static_cast<int>(i - 1), static_cast<int>(j - 1), v);
    if (symmetric && i != j) triplets.emplace_back(static_cast<int>(j - 1), static_cast<int>(i - 1), v);
  }
  if (in.next(w)) in.fail("more entries than the " + std::to_string(entries) + " the size line announces");
  std::sort(triplets.begin(), triplets.end(),
            [](const auto& a, const auto& b) { return std::tie(std::get<0>(a), std::get<1>(a)) < std::tie(std::get<0>(b), std::get<1>(b)); });
  CsrMatrix a;
  a.rows = static_cast<int>(rows);
  a.cols = static_cast<int>(cols);
  a.row_ptr.assign(static_cast<std::size_t>(rows) + 1, 0);
  for (std::size_t k = 0; k < triplets.size(); ++k) {
    const auto& [i, j, v] = triplets[k];
    if (k > 0 && std::get<0>(triplets[k - 1]) == i && std::get<1>(triplets[k - 1]) == j)
      read_error(path, "duplicate entry (" + std::to_string(i + 1) + ", " + std::to_string(j + 1) + ")");
    a.col.push_back(j);
    a.val.push_back(v);
    ++a.row_ptr[static_cast<std::size_t>(i) + 1];
  }
  std::partial_sum(a.row_ptr.begin(), a.row_ptr.end(), a.row_ptr.begin());
  return a;
}

std::vector<double> read_matrix_market_vector(const fs::path& path) {
  MatrixMarketLines in(path);
  const auto banner = in.banner();
  if (banner.size() < 4 || banner[2] != "array" || banner[3] != "real") in.fail("expected 'matrix array real'");
  std::vector<std::string> w;
  if (!in.next(w) || w.size() != 2) in.fail("expected the size line 'rows 1'");
  const long rows = in.whole(w[0], 0, static_cast<long>(in.file_size() / 2), "row count (bounded by the file size)");
  in.whole(w[1], 1, 1, "column count");
  std::vector<double> v;
  v.reserve(static_cast<std::size_t>(std::min(rows, 1L << 24)));  // capped, as for the matrix
  for (long r = 0; r < rows; ++r) {
    if (!in.next(w) || w.size() != 1) in.fail("expected " + std::to_string(rows) + " values, one per line");
    v.push_back(in.finite(w[0]));
  }
  if (in.next(w)) in.fail("more values than the " + std::to_string(rows) + " the size line announces");
  return v;
}

// ---------------------------------------------------------------------------------------------------------
// Particle files

namespace {

// Each non-ghost particle's nearest other particle (index, distance), by a grid of cells about as wide as the mean
// spacing: a ring of cells k away holds nothing nearer than (k - 1) cells, so the search stops early.
struct Nearest {
  std::vector<std::size_t> index;
  std::vector<double> distance;  // infinity where a particle is alone
};

Nearest nearest_particles(const Particles& p) {
  std::vector<std::size_t> active;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] != Kind::ghost) active.push_back(i);
  Nearest out{std::vector<std::size_t>(p.size(), 0),
              std::vector<double>(p.size(), std::numeric_limits<double>::infinity())};
  if (active.size() < 2) return out;
  double x0 = p.x[active[0]], x1 = x0, y0 = p.y[active[0]], y1 = y0;
  for (std::size_t i : active) {
    x0 = std::min(x0, p.x[i]);
    x1 = std::max(x1, p.x[i]);
    y0 = std::min(y0, p.y[i]);
    y1 = std::max(y1, p.y[i]);
  }
  const auto n = static_cast<double>(active.size());
  const double w = x1 - x0, h = y1 - y0, extent = std::max(w, h);
  // At least extent / n, so a row of particles (h = 0) gets no more cells than particles; all in one point: one cell.
  double cell = std::max(std::sqrt(w * h / n), extent / n);
  if (!(cell > 0.0)) cell = 1.0;
  const auto nx = static_cast<long>(w / cell) + 1, ny = static_cast<long>(h / cell) + 1;
  auto cell_of = [&](std::size_t i) {
    const long cx = std::min(nx - 1, static_cast<long>((p.x[i] - x0) / cell));
    const long cy = std::min(ny - 1, static_cast<long>((p.y[i] - y0) / cell));
    return std::pair{cx, cy};
  };
  std::vector<std::size_t> start(static_cast<std::size_t>(nx * ny) + 1, 0), sorted(active.size());
  for (std::size_t i : active) {
    const auto [cx, cy] = cell_of(i);
    ++start[static_cast<std::size_t>(cy * nx + cx) + 1];
  }
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<std::size_t> fill(start.begin(), start.end() - 1);
  for (std::size_t i : active) {
    const auto [cx, cy] = cell_of(i);
    sorted[fill[static_cast<std::size_t>(cy * nx + cx)]++] = i;
  }
  const long rings = std::max(nx, ny);
  for (std::size_t i : active) {
    const auto [cx, cy] = cell_of(i);
    double best = std::numeric_limits<double>::infinity();
    std::size_t best_j = i;
    auto scan = [&](long gx, long gy) {
      const auto c = static_cast<std::size_t>(gy * nx + gx);
      for (std::size_t s = start[c]; s < start[c + 1]; ++s) {
        const std::size_t j = sorted[s];
        const double d = j == i ? best : std::hypot(p.x[j] - p.x[i], p.y[j] - p.y[i]);
        if (d < best || (d == best && j != i && j < best_j)) {
          best = d;
          best_j = j;
        }
      }
    };
    for (long k = 0; k <= rings; ++k) {  // the ring of cells k away: two full rows, and two cells of each row between
      for (long gy = std::max(0L, cy - k); gy <= std::min(ny - 1, cy + k); ++gy) {
        if (gy == cy - k || gy == cy + k) {
          for (long gx = std::max(0L, cx - k); gx <= std::min(nx - 1, cx + k); ++gx) scan(gx, gy);
        } else {
          if (cx - k >= 0) scan(cx - k, gy);
          if (cx + k < nx) scan(cx + k, gy);
        }
      }
      if (best <= static_cast<double>(k) * cell) break;
    }
    out.index[i] = best_j;
    out.distance[i] = best;
  }
  return out;
}

double median_of(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::infinity();
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

std::string trimmed(const std::string& text) {
  const auto begin = text.find_first_not_of(" \t\r");
  if (begin == std::string::npos) return {};
  return text.substr(begin, text.find_last_not_of(" \t\r") - begin + 1);
}

std::vector<std::string> split_fields(const std::string& line) {
  std::vector<std::string> fields;
  std::size_t from = 0;
  for (std::size_t comma; (comma = line.find(',', from)) != std::string::npos; from = comma + 1)
    fields.push_back(trimmed(line.substr(from, comma - from)));
  fields.push_back(trimmed(line.substr(from)));
  return fields;
}

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  return text;
}

std::string number_text(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

}  // namespace

Particles read_particles_csv(const fs::path& path) {
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in || fs::is_directory(path))
    throw std::runtime_error("cannot read the particle file " + path.string() + system_reason());
  long line_number = 0;
  auto fail = [&](const std::string& what) -> void {
    throw std::runtime_error("particle file " + path.string() + ":" + std::to_string(line_number) + ": " + what);
  };
  enum Column { x, y, kind, u, v, p, group, columns };
  static const std::array<const char*, columns> names{"x", "y", "kind", "u", "v", "p", "group"};
  const std::string valid = "the columns are x, y, kind (required) and u, v, p, group (optional)";
  std::vector<int> field_column;  // the column each field of a row holds
  std::array<int, columns> field_of{};
  field_of.fill(-1);
  Particles out;
  std::vector<long> lines;  // each particle's line, for the messages of the spacing check
  for (std::string line; std::getline(in, line);) {
    ++line_number;
    const std::string text = trimmed(line);
    if (text.empty() || text[0] == '#') continue;
    const std::vector<std::string> fields = split_fields(text);
    if (field_column.empty()) {  // the header
      for (const std::string& field : fields) {
        const std::string name = lower(field);
        const auto at = std::find(names.begin(), names.end(), name);
        if (at == names.end())
          fail("unknown column '" + field + "' in the header (the first line that is not a comment names the " +
               "columns, comma-separated: " + valid.substr(16) + ")");
        const auto column = static_cast<int>(at - names.begin());
        if (field_of[static_cast<std::size_t>(column)] >= 0) fail("column '" + name + "' named twice in the header");
        field_of[static_cast<std::size_t>(column)] = static_cast<int>(field_column.size());
        field_column.push_back(column);
      }
      for (int c : {Column::x, Column::y, Column::kind})
        if (field_of[static_cast<std::size_t>(c)] < 0)
          fail(std::string("the header has no column '") + names[static_cast<std::size_t>(c)] + "' (" + valid + ")");
      continue;
    }
    if (fields.size() != field_column.size())
      fail("expected " + std::to_string(field_column.size()) + " comma-separated fields, as the header names, found " +
           std::to_string(fields.size()));
    std::array<double, columns> value{};
    Kind particle_kind = Kind::fluid;
    int particle_group = 0;
    for (std::size_t f = 0; f < fields.size(); ++f) {
      const std::string& word = fields[f];
      const auto column = static_cast<std::size_t>(field_column[f]);
      if (column == Column::kind) {
        const std::string k = lower(word);
        if (k == "fluid" || k == "0") particle_kind = Kind::fluid;
        else if (k == "wall" || k == "1") particle_kind = Kind::wall;
        else if (k == "dummy" || k == "2") particle_kind = Kind::dummy;
        else if (k == "ghost" || k == "3") fail("kind '" + word + "': ghosts (inactive particles) cannot start a scene; leave the row out");
        else fail("kind '" + word + "' is not fluid, wall or dummy (or 0, 1, 2)");
        continue;
      }
      if (column == Column::group) {
        long g = 0;
        const auto [end, ec] = std::from_chars(word.data(), word.data() + word.size(), g);
        if (ec != std::errc() || end != word.data() + word.size() || g < std::numeric_limits<int>::min() ||
            g > std::numeric_limits<int>::max())
          fail("group '" + word + "' is not a whole number");
        particle_group = static_cast<int>(g);
        continue;
      }
      char* end = nullptr;
      const double number = std::strtod(word.c_str(), &end);
      if (word.empty() || end != word.c_str() + word.size() || !std::isfinite(number))
        fail(std::string("column '") + names[column] + "': '" + word + "' is not a finite number");
      value[column] = number;
    }
    out.add(value[Column::x], value[Column::y], particle_kind, particle_group, value[Column::u], value[Column::v]);
    out.p.back() = value[Column::p];
    lines.push_back(line_number);
  }
  if (in.bad()) fail("read error" + system_reason());
  if (field_column.empty()) fail("no header line (" + valid + ")");
  if (out.empty()) fail("no particles after the header");
  const Nearest near = nearest_particles(out);
  const double spacing = median_of(near.distance);
  for (std::size_t i = 0; i < out.size(); ++i) {
    const std::size_t j = near.index[i];
    const std::string pair = "particle file " + path.string() + ": lines " + std::to_string(lines[std::min(i, j)]) +
                             " and " + std::to_string(lines[std::max(i, j)]) + ": ";
    if (near.distance[i] == 0.0)
      throw std::runtime_error(pair + "two particles at the same position (" + number_text(out.x[i]) + ", " +
                               number_text(out.y[i]) + "); remove one");
    if (near.distance[i] < 0.5 * spacing)
      throw std::runtime_error(pair + "two particles " + number_text(near.distance[i]) +
                               " m apart, less than half the file's spacing (" + number_text(spacing) +
                               " m, the median distance to the nearest particle); remove or move one");
  }
  return out;
}

void write_particles_csv(const fs::path& path, const Particles& particles, const std::vector<std::string>& comments) {
  write_atomically(path, [&](std::ofstream& out) {
    for (const std::string& line : comments) out << "# " << line << '\n';
    out << "x,y,kind,u,v,p,group\n";
    for (std::size_t i = 0; i < particles.size(); ++i) {
      if (particles.kind[i] == Kind::ghost) continue;
      out << particles.x[i] << ',' << particles.y[i] << ',' << to_string(particles.kind[i]) << ',' << particles.u[i]
          << ',' << particles.v[i] << ',' << particles.p[i] << ',' << particles.group[i] << '\n';
    }
  });
}

double median_spacing(const Particles& particles) {
  Nearest near = nearest_particles(particles);
  std::vector<double> distances;
  for (std::size_t i = 0; i < particles.size(); ++i)
    if (particles.kind[i] != Kind::ghost) distances.push_back(near.distance[i]);
  return median_of(std::move(distances));
}

}  // namespace mps
