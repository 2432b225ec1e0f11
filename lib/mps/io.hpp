#pragma once
/// \file
/// Output: VTK XML PolyData frames (.vtp, binary and zlib-compressed) and their series (.pvd) for ParaView, CSV
/// tables, JSON summaries, and Matrix Market for exporting any PPE to other solvers. Every file is written to a
/// temporary name and renamed into place, so a run that stops leaves its last complete outputs, never a half-written
/// file.
#include <array>
#include <filesystem>
#include <map>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mps/csr.hpp"
#include "mps/particles.hpp"

namespace mps {

/// Per-particle fields of a frame beyond the particles' own, each of length particles.size().
struct PointFields {
  std::map<std::string, std::span<const double>> scalars{};  ///< one value per particle, by name
  /// (x, y) components per particle, by name: written as 3-component arrays (z = 0), so ParaView treats them as vectors
  std::map<std::string, std::array<std::span<const double>, 2>> vectors{};
};

/// A frame at simulation time `time`: position, velocity, pressure, kind, group and id of every non-ghost particle,
/// plus `extra`, as VTK XML PolyData with binary appended, zlib-compressed arrays (VTK's own block layout, UInt64
/// headers), and `time` as the field-data array TIME. A failed compression throws, naming the array and the file.
void write_vtp(const std::filesystem::path& path, const Particles& particles, double time,
               const PointFields& extra = {});

/// A time series of frames: each add() rewrites the .pvd index, so it is valid after every frame.
class PvdSeries {
 public:
  explicit PvdSeries(std::filesystem::path pvd_path);  ///< a series written to pvd_path, empty until the first add()
  /// Adds the frame at frame_path for `time` (stored relative to the .pvd, so the folder can move as a whole) and
  /// rewrites the index.
  void add(double time, const std::filesystem::path& frame_path);
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }  ///< the .pvd file

 private:
  std::filesystem::path path_;
  std::vector<std::pair<double, std::string>> frames_;
};

/// One column per name; all columns of equal length.
void write_csv(const std::filesystem::path& path, const std::vector<std::string>& header,
               const std::vector<std::vector<double>>& columns);

void write_json(const std::filesystem::path& path, const nlohmann::json& value);  ///< indented, as a whole file
void write_text(const std::filesystem::path& path, const std::string& text);      ///< the text as a whole file

/// Matrix Market "coordinate real general", 17 significant digits, so a read returns the same matrix.
void write_matrix_market(const std::filesystem::path& path, const CsrMatrix& a);
/// With comment lines after the banner (each prefixed "% "); symmetric: only the lower triangle is written, and a
/// matrix that is not exactly symmetric is refused.
void write_matrix_market(const std::filesystem::path& path, const CsrMatrix& a, const std::vector<std::string>& comments,
                         bool symmetric);
void write_matrix_market(const std::filesystem::path& path, std::span<const double> vector);  ///< "array real general"
CsrMatrix read_matrix_market(const std::filesystem::path& path);  ///< coordinate, general or symmetric
/// "array real" with one column; refuses anything else, naming the line.
std::vector<double> read_matrix_market_vector(const std::filesystem::path& path);

}  // namespace mps
