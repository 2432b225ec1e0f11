#pragma once
/// \file
/// Input and output: VTK XML PolyData frames (.vtp, binary and zlib-compressed) and their series (.pvd) for ParaView,
/// CSV tables, JSON summaries, particle files (CSV) a scene can start from, and Matrix Market for exporting any PPE to
/// other solvers. Every file is written to a temporary name and renamed into place, so a run that stops leaves its
/// last complete outputs, never a half-written file.
#include <array>
#include <filesystem>
#include <map>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

#include "mps/core/csr.hpp"
#include "mps/core/particles.hpp"
#include "mps/step/config.hpp"

namespace mps {

/// Throws std::invalid_argument if `path` is empty or exists and is not a regular file (a directory, a device, a
/// FIFO, a socket): every writer below checks it, and an app can check its output paths before a run.
void require_file_path(const std::filesystem::path& path);
/// Throws std::invalid_argument if `path` is empty or exists and is not a directory (an app's output folder).
void require_directory_path(const std::filesystem::path& path);

/// Per-particle fields of a frame beyond the particles' own, each of length particles.size().
template <int D>
struct BasicPointFields {
  std::map<std::string, std::span<const double>> scalars{};  ///< one value per particle, by name
  /// D components per particle, by name: written as 3-component arrays (z = 0 in 2-D), so ParaView treats them as
  /// vectors
  std::map<std::string, std::array<std::span<const double>, D>> vectors{};
};
using PointFields = BasicPointFields<2>;  ///< a 2-D frame's extra fields

/// A frame at simulation time `time`: position, velocity, pressure, kind, group and id of every non-ghost particle,
/// plus `extra`, as VTK XML PolyData with binary appended, zlib-compressed arrays (VTK's own block layout, UInt64
/// headers), and `time` as the field-data array TIME. A failed compression throws, naming the array and the file.
/// Points and vectors have three components, z = 0 in 2-D.
template <int D>
void write_vtp(const std::filesystem::path& path, const BasicParticles<D>& particles, double time,
               const std::type_identity_t<BasicPointFields<D>>& extra = {});

/// A time series of frames: each add() rewrites the .pvd index, so it is valid after every frame.
class PvdSeries {
 public:
  explicit PvdSeries(std::filesystem::path pvd_path);  ///< a series written to pvd_path, empty until the first add()
  /// Adds the frame at frame_path for `time` (stored relative to the .pvd, so the folder can move as a whole) and
  /// rewrites the index.
  void add(double time, const std::filesystem::path& frame_path);
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }  ///< the .pvd file
  /// @{ The frames listed so far, for a checkpoint; restore_state() takes them back and rewrites the index.
  [[nodiscard]] nlohmann::json save_state() const;
  void restore_state(const nlohmann::json& state);
  /// @}

 private:
  void write() const;
  std::filesystem::path path_;
  std::vector<std::pair<double, std::string>> frames_;
};

/// One column per name; all columns of equal length.
void write_csv(const std::filesystem::path& path, const std::vector<std::string>& header,
               const std::vector<std::vector<double>>& columns);

void write_json(const std::filesystem::path& path, const nlohmann::json& value);  ///< indented, as a whole file
/// A checkpoint file (docs/restart.md): `state` (Simulation::checkpoint() and whatever else the caller adds) as
/// CBOR (RFC 8949), its arrays as byte strings, under a header naming the format and its version. Written through a
/// temporary file renamed over the target, so that a stop mid-write leaves the previous checkpoint whole.
void write_checkpoint(const std::filesystem::path& path, const nlohmann::json& state);
/// The state of a checkpoint file; throws std::runtime_error naming the file and what is wrong with it (missing,
/// not a checkpoint, truncated or damaged, another format version).
nlohmann::json read_checkpoint(const std::filesystem::path& path);
/// Every field of the config from its schema (for_each_parameter), each key ending in its unit as the summaries'
/// naming rule has it ("l0_m", "radius_density_l0", "nu_m2_per_s", "gamma"): what an app's summary records. The guard's
/// max_speed, infinite when off, is written "max_speed": "off".
nlohmann::json config_json(const SimulationConfig& config);
void write_text(const std::filesystem::path& path, const std::string& text);      ///< the text as a whole file

/// Matrix Market "coordinate real general", 17 significant digits, so a read returns the same matrix.
void write_matrix_market(const std::filesystem::path& path, const CsrMatrix& a);
/// With comment lines after the banner (each prefixed "% "); symmetric: only the lower triangle is written, and a
/// matrix that is not exactly symmetric is refused.
void write_matrix_market(const std::filesystem::path& path, const CsrMatrix& a, const std::vector<std::string>& comments,
                         bool symmetric);
void write_matrix_market(const std::filesystem::path& path, std::span<const double> vector);  ///< "array real general"
/// Coordinate, general or symmetric; a file whose name ends in .gz is read through zlib (gzip), so the compressed
/// sample PPEs of data/ppe/ read as they are.
CsrMatrix read_matrix_market(const std::filesystem::path& path);
/// "array real" with one column (gzip-compressed if the name ends in .gz); refuses anything else, naming the line.
std::vector<double> read_matrix_market_vector(const std::filesystem::path& path);

/// Particles from a CSV file (docs/particle-files.md), in the file's order, each with the next id. Lines starting with
/// '#' and blank lines are skipped; the first other line is the header, naming the columns in any order: `x`, `y`
/// [m] and `kind` (`fluid`, `wall`, `dummy`, or 0, 1, 2) are required, `u`, `v` [m/s], `p` [Pa] and `group` (a whole
/// number) optional, 0 when absent; in 3-D (D = 3) `z` is required too and `w` optional, in 2-D both are refused. Throws std::runtime_error naming the file, the line and what to change for: an
/// unknown, repeated or missing column, a row with the wrong number of fields, a value that is not a finite number, an
/// unknown kind or a ghost, no particles, and two particles closer than half the file's spacing (median_spacing).
template <int D = 2>
BasicParticles<D> read_particles_csv(const std::filesystem::path& path);
/// Writes the non-ghost particles as read_particles_csv reads them: comment lines first (each prefixed "# "), then
/// the header `x,y,kind,u,v,p,group` (3-D: `x,y,z,kind,u,v,w,p,group`) and one row per particle, 17 significant digits,
/// so a read gives every bit back.
template <int D>
void write_particles_csv(const std::filesystem::path& path, const BasicParticles<D>& particles,
                         const std::vector<std::string>& comments = {});
/// A frame as write_vtp writes it, read back as particles: positions, velocity, pressure, kind and group, bit for bit,
/// in the frame's order, each with the next id; `time`, if not null, receives the frame's TIME (NaN without one). Reads
/// VTK XML PolyData with one piece and raw appended data, zlib-compressed or not, with UInt32 or UInt64 headers, in the
/// machine's byte order, as VTK's own writer makes it too. Throws std::runtime_error naming the file and the reason:
/// another encoding, a missing array, a value that is not finite, a kind that is not fluid, wall or dummy, data that
/// run past the file's end or do not decompress; read as 2-D, a frame with a point off z = 0.
template <int D = 2>
BasicParticles<D> read_vtp(const std::filesystem::path& path, double* time = nullptr);
/// The median distance from a non-ghost particle to its nearest other one [m]: the spacing of a lattice, whatever its
/// shape (a cell grid, O(N)). Infinity for fewer than two particles.
template <int D>
double median_spacing(const BasicParticles<D>& particles);

}  // namespace mps
