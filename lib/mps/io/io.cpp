#include "mps/io/io.hpp"
#include "mps/core/state.hpp"
#include "mps/core/vec.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <string_view>
#include <map>
#include <iterator>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <numeric>
#include <set>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include <fcntl.h>
#include <unistd.h>
#include <zlib.h>

namespace mps {
namespace {

namespace fs = std::filesystem;

std::string kind_of(const fs::file_status& s);

}  // namespace

void require_file_path(const fs::path& path) {
  if (path.empty()) throw std::invalid_argument("an output file's path is empty; name the file to write");
  std::error_code ec;
  const fs::file_status s = fs::status(path, ec);
  if (fs::exists(s) && !fs::is_regular_file(s))
    throw std::invalid_argument("cannot write " + path.string() + ": it exists and is " + kind_of(s) +
                                ", not a regular file; give the path of a file (a file there is replaced)");
}

void require_directory_path(const fs::path& path) {
  if (path.empty()) throw std::invalid_argument("an output folder's path is empty; name the folder to write into");
  std::error_code ec;
  const fs::file_status s = fs::status(path, ec);
  if (fs::exists(s) && !fs::is_directory(s))
    throw std::invalid_argument("cannot write into " + path.string() + ": it exists and is " +
                                (fs::is_regular_file(s) ? std::string("a file") : kind_of(s)) +
                                ", not a directory; give a directory (made if missing)");
}

namespace {

// What the system said about the last failed call (errno), for messages: "No space left on device".
std::string system_reason() { return errno != 0 ? std::string(": ") + std::strerror(errno) : std::string(); }

// What a path names, for messages: "a directory", "a character device (such as /dev/null)".
std::string kind_of(const fs::file_status& s) {
  switch (s.type()) {
    case fs::file_type::directory: return "a directory";
    case fs::file_type::character: return "a character device";
    case fs::file_type::block: return "a block device";
    case fs::file_type::fifo: return "a FIFO";
    case fs::file_type::socket: return "a socket";
    case fs::file_type::symlink: return "a symbolic link";
    default: return "not a regular file";
  }
}

// Opens `tmp` as a new regular file of its own: a leftover regular file (a killed run's) is replaced, anything else
// there (a FIFO, a device, a link) refused, so the write can neither block nor land outside the file.
void create_temporary(const fs::path& tmp) {
  for (int attempt = 0; attempt < 2; ++attempt) {
    errno = 0;
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0) {
      ::close(fd);
      return;
    }
    if (errno != EEXIST) break;
    std::error_code ec;
    const fs::file_status there = fs::symlink_status(tmp, ec);
    if (!fs::is_regular_file(there))
      throw std::runtime_error("cannot write through " + tmp.string() + ": it exists and is " + kind_of(there) +
                               "; remove it");
    fs::remove(tmp, ec);
  }
  throw std::runtime_error("cannot create " + tmp.string() + system_reason());
}

// Writes through a temporary file in the same directory, then renames it over the target; on any failure the
// temporary file is removed, the target left as it was, and the message says why (errno).
template <class Body>
void write_atomically(const fs::path& path, Body&& body) {
  require_file_path(path);
  // A link to a file is written through, so that the link stays.
  std::error_code ec;
  const fs::path target = fs::is_symlink(fs::symlink_status(path, ec)) ? fs::canonical(path) : path;
  if (target.has_parent_path()) fs::create_directories(target.parent_path());
  fs::path tmp = target;
  tmp += ".tmp";
  auto fail = [&](const std::string& what) {
    const std::string reason = system_reason();
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw std::runtime_error(what + reason);
  };
  create_temporary(tmp);
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
  // Checked again just before the rename: whatever appeared at the path meanwhile is never replaced unless a file.
  try {
    require_file_path(target);
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw;
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    errno = ec.value();
    fail("cannot rename " + tmp.string() + " to " + target.string());
  }
}

[[noreturn]] void read_error(const fs::path& path, const std::string& what) {
  throw std::runtime_error("Matrix Market file " + path.string() + ": " + what);
}

// Whether `field` is a component of the position or the velocity: frames write those as the points and the vector
// "velocity", particle files as their first columns; every other field of the list is written by its name.
template <int D, class T>
bool is_vector_component(const BasicParticles<D>& p, const std::vector<T>& field) {
  if constexpr (std::is_same_v<T, double>) {
    for (std::size_t a = 0; a < D; ++a)
      if (&field == p.positions()[a] || &field == p.velocities()[a]) return true;
  }
  return false;
}

// A particle file's columns, f(name, field) in their order: the position's components, kind, then every other field
// of the particles' list but id (a read numbers the particles afresh).
template <class Particles, class F>
void for_each_file_column(Particles& p, F&& f) {
  auto is_position = [&p](const auto& field) {
    if constexpr (std::is_same_v<std::remove_cvref_t<decltype(field)>, std::vector<double>>) {
      for (const auto* component : p.positions())
        if (&field == component) return true;
    }
    return false;
  };
  p.for_each_field([&](const char* name, auto& field) {
    if (is_position(field)) f(name, field);
  });
  f("kind", p.kind);
  p.for_each_field([&](const char* name, auto& field) {
    if (!is_position(field) && static_cast<const void*>(&field) != &p.kind && std::string_view(name) != "id")
      f(name, field);
  });
}

template <class Particles>
std::vector<std::string> file_columns(Particles& p) {
  std::vector<std::string> names;
  for_each_file_column(p, [&](const char* name, const auto&) { names.emplace_back(name); });
  return names;
}

// A field's array in frames: the field list's name, but "pressure" for p (the name ParaView users and readers know).
std::string frame_name(std::string_view field) { return field == "p" ? "pressure" : std::string(field); }

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

template <int D>
void write_vtp(const fs::path& path, const BasicParticles<D>& p, double time,
               const std::type_identity_t<BasicPointFields<D>>& extra) {
  if (!std::isfinite(time)) throw std::invalid_argument("write_vtp: the time of " + path.string() + " is not finite");
  std::set<std::string> names{"velocity"};
  p.for_each_field([&](const char* name, const auto& field) {
    if (!is_vector_component(p, field)) names.insert(frame_name(name));
  });
  for (const auto& [name, field] : extra.scalars) {
    check_field_name(name, names);
    if (field.size() != p.size()) throw std::invalid_argument("write_vtp: field " + name + " has the wrong length");
  }
  for (const auto& [name, field] : extra.vectors) {
    check_field_name(name, names);
    for (const auto& component : field)
      if (component.size() != p.size()) throw std::invalid_argument("write_vtp: field " + name + " has the wrong length");
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
  auto vector = [&](const std::string& name, const std::array<std::span<const double>, D>& field) {
    std::vector<double> out(3 * n, 0.0);
    for (std::size_t k = 0; k < n; ++k)
      for (std::size_t a = 0; a < D; ++a) out[3 * k + a] = field[a][active[k]];
    element("Float64", name, 3, data.add<double>(name, out));
  };
  auto components = [](const auto& vectors) {
    std::array<std::span<const double>, D> field;
    for (std::size_t a = 0; a < D; ++a) field[a] = *vectors[a];
    return field;
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
  vector("", components(p.positions()));
  xml << "</Points>\n<Verts>\n";  // one vertex cell per point, so that ParaView draws the points
  std::vector<std::int64_t> connectivity(n), offsets(n);
  std::iota(connectivity.begin(), connectivity.end(), 0);
  std::iota(offsets.begin(), offsets.end(), 1);
  element("Int64", "connectivity", 1, data.add<std::int64_t>("connectivity", connectivity));
  element("Int64", "offsets", 1, data.add<std::int64_t>("offsets", offsets));
  xml << "</Verts>\n<PointData Scalars=\"pressure\" Vectors=\"velocity\">\n";
  vector("velocity", components(p.velocities()));
  p.for_each_field([&]<class T>(const char* name, const std::vector<T>& field) {
    if (is_vector_component(p, field)) return;
    if constexpr (std::is_same_v<T, double>) scalar(frame_name(name), field);
    else integers(frame_name(name), [&](std::size_t i) { return static_cast<int>(field[i]); });
  });
  for (const auto& [name, field] : extra.vectors) vector(name, field);
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

nlohmann::json config_json(const SimulationConfig& config) {
  // The schema's units as the summaries' key suffixes (docs/summary.schema.json).
  static const std::map<std::string, std::string> suffix{
      {"m", "_m"},           {"l0", "_l0"},   {"s", "_s"},         {"m/s", "_m_per_s"}, {"m/s^2", "_m_per_s2"},
      {"kg/m^3", "_kg_per_m3"}, {"m^2/s", "_m2_per_s"}, {"steps", "_steps"}, {"", ""}};
  nlohmann::json out = nlohmann::json::object();
  for_each_parameter([&]<class T>(const Parameter<T>& p) {
    const std::string key = p.name + suffix.at(p.unit);
    if constexpr (std::is_same_v<T, Weight> || std::is_same_v<T, GradientVariant>)
      out[key] = std::string(to_string(config.*p.member));
    else if constexpr (std::is_same_v<T, double>) {
      // The one infinity validate() lets through is the guard's "off": written as such, where JSON has no infinity.
      if (std::isfinite(config.*p.member)) out[key] = config.*p.member;
      else out[p.name] = "off";
    } else {
      out[key] = config.*p.member;
    }
  });
  return out;
}

PvdSeries::PvdSeries(fs::path pvd_path) : path_(std::move(pvd_path)) {}

void PvdSeries::add(double time, const fs::path& frame_path) {
  // Paths relative to the .pvd, so the output folder can be moved as a whole.
  frames_.emplace_back(time, fs::relative(fs::absolute(frame_path), fs::absolute(path_).parent_path()).string());
  write();
}

nlohmann::json PvdSeries::save_state() const {
  nlohmann::json frames = nlohmann::json::array();
  for (const auto& [t, file] : frames_) frames.push_back({{"time", t}, {"file", file}});
  return frames;
}

void PvdSeries::restore_state(const nlohmann::json& state) {
  std::vector<std::pair<double, std::string>> frames;
  for (const auto& frame : state) frames.emplace_back(unpack_value<double>(frame, "time"), unpack_value<std::string>(frame, "file"));
  frames_ = std::move(frames);
  if (!frames_.empty()) write();
}

void PvdSeries::write() const {
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

namespace {
constexpr const char* kCheckpointFormat = "sparsemps-checkpoint";
constexpr int kCheckpointVersion = 1;
}  // namespace

void write_checkpoint(const fs::path& path, const nlohmann::json& state) {
  static_assert(std::endian::native == std::endian::little, "checkpoints store arrays in little-endian byte order");
  const nlohmann::json file = {{"format", kCheckpointFormat}, {"version", kCheckpointVersion}, {"state", state}};
  const std::vector<std::uint8_t> bytes = nlohmann::json::to_cbor(file);
  write_atomically(path, [&](std::ofstream& out) {
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  });
}

nlohmann::json read_checkpoint(const fs::path& path) {
  const std::string what = "checkpoint " + path.string() + ": ";
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(what + "cannot open it" + system_reason());
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  nlohmann::json file;
  try {
    file = nlohmann::json::from_cbor(bytes, true, true, nlohmann::json::cbor_tag_handler_t::store);  // arrays' types
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(what + "not a SparseMPS checkpoint, or truncated or damaged (" + e.what() + ")");
  }
  const auto format = file.is_object() ? file.find("format") : file.end();
  if (format == file.end() || *format != kCheckpointFormat)
    throw std::runtime_error(what + "not a SparseMPS checkpoint (no \"format\": \"" + kCheckpointFormat + "\")");
  const auto version = file.find("version");
  if (version == file.end() || *version != kCheckpointVersion)
    throw std::runtime_error(what + "format version " + (version == file.end() ? "missing" : version->dump()) +
                             "; this SparseMPS reads version " + std::to_string(kCheckpointVersion));
  const auto state = file.find("state");
  if (state == file.end() || !state->is_object()) throw std::runtime_error(what + "no state in it (a damaged file?)");
  return std::move(*state);
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

template <int D>
Nearest nearest_particles(const BasicParticles<D>& p) {
  std::vector<std::size_t> active;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] != Kind::ghost) active.push_back(i);
  Nearest out{std::vector<std::size_t>(p.size(), 0),
              std::vector<double>(p.size(), std::numeric_limits<double>::infinity())};
  if (active.size() < 2) return out;
  Vec<D> lo = p.position(active[0]), hi = lo;
  for (std::size_t i : active) {
    const Vec<D> r = p.position(i);
    for (std::size_t a = 0; a < D; ++a) {
      lo[a] = std::min(lo[a], r[a]);
      hi[a] = std::max(hi[a], r[a]);
    }
  }
  const auto n = static_cast<double>(active.size());
  double volume = 1.0, extent = 0.0;
  for (std::size_t a = 0; a < D; ++a) {
    volume *= hi[a] - lo[a];
    extent = std::max(extent, hi[a] - lo[a]);
  }
  // At least extent / n, so a row of particles (no area) gets no more cells than particles; all in one point: one
  // cell.
  double cell = std::max(D == 2 ? std::sqrt(volume / n) : std::cbrt(volume / n), extent / n);
  if (!(cell > 0.0)) cell = 1.0;
  std::array<long, D> cells;
  std::size_t total = 1;
  for (std::size_t a = 0; a < D; ++a) {
    cells[a] = static_cast<long>((hi[a] - lo[a]) / cell) + 1;
    total *= static_cast<std::size_t>(cells[a]);
  }
  auto cell_of = [&](std::size_t i) {
    std::array<long, D> c;
    const Vec<D> r = p.position(i);
    for (std::size_t a = 0; a < D; ++a) c[a] = std::min(cells[a] - 1, static_cast<long>((r[a] - lo[a]) / cell));
    return c;
  };
  auto index_of = [&](const std::array<long, D>& c) {
    std::size_t k = 0;
    for (std::size_t a = D; a-- > 0;) k = k * static_cast<std::size_t>(cells[a]) + static_cast<std::size_t>(c[a]);
    return k;
  };
  std::vector<std::size_t> start(total + 1, 0), sorted(active.size());
  for (std::size_t i : active) ++start[index_of(cell_of(i)) + 1];
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<std::size_t> fill(start.begin(), start.end() - 1);
  for (std::size_t i : active) sorted[fill[index_of(cell_of(i))]++] = i;
  long rings = 0;
  for (long c : cells) rings = std::max(rings, c);
  for (std::size_t i : active) {
    const std::array<long, D> ci = cell_of(i);
    const Vec<D> ri = p.position(i);
    double best = std::numeric_limits<double>::infinity();
    std::size_t best_j = i;
    auto scan = [&](const std::array<long, D>& c) {
      const std::size_t k = index_of(c);
      for (std::size_t s = start[k]; s < start[k + 1]; ++s) {
        const std::size_t j = sorted[s];
        const Vec<D> rj = p.position(j);
        Vec<D> d;
        for (std::size_t a = 0; a < D; ++a) d[a] = rj[a] - ri[a];
        const double dist = j == i ? best : norm<D>(d);
        if (dist < best || (dist == best && j != i && j < best_j)) {
          best = dist;
          best_j = j;
        }
      }
    };
    for (long k = 0; k <= rings; ++k) {
      // The shell of cells k away (Chebyshev), clipped to the grid.
      std::array<long, D> from, to, c;
      for (std::size_t a = 0; a < D; ++a) {
        from[a] = std::max(0L, ci[a] - k);
        to[a] = std::min(cells[a] - 1, ci[a] + k);
      }
      c = from;
      while (true) {
        long away = 0;
        for (std::size_t a = 0; a < D; ++a) away = std::max(away, std::abs(c[a] - ci[a]));
        if (away == k) scan(c);
        std::size_t a = 0;
        for (; a < D; ++a) {
          if (++c[a] <= to[a]) break;
          c[a] = from[a];
        }
        if (a == D) break;
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

template <int D>
BasicParticles<D> read_particles_csv(const fs::path& path) {
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in || fs::is_directory(path))
    throw std::runtime_error("cannot read the particle file " + path.string() + system_reason());
  long line_number = 0;
  auto fail = [&](const std::string& what) -> void {
    throw std::runtime_error("particle file " + path.string() + ":" + std::to_string(line_number) + ": " + what);
  };
  // The columns: every field of the particles' list but id (a read numbers the particles afresh); the position's
  // components and kind are required.
  BasicParticles<D> out;
  const std::vector<std::string> names = file_columns(out);
  std::string required = names[0], optional = names[D + 1];  // the position and kind; the rest
  for (std::size_t c = 1; c <= D; ++c) required += ", " + names[c];
  for (std::size_t c = D + 2; c < names.size(); ++c) optional += ", " + names[c];
  const std::string valid = "the columns are " + required + " (required) and " + optional + " (optional)";
  std::vector<int> field_column;  // the column each field of a row holds
  std::vector<int> field_of(names.size(), -1);
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
        if (D == 2 && (name == "z" || name == "w"))
          fail("column '" + name + "': a 3-D particle file; this scene is 2-D (" + valid + ")");
        if (at == names.end())
          fail("unknown column '" + field + "' in the header (the first line that is not a comment names the " +
               "columns, comma-separated: " + valid.substr(16) + ")");
        const auto column = static_cast<std::size_t>(at - names.begin());
        if (field_of[column] >= 0) fail("column '" + name + "' named twice in the header");
        field_of[column] = static_cast<int>(field_column.size());
        field_column.push_back(static_cast<int>(column));
      }
      for (std::size_t c = 0; c <= D; ++c)
        if (field_of[c] < 0) fail("the header has no column '" + names[c] + "' (" + valid + ")");
      continue;
    }
    if (fields.size() != field_column.size())
      fail("expected " + std::to_string(field_column.size()) + " comma-separated fields, as the header names, found " +
           std::to_string(fields.size()));
    std::size_t c = 0;
    out.add(Vec<D>{}, Kind::fluid);
    for_each_file_column(out, [&]<class T>(const char* name, std::vector<T>& field) {
      const int f = field_of[c++];
      if (f < 0) return;  // an optional column the file leaves out: the field's default
      const std::string& word = fields[static_cast<std::size_t>(f)];
      if constexpr (std::is_same_v<T, Kind>) {
        const std::string k = lower(word);
        if (k == "fluid" || k == "0") field.back() = Kind::fluid;
        else if (k == "wall" || k == "1") field.back() = Kind::wall;
        else if (k == "dummy" || k == "2") field.back() = Kind::dummy;
        else if (k == "ghost" || k == "3") fail("kind '" + word + "': ghosts (inactive particles) cannot start a scene; leave the row out");
        else fail("kind '" + word + "' is not fluid, wall or dummy (or 0, 1, 2)");
      } else if constexpr (std::is_same_v<T, int>) {
        long g = 0;
        const auto [end, ec] = std::from_chars(word.data(), word.data() + word.size(), g);
        if (ec != std::errc() || end != word.data() + word.size() || g < std::numeric_limits<int>::min() ||
            g > std::numeric_limits<int>::max())
          fail(std::string(name) + " '" + word + "' is not a whole number");
        field.back() = static_cast<int>(g);
      } else {
        char* end = nullptr;
        const double number = std::strtod(word.c_str(), &end);
        if (word.empty() || end != word.c_str() + word.size() || !std::isfinite(number))
          fail(std::string("column '") + name + "': '" + word + "' is not a finite number");
        field.back() = number;
      }
    });
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
    if (near.distance[i] == 0.0) {
      std::string at = "(" + number_text(out.x[i]) + ", " + number_text(out.y[i]);
      if constexpr (D == 3) at += ", " + number_text(out.z[i]);
      throw std::runtime_error(pair + "two particles at the same position " + at + "); remove one");
    }
    if (near.distance[i] < 0.5 * spacing)
      throw std::runtime_error(pair + "two particles " + number_text(near.distance[i]) +
                               " m apart, less than half the file's spacing (" + number_text(spacing) +
                               " m, the median distance to the nearest particle); remove or move one");
  }
  return out;
}

template <int D>
void write_particles_csv(const fs::path& path, const BasicParticles<D>& particles,
                         const std::vector<std::string>& comments) {
  write_atomically(path, [&](std::ofstream& out) {
    for (const std::string& line : comments) out << "# " << line << '\n';
    const std::vector<std::string> names = file_columns(particles);
    for (std::size_t c = 0; c < names.size(); ++c) out << (c ? "," : "") << names[c];
    out << '\n';
    for (std::size_t i = 0; i < particles.size(); ++i) {
      if (particles.kind[i] == Kind::ghost) continue;
      bool first = true;
      for_each_file_column(particles, [&]<class T>(const char*, const std::vector<T>& field) {
        if (!first) out << ',';
        first = false;
        if constexpr (std::is_same_v<T, Kind>) out << to_string(field[i]);
        else out << field[i];
      });
      out << '\n';
    }
  });
}

// ---------------------------------------------------------------------------------------------------------
// Frames read back

namespace {

// The value of attribute `name` in an XML start tag, or `fallback` when the tag has none.
std::string attribute(const std::string& tag, const std::string& name, const std::string& fallback = "") {
  const std::string key = " " + name + "=\"";
  const std::size_t at = tag.find(key);
  if (at == std::string::npos) return fallback;
  const std::size_t begin = at + key.size(), end = tag.find('"', begin);
  return end == std::string::npos ? fallback : tag.substr(begin, end - begin);
}

// The appended arrays of a frame, decoded to doubles.
class AppendedReader {
 public:
  AppendedReader(const fs::path& path, std::string_view data, bool wide_header, bool zlib)
      : path_(path), data_(data), wide_(wide_header), zlib_(zlib) {}

  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error("frame " + path_.string() + ": " + what);
  }

  // The array of the DataArray tag `tag`, as doubles, expecting `count` values.
  std::vector<double> values(const std::string& tag, std::size_t count) const {
    const std::string name = attribute(tag, "Name", "points");
    if (attribute(tag, "format") != "appended")
      fail("array '" + name + "' is not appended raw data (format '" + attribute(tag, "format") +
           "'); write it with write_vtp, or with VTK's writer in appended mode without encoding");
    const std::string type = attribute(tag, "type");
    static const std::map<std::string, std::size_t> sizes{{"Float32", 4}, {"Float64", 8}, {"Int8", 1}, {"UInt8", 1},
                                                          {"Int16", 2},   {"UInt16", 2},  {"Int32", 4}, {"UInt32", 4},
                                                          {"Int64", 8},   {"UInt64", 8}};
    const auto size = sizes.find(type);
    if (size == sizes.end()) fail("array '" + name + "' has type '" + type + "', which is not read");
    char* end = nullptr;
    const std::string offset_text = attribute(tag, "offset");
    const unsigned long long offset = std::strtoull(offset_text.c_str(), &end, 10);
    if (offset_text.empty() || *end != '\0') fail("array '" + name + "' has no offset");
    const std::vector<unsigned char> bytes = decode(name, offset);
    if (bytes.size() != count * size->second)
      fail("array '" + name + "' holds " + std::to_string(bytes.size()) + " bytes, not the " +
           std::to_string(count * size->second) + " its " + std::to_string(count) + " values need");
    std::vector<double> out(count);
    const unsigned char* raw = bytes.data();
    for (std::size_t k = 0; k < count; ++k) out[k] = number(type, raw + k * size->second);
    return out;
  }

 private:
  static double number(const std::string& type, const unsigned char* at) {
    auto as = [&](auto zero) {
      decltype(zero) v;
      std::memcpy(&v, at, sizeof v);
      return static_cast<double>(v);
    };
    if (type == "Float64") return as(double{});
    if (type == "Float32") return as(float{});
    if (type == "Int8") return as(std::int8_t{});
    if (type == "UInt8") return as(std::uint8_t{});
    if (type == "Int16") return as(std::int16_t{});
    if (type == "UInt16") return as(std::uint16_t{});
    if (type == "Int32") return as(std::int32_t{});
    if (type == "UInt32") return as(std::uint32_t{});
    if (type == "Int64") return as(std::int64_t{});
    return as(std::uint64_t{});
  }

  std::uint64_t header(const std::string& name, std::uint64_t at) const {
    const std::size_t width = wide_ ? 8 : 4;
    if (at + width > data_.size()) fail("array '" + name + "' runs past the end of the file");
    if (wide_) {
      std::uint64_t v;
      std::memcpy(&v, data_.data() + at, 8);
      return v;
    }
    std::uint32_t v;
    std::memcpy(&v, data_.data() + at, 4);
    return v;
  }

  // The bytes of the array at `offset`: [byte count, bytes] uncompressed; [blocks, block size, last block's size
  // if partial, each block's compressed size, blocks] with zlib, the layout write_vtp writes.
  std::vector<unsigned char> decode(const std::string& name, std::uint64_t offset) const {
    const std::uint64_t width = wide_ ? 8 : 4;
    auto span = [&](std::uint64_t at, std::uint64_t length) {
      if (at > data_.size() || length > data_.size() - at) fail("array '" + name + "' runs past the end of the file");
      return reinterpret_cast<const unsigned char*>(data_.data() + at);
    };
    if (!zlib_) {
      const std::uint64_t length = header(name, offset);
      const unsigned char* at = span(offset + width, length);
      return {at, at + length};
    }
    const std::uint64_t blocks = header(name, offset), block = header(name, offset + width),
                        last = header(name, offset + 2 * width);
    if (blocks > data_.size() / width || (blocks > 0 && (block == 0 || last > block)))
      fail("array '" + name + "' has a broken compression header");
    const std::uint64_t total = blocks == 0 ? 0 : (blocks - 1) * block + (last > 0 ? last : block);
    if (total > 1032 * static_cast<std::uint64_t>(data_.size()))  // deflate's largest ratio
      fail("array '" + name + "' claims more data than its file can hold");
    std::vector<unsigned char> out(static_cast<std::size_t>(total));
    std::uint64_t from = offset + (3 + blocks) * width;
    for (std::uint64_t b = 0; b < blocks; ++b) {
      const std::uint64_t compressed = header(name, offset + (3 + b) * width);
      const std::uint64_t expected = b + 1 == blocks && last > 0 ? last : block;
      uLongf length = static_cast<uLongf>(expected);
      const int rc = uncompress(out.data() + b * block, &length, span(from, compressed), static_cast<uLong>(compressed));
      if (rc != Z_OK || length != expected)
        fail("array '" + name + "' does not decompress (block " + std::to_string(b) + ": " + zError(rc) + ")");
      from += compressed;
    }
    return out;
  }

  fs::path path_;
  std::string_view data_;
  bool wide_, zlib_;
};

}  // namespace

template <int D>
BasicParticles<D> read_vtp(const fs::path& path, double* time) {
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in || fs::is_directory(path)) throw std::runtime_error("cannot read the frame " + path.string() + system_reason());
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto fail = [&](const std::string& what) -> void { throw std::runtime_error("frame " + path.string() + ": " + what); };
  const std::size_t appended = text.find("<AppendedData");
  const std::string xml = text.substr(0, appended);
  auto tag = [&](const std::string& name, std::size_t from = 0, std::size_t to = std::string::npos) {
    const std::size_t at = xml.find("<" + name, from);
    if (at == std::string::npos || at >= to) return std::string();
    return xml.substr(at, xml.find('>', at) - at);
  };
  const std::string file = tag("VTKFile");
  if (file.empty() || attribute(file, "type") != "PolyData") fail("not a VTK XML PolyData file (.vtp)");
  const bool little = std::endian::native == std::endian::little;
  if (attribute(file, "byte_order", "LittleEndian") != (little ? "LittleEndian" : "BigEndian"))
    fail("byte order " + attribute(file, "byte_order") + " is not this machine's");
  const std::string header_type = attribute(file, "header_type", "UInt32"), compressor = attribute(file, "compressor");
  if (header_type != "UInt32" && header_type != "UInt64") fail("header_type " + header_type + " is not read");
  if (!compressor.empty() && compressor != "vtkZLibDataCompressor")
    fail("compressed by " + compressor + "; only zlib (vtkZLibDataCompressor) or no compression is read");
  if (xml.find("<Piece", xml.find("<Piece") + 1) != std::string::npos) fail("more than one piece");
  const std::string piece = tag("Piece");
  char* end = nullptr;
  const std::string points_text = attribute(piece, "NumberOfPoints");
  const unsigned long long n = std::strtoull(points_text.c_str(), &end, 10);
  if (piece.empty() || points_text.empty() || *end != '\0') fail("no piece with NumberOfPoints");
  if (appended == std::string::npos) fail("no appended data (write it with write_vtp)");
  const std::string appended_tag = text.substr(appended, text.find('>', appended) - appended);
  if (attribute(appended_tag, "encoding") != "raw")
    fail("appended data encoded as '" + attribute(appended_tag, "encoding") + "'; only raw is read");
  const std::size_t underscore = text.find('_', appended + appended_tag.size());
  if (underscore == std::string::npos) fail("no '_' opening the appended data");
  // A frame cut short may still hold every array it names; its missing closing tags tell.
  const std::string closing = "</AppendedData>";
  const std::size_t closed = text.rfind(closing);
  bool whole = closed != std::string::npos && closed > underscore;
  if (whole) {
    const std::size_t tail = text.find_first_not_of(" \t\r\n", closed + closing.size());
    whole = tail != std::string::npos && text.compare(tail, 10, "</VTKFile>") == 0 &&
            text.find_first_not_of(" \t\r\n", tail + 10) == std::string::npos;
  }
  if (!whole)
    fail("it ends before its closing </AppendedData> and </VTKFile> tags: the file was cut short");
  const AppendedReader data(path, std::string_view(text).substr(underscore + 1, closed - underscore - 1),
                            header_type == "UInt64", compressor == "vtkZLibDataCompressor");
  if (n > text.size()) fail("NumberOfPoints " + points_text + " exceeds what the file can hold");

  const std::size_t points_at = xml.find("<Points"), point_data_at = xml.find("<PointData");
  const std::string points = tag("DataArray", points_at, xml.find("</Points"));
  if (points_at == std::string::npos || points.empty()) fail("no points");
  if (attribute(points, "NumberOfComponents", "1") != "3") fail("points without 3 components");
  auto named = [&](const std::string& name, const std::string& components) {
    for (std::size_t at = point_data_at; at != std::string::npos && at < xml.size();) {
      const std::string array = tag("DataArray", at, xml.find("</PointData"));
      if (array.empty()) break;
      if (attribute(array, "Name") == name) {
        if (attribute(array, "NumberOfComponents", "1") != components)
          fail("array '" + name + "' has " + attribute(array, "NumberOfComponents", "1") + " components, not " +
               components);
        return array;
      }
      at = xml.find("<DataArray", at) + 1;
    }
    fail("no point array '" + name + "' (frames of write_vtp have velocity and every field of the particles' list)");
    return std::string();
  };
  const std::vector<double> xyz = data.values(points, 3 * n), uvw = data.values(named("velocity", "3"), 3 * n);
  // Every other field of the particles' list by its frame name, but id: a read numbers the particles afresh.
  BasicParticles<D> out;
  auto for_each_column = [&out](auto&& f) {
    out.for_each_field([&](const char* name, auto& field) {
      if (!is_vector_component(out, field) && std::string_view(name) != "id") f(name, field);
    });
  };
  std::vector<std::vector<double>> columns;
  for_each_column([&](const char* name, const auto&) { columns.push_back(data.values(named(frame_name(name), "1"), n)); });
  out.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::string point = "point " + std::to_string(i);
    for (std::size_t a = 0; a < 3; ++a)
      if (!std::isfinite(xyz[3 * i + a]) || !std::isfinite(uvw[3 * i + a]))
        fail(point + " has a position or velocity that is not finite");
    if (D == 2 && (xyz[3 * i + 2] != 0.0 || uvw[3 * i + 2] != 0.0))
      fail(point + " has z = " + number_text(xyz[3 * i + 2]) + " or w = " + number_text(uvw[3 * i + 2]) +
           ": a 3-D frame; this scene is 2-D");
    Vec<D> r, vel;
    for (std::size_t a = 0; a < D; ++a) {
      r[a] = xyz[3 * i + a];
      vel[a] = uvw[3 * i + a];
    }
    out.add(r, Kind::fluid, 0, vel);
    std::size_t c = 0;
    for_each_column([&]<class T>(const char* name, std::vector<T>& field) {
      const double v = columns[c++][i];
      const std::string what = point + " has " + frame_name(name) + " " + number_text(v);
      if constexpr (std::is_same_v<T, double>) {
        if (!std::isfinite(v)) fail(what + ", not a finite number");
      } else if constexpr (std::is_same_v<T, Kind>) {
        if (v != 0 && v != 1 && v != 2) fail(what + ", not fluid (0), wall (1) or dummy (2)");
      } else if (v != std::floor(v) || std::abs(v) > std::numeric_limits<int>::max()) {
        fail(what + ", not a whole number");
      }
      if constexpr (std::is_same_v<T, double>) field.back() = v;
      else field.back() = static_cast<T>(static_cast<int>(v));
    });
  }
  if (time != nullptr) {
    *time = std::numeric_limits<double>::quiet_NaN();
    const std::size_t field_at = xml.find("<FieldData");
    for (std::size_t at = field_at; at != std::string::npos;) {
      const std::string array = tag("DataArray", at, xml.find("</FieldData"));
      if (array.empty()) break;
      if (attribute(array, "Name") == "TIME") {
        *time = data.values(array, 1)[0];
        break;
      }
      at = xml.find("<DataArray", at) + 1;
    }
  }
  return out;
}

template <int D>
double median_spacing(const BasicParticles<D>& particles) {
  Nearest near = nearest_particles(particles);
  std::vector<double> distances;
  for (std::size_t i = 0; i < particles.size(); ++i)
    if (particles.kind[i] != Kind::ghost) distances.push_back(near.distance[i]);
  return median_of(std::move(distances));
}

template void write_vtp(const fs::path&, const BasicParticles<2>&, double, const BasicPointFields<2>&);
template void write_vtp(const fs::path&, const BasicParticles<3>&, double, const BasicPointFields<3>&);
template BasicParticles<2> read_particles_csv(const fs::path&);
template BasicParticles<3> read_particles_csv(const fs::path&);
template void write_particles_csv(const fs::path&, const BasicParticles<2>&, const std::vector<std::string>&);
template void write_particles_csv(const fs::path&, const BasicParticles<3>&, const std::vector<std::string>&);
template BasicParticles<2> read_vtp(const fs::path&, double*);
template BasicParticles<3> read_vtp(const fs::path&, double*);
template double median_spacing(const BasicParticles<2>&);
template double median_spacing(const BasicParticles<3>&);

}  // namespace mps
