#pragma once
/// \file
/// Output: VTK XML PolyData frames (.vtp) and their series (.pvd) for ParaView, CSV tables, JSON summaries,
/// and Matrix Market for exporting any PPE to other solvers. Every file is written to a temporary name and
/// renamed into place, so a run that stops leaves its last complete outputs, never a half-written file.
#include <filesystem>
#include <map>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mps/csr.hpp"
#include "mps/particles.hpp"

namespace mps {

/// Writes position, velocity, pressure, kind, group and id of every non-ghost particle, plus any extra
/// per-particle scalar fields (each of length particles.size()).
void write_vtp(const std::filesystem::path& path, const Particles& particles,
               const std::map<std::string, std::span<const double>>& extra = {});

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
