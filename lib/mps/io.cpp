#include "mps/io.hpp"

#include <algorithm>
#include <fstream>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <tuple>

namespace mps {
namespace {

namespace fs = std::filesystem;

// Writes through a temporary file in the same directory, then renames it over the target.
template <class Body>
void write_atomically(const fs::path& path, Body&& body) {
  if (path.has_parent_path()) fs::create_directories(path.parent_path());
  fs::path tmp = path;
  tmp += ".tmp";
  {
    std::ofstream out(tmp);
    if (!out) throw std::runtime_error("cannot open " + tmp.string() + " for writing");
    out.precision(17);
    body(out);
    out.flush();
    if (!out) throw std::runtime_error("failed while writing " + tmp.string());
  }
  fs::rename(tmp, path);
}

void read_error(const fs::path& path, const std::string& what) {
  throw std::runtime_error("Matrix Market file " + path.string() + ": " + what);
}

std::string xml_escape_free(const std::string& name) {
  for (char ch : name)
    if (ch == '"' || ch == '<' || ch == '>' || ch == '&') throw std::invalid_argument("write_vtp: bad field name " + name);
  return name;
}

}  // namespace

void write_vtp(const fs::path& path, const Particles& p, const std::map<std::string, std::span<const double>>& extra) {
  std::vector<std::size_t> active;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] != Kind::ghost) active.push_back(i);
  for (const auto& [name, field] : extra)
    if (field.size() != p.size()) throw std::invalid_argument("write_vtp: field " + name + " has the wrong length");
  write_atomically(path, [&](std::ofstream& out) {
    const std::size_t n = active.size();
    out << "<?xml version=\"1.0\"?>\n"
        << "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\">\n<PolyData>\n"
        << "<Piece NumberOfPoints=\"" << n << "\" NumberOfVerts=\"" << n
        << "\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">\n"
        << "<Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n";
    for (std::size_t i : active) out << p.x[i] << ' ' << p.y[i] << " 0\n";
    out << "</DataArray></Points>\n<Verts>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
    for (std::size_t k = 0; k < n; ++k) out << k << '\n';
    out << "</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
    for (std::size_t k = 1; k <= n; ++k) out << k << '\n';
    out << "</DataArray>\n</Verts>\n<PointData Scalars=\"pressure\" Vectors=\"velocity\">\n"
        << "<DataArray type=\"Float64\" Name=\"velocity\" NumberOfComponents=\"3\" format=\"ascii\">\n";
    for (std::size_t i : active) out << p.u[i] << ' ' << p.v[i] << " 0\n";
    out << "</DataArray>\n<DataArray type=\"Float64\" Name=\"pressure\" format=\"ascii\">\n";
    for (std::size_t i : active) out << p.p[i] << '\n';
    out << "</DataArray>\n<DataArray type=\"Int32\" Name=\"kind\" format=\"ascii\">\n";
    for (std::size_t i : active) out << static_cast<int>(p.kind[i]) << '\n';
    out << "</DataArray>\n<DataArray type=\"Int32\" Name=\"group\" format=\"ascii\">\n";
    for (std::size_t i : active) out << p.group[i] << '\n';
    out << "</DataArray>\n<DataArray type=\"Int32\" Name=\"id\" format=\"ascii\">\n";
    for (std::size_t i : active) out << p.id[i] << '\n';
    out << "</DataArray>\n";
    for (const auto& [name, field] : extra) {
      out << "<DataArray type=\"Float64\" Name=\"" << xml_escape_free(name) << "\" format=\"ascii\">\n";
      for (std::size_t i : active) out << field[i] << '\n';
      out << "</DataArray>\n";
    }
    out << "</PointData>\n</Piece>\n</PolyData>\n</VTKFile>\n";
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

void write_matrix_market(const fs::path& path, const CsrMatrix& a) {
  write_atomically(path, [&](std::ofstream& out) {
    out << "%%MatrixMarket matrix coordinate real general\n% written by SparseMPS\n"
        << a.rows << ' ' << a.cols << ' ' << a.nnz() << '\n';
    for (int i = 0; i < a.rows; ++i)
      for (int k = a.row_ptr[static_cast<std::size_t>(i)]; k < a.row_ptr[static_cast<std::size_t>(i) + 1]; ++k)
        out << i + 1 << ' ' << a.col[static_cast<std::size_t>(k)] + 1 << ' ' << a.val[static_cast<std::size_t>(k)] << '\n';
  });
}

void write_matrix_market(const fs::path& path, std::span<const double> vector) {
  write_atomically(path, [&](std::ofstream& out) {
    out << "%%MatrixMarket matrix array real general\n% written by SparseMPS\n" << vector.size() << " 1\n";
    for (double v : vector) out << v << '\n';
  });
}

namespace {
// Returns the banner's words (lower case) and leaves `in` after the comment lines.
std::vector<std::string> read_banner(std::ifstream& in, const fs::path& path) {
  std::string line;
  if (!std::getline(in, line) || line.rfind("%%MatrixMarket", 0) != 0) read_error(path, "missing %%MatrixMarket banner");
  std::istringstream words(line);
  std::vector<std::string> out;
  for (std::string w; words >> w;) {
    std::transform(w.begin(), w.end(), w.begin(), [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
    out.push_back(w);
  }
  while (in.peek() == '%') std::getline(in, line);
  return out;
}
}  // namespace

CsrMatrix read_matrix_market(const fs::path& path) {
  std::ifstream in(path);
  if (!in) read_error(path, "cannot open");
  const auto banner = read_banner(in, path);
  if (banner.size() < 5 || banner[1] != "matrix" || banner[2] != "coordinate" || banner[3] != "real")
    read_error(path, "only 'matrix coordinate real' is supported");
  const bool symmetric = banner[4] == "symmetric";
  if (!symmetric && banner[4] != "general") read_error(path, "only general or symmetric storage is supported");
  long rows = 0, cols = 0, entries = 0;
  if (!(in >> rows >> cols >> entries) || rows < 0 || cols < 0 || entries < 0) read_error(path, "bad size line");
  std::vector<std::tuple<int, int, double>> triplets;
  triplets.reserve(static_cast<std::size_t>(symmetric ? 2 * entries : entries));
  for (long e = 0; e < entries; ++e) {
    long i = 0, j = 0;
    double v = 0;
    if (!(in >> i >> j >> v)) read_error(path, "expected " + std::to_string(entries) + " entries, got " + std::to_string(e));
    if (i < 1 || i > rows || j < 1 || j > cols) read_error(path, "entry out of range");
    triplets.emplace_back(static_cast<int>(i - 1), static_cast<int>(j - 1), v);
    if (symmetric && i != j) triplets.emplace_back(static_cast<int>(j - 1), static_cast<int>(i - 1), v);
  }
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
  std::ifstream in(path);
  if (!in) read_error(path, "cannot open");
  const auto banner = read_banner(in, path);
  if (banner.size() < 4 || banner[2] != "array" || banner[3] != "real") read_error(path, "expected 'matrix array real'");
  long rows = 0, cols = 0;
  if (!(in >> rows >> cols) || rows < 0 || cols != 1) read_error(path, "expected a single column");
  std::vector<double> v(static_cast<std::size_t>(rows));
  for (auto& x : v)
    if (!(in >> x)) read_error(path, "fewer values than announced");
  return v;
}

}  // namespace mps
