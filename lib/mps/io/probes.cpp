#include "mps/io/probes.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "mps/core/state.hpp"
#include "mps/io/io.hpp"
#include "mps/solids/fsi.hpp"

namespace mps {

namespace {

template <int D>
bool finite_point(const Vec<D>& r) {
  return std::all_of(r.begin(), r.end(), [](double v) { return std::isfinite(v); });
}

template <int D>
void require_points(const std::string& what, const std::vector<Vec<D>>& points) {
  if (points.empty()) throw std::invalid_argument(what + ": no point to sample");
  for (std::size_t k = 0; k < points.size(); ++k)
    if (!finite_point<D>(points[k]))
      throw std::invalid_argument(what + ": point " + std::to_string(k) + " has a non-finite coordinate");
}

void require_positive(const std::string& what, const char* name, double value) {
  if (!(std::isfinite(value) && value > 0.0))
    throw std::invalid_argument(what + ": the " + std::string(name) + " must be positive and finite, got " +
                                std::to_string(value));
}

template <int D>
Vec<D> displacement(const BasicParticles<D>& s, std::size_t i, const Vec<D>& at) {
  Vec<D> d = s.position(i);
  for (std::size_t a = 0; a < D; ++a) d[a] -= at[a];
  return d;
}

// A run samples its front and levels every step: the per-axis test skips the square root for nearly every particle,
// and decides as the distance would (|d| is never below one of its components, nor is its rounding).
template <int D>
bool has_fluid_neighbour(const BasicParticles<D>& s, std::size_t i, double radius) {
  const Vec<D> r = s.position(i);
  for (std::size_t j = 0; j < s.size(); ++j) {
    if (j == i || s.kind[j] != Kind::fluid) continue;
    const Vec<D> d = displacement<D>(s, j, r);
    if (std::all_of(d.begin(), d.end(), [&](double c) { return std::abs(c) < radius; }) && norm<D>(d) < radius)
      return true;
  }
  return false;
}

// Horizontal distance from the vertical line through `at` (the last axis is vertical).
template <int D>
double from_vertical_line(const BasicParticles<D>& s, std::size_t i, const Vec<D>& at) {
  if constexpr (D == 2) return std::abs(s.x[i] - at[0]);
  else return std::hypot(s.x[i] - at[0], s.y[i] - at[1]);
}

constexpr double kSurfaceNeighbour = 2.1, kWireFloorReach = 1.5, kWireGap = 2.0;  // in l0 (LevelMethod's notes)

std::string probe_what(const std::string& name) { return "probe '" + name + "'"; }

}  // namespace

template <int D>
std::vector<Vec<D>> line_points(const Vec<D>& a, const Vec<D>& b, int n) {
  if (n < 1) throw std::invalid_argument("line_points: the count must be at least 1, got " + std::to_string(n));
  if (!finite_point<D>(a) || !finite_point<D>(b)) throw std::invalid_argument("line_points: a non-finite end");
  std::vector<Vec<D>> points;
  for (int k = 0; k < n; ++k) {
    const double t = n == 1 ? 0.5 : static_cast<double>(k) / (n - 1);
    Vec<D> r;
    for (std::size_t d = 0; d < D; ++d) r[d] = a[d] + t * (b[d] - a[d]);
    points.push_back(r);
  }
  return points;
}

template <int D>
std::vector<Vec<D>> plane_points(const Vec<D>& origin, const Vec<D>& e1, const Vec<D>& e2, int n1, int n2) {
  if (n1 < 1 || n2 < 1)
    throw std::invalid_argument("plane_points: the counts must be at least 1, got " + std::to_string(n1) + " x " +
                                std::to_string(n2));
  if (!finite_point<D>(origin) || !finite_point<D>(e1) || !finite_point<D>(e2))
    throw std::invalid_argument("plane_points: a non-finite corner or edge");
  std::vector<Vec<D>> points;
  for (int i = 0; i < n1; ++i) {
    const double s = n1 == 1 ? 0.5 : static_cast<double>(i) / (n1 - 1);
    for (int j = 0; j < n2; ++j) {
      const double t = n2 == 1 ? 0.5 : static_cast<double>(j) / (n2 - 1);
      Vec<D> r;
      for (std::size_t d = 0; d < D; ++d) r[d] = origin[d] + s * e1[d] + t * e2[d];
      points.push_back(r);
    }
  }
  return points;
}

template <int D>
double kernel_pressure(const BasicParticles<D>& s, const Vec<D>& at, const Kernel& kernel) {
  double weighted = 0.0, weights = 0.0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.kind[i] != Kind::fluid && s.kind[i] != Kind::wall) continue;
    const double w = kernel.w(norm<D>(displacement<D>(s, i, at)));
    weighted += w * s.p[i];
    weights += w;
  }
  return weights > 0.0 ? weighted / weights : 0.0;
}

template <int D>
Vec<D> kernel_velocity(const BasicParticles<D>& s, const Vec<D>& at, const Kernel& kernel) {
  Vec<D> weighted{};
  double weights = 0.0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.kind[i] != Kind::fluid) continue;
    const double w = kernel.w(norm<D>(displacement<D>(s, i, at)));
    const Vec<D> u = s.velocity(i);
    for (std::size_t d = 0; d < D; ++d) weighted[d] += w * u[d];
    weights += w;
  }
  if (weights > 0.0)
    for (double& c : weighted) c /= weights;
  return weighted;
}

template <int D>
double patch_pressure(const BasicParticles<D>& s, const BasicSensorPatch<D>& patch) {
  const auto n = static_cast<std::size_t>(patch.normal_axis);
  auto inside = [&](std::size_t i) {
    const Vec<D> d = displacement<D>(s, i, patch.centre);
    const Vec<D> r = s.position(i);
    if (patch.radius <= 0.0) return norm<D>(d) < patch.reach;
    for (std::size_t a = 0; a < D; ++a)
      if (a != n && !(r[a] > patch.lower[a] && r[a] < patch.upper[a])) return false;
    if (!(std::abs(d[n]) < patch.reach)) return false;
    if constexpr (D == 2) {
      return std::abs(d[1 - n]) <= patch.radius;
    } else {
      const std::size_t a = n == 0 ? 1 : 0, c = n == 2 ? 1 : 2;  // the wall's two axes, in order
      return std::hypot(d[a], d[c]) < patch.radius;
    }
  };
  double sum = 0.0;
  int count = 0;
  for (std::size_t i = 0; i < s.size(); ++i)
    if ((s.kind[i] == Kind::fluid || s.kind[i] == Kind::wall) && inside(i)) {
      sum += s.p[i];
      ++count;
    }
  return count > 0 ? sum / count : 0.0;
}

// Highest first until one has a neighbour, from a heap: usually the first does, and sorting every candidate was most
// of the dam break's sampling, which runs every step. Candidates of equal coordinate give the same answer.
template <int D>
std::optional<double> outermost_with_fluid_neighbour(const BasicParticles<D>& s, std::vector<std::size_t> candidates,
                                                     std::span<const double> coordinate, double radius) {
  const auto lower = [&](std::size_t a, std::size_t b) { return coordinate[a] < coordinate[b]; };
  std::make_heap(candidates.begin(), candidates.end(), lower);
  for (auto end = candidates.end(); end != candidates.begin(); --end) {
    std::pop_heap(candidates.begin(), end, lower);
    const std::size_t i = *(end - 1);
    if (has_fluid_neighbour<D>(s, i, radius)) return coordinate[i];
  }
  return std::nullopt;
}

template <int D>
double water_level(const BasicParticles<D>& s, const Vec<D>& at, double l0, LevelMethod method) {
  constexpr std::size_t up = D - 1;
  const auto& height = *s.positions()[up];
  std::vector<std::size_t> line;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (s.kind[i] == Kind::fluid && from_vertical_line<D>(s, i, at) < l0) line.push_back(i);
  if (method == LevelMethod::surface) {
    const auto top = outermost_with_fluid_neighbour<D>(s, std::move(line), height, kSurfaceNeighbour * l0);
    return top ? *top + 0.5 * l0 : 0.0;
  }
  std::vector<double> heights;
  for (std::size_t i : line) heights.push_back(height[i] - at[up]);
  std::sort(heights.begin(), heights.end());
  if (heights.empty() || heights.front() > kWireFloorReach * l0) return 0.0;
  double top = heights.front();
  for (double h : heights) {
    if (h - top > kWireGap * l0) break;
    top = h;
  }
  return top + 0.5 * l0 + at[up];
}

template <int D>
BasicProbe<D> pressure_probe(std::string name, std::vector<Vec<D>> points, const Kernel& kernel) {
  require_points<D>(probe_what(name), points);
  require_positive(probe_what(name), "kernel radius", kernel.re);
  BasicProbe<D> probe{std::move(name), "pressure", std::move(points), 1, {}};
  probe.read = [at = probe.points, kernel](const BasicParticles<D>& s, double* values) {
    for (const Vec<D>& r : at) *values++ = kernel_pressure<D>(s, r, kernel);
  };
  return probe;
}

template <int D>
BasicProbe<D> velocity_probe(std::string name, std::vector<Vec<D>> points, const Kernel& kernel) {
  require_points<D>(probe_what(name), points);
  require_positive(probe_what(name), "kernel radius", kernel.re);
  BasicProbe<D> probe{std::move(name), "velocity", std::move(points), D, {}};
  probe.read = [at = probe.points, kernel](const BasicParticles<D>& s, double* values) {
    for (const Vec<D>& r : at)
      for (double u : kernel_velocity<D>(s, r, kernel)) *values++ = u;
  };
  return probe;
}

template <int D>
BasicProbe<D> patch_probe(std::string name, std::vector<Vec<D>> points, const BasicSensorPatch<D>& patch) {
  const std::string what = probe_what(name);
  require_points<D>(what, points);
  require_positive(what, "patch's reach", patch.reach);
  if (!(std::isfinite(patch.radius) && patch.radius >= 0.0))
    throw std::invalid_argument(what + ": the patch's radius must be finite and not negative");
  if (patch.normal_axis < 0 || patch.normal_axis >= D)
    throw std::invalid_argument(what + ": the patch's normal axis must be 0.." + std::to_string(D - 1) + ", got " +
                                std::to_string(patch.normal_axis));
  BasicProbe<D> probe{std::move(name), "pressure", std::move(points), 1, {}};
  probe.read = [at = probe.points, patch](const BasicParticles<D>& s, double* values) {
    BasicSensorPatch<D> here = patch;
    for (const Vec<D>& r : at) {
      here.centre = r;
      *values++ = patch_pressure<D>(s, here);
    }
  };
  return probe;
}

template <int D>
BasicProbe<D> level_probe(std::string name, std::vector<Vec<D>> points, double l0, LevelMethod method) {
  require_points<D>(probe_what(name), points);
  require_positive(probe_what(name), "spacing l0", l0);
  BasicProbe<D> probe{std::move(name), "level", std::move(points), 1, {}};
  probe.read = [at = probe.points, l0, method](const BasicParticles<D>& s, double* values) {
    for (const Vec<D>& r : at) *values++ = water_level<D>(s, r, l0, method);
  };
  return probe;
}

Probe force_probe(std::string name, const WallForce& force) {
  Probe probe{std::move(name), "force", {Vec<2>{0.0, 0.0}}, 2, {}};
  probe.read = [&force](const Particles&, double* values) {
    const std::array<double, 2> f = force.force();
    values[0] = f[0];
    values[1] = f[1];
  };
  return probe;
}

Probe displacement_probe(std::string name, std::vector<Vec<2>> points, const ElasticSolid& solid) {
  require_points<2>(probe_what(name), points);
  Probe probe{std::move(name), "displacement", std::move(points), 2, {}};
  probe.read = [at = probe.points, &solid](const Particles&, double* values) {
    for (const Vec<2>& r : at)
      for (double u : solid.displacement_at(r[0], r[1])) *values++ = u;
  };
  return probe;
}

Probe displacement_probe(std::string name, std::vector<Vec<2>> points, const ElasticStructure& body) {
  return displacement_probe(std::move(name), std::move(points), body.solid());
}

template <int D>
BasicProbeSeries<D>::BasicProbeSeries(double interval) : interval_(interval) {
  if (!(std::isfinite(interval) && interval >= 0.0))
    throw std::invalid_argument("probes: the sampling interval must be finite and not negative, got " +
                                std::to_string(interval));
}

template <int D>
void BasicProbeSeries<D>::add(BasicProbe<D> probe) {
  const std::string what = probe_what(probe.name);
  const bool valid_name =
      !probe.name.empty() && std::all_of(probe.name.begin(), probe.name.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
      });
  if (!valid_name) throw std::invalid_argument(what + ": a name is letters, digits, '_', '-' and '.'");
  if (probe.name == "time") throw std::invalid_argument(what + ": 'time' is the series' first column");
  for (const BasicProbe<D>& p : probes_)
    if (p.name == probe.name) throw std::invalid_argument(what + ": the name is taken by another probe");
  if (!rows_.empty()) throw std::invalid_argument(what + ": probes are added before the first sample");
  require_points<D>(what, probe.points);
  if (probe.components < 1) throw std::invalid_argument(what + ": components must be at least 1");
  if (!probe.read) throw std::invalid_argument(what + ": no read function");
  probes_.push_back(std::move(probe));
}

template <int D>
bool BasicProbeSeries<D>::sample(double time, const BasicParticles<D>& particles, double early) {
  if (!std::isfinite(time)) throw std::invalid_argument("probes: a non-finite time");
  if (!(std::isfinite(early) && early >= 0.0))
    throw std::invalid_argument("probes: how early a sample may be must be finite and not negative");
  const double slack = std::max(1e-9 * interval_, early);
  if (!rows_.empty() && time < rows_.back().front())
    throw std::invalid_argument("probes: time " + std::to_string(time) + " is before the last sample's");
  if (rows_.empty() && marks_passed_ == 0) {
    first_time_ = time;
  } else if (interval_ > 0.0) {
    const double next = first_time_ + static_cast<double>(marks_passed_) * interval_;
    if (time < next - slack) return false;
  }
  std::vector<double> row{time};
  for (const BasicProbe<D>& probe : probes_) {
    const std::size_t first = row.size();
    row.resize(first + probe.points.size() * static_cast<std::size_t>(probe.components));
    probe.read(particles, row.data() + first);
  }
  rows_.push_back(std::move(row));
  // The next mark after `time`: a step longer than the interval skips the marks it passed.
  ++marks_passed_;
  if (interval_ > 0.0)
    while (first_time_ + static_cast<double>(marks_passed_) * interval_ <= time + slack) ++marks_passed_;
  return true;
}

template <int D>
std::vector<std::string> BasicProbeSeries<D>::columns() const {
  static constexpr const char* axes[3] = {".x", ".y", ".z"};
  std::vector<std::string> names{"time"};
  for (const BasicProbe<D>& probe : probes_)
    for (std::size_t k = 0; k < probe.points.size(); ++k) {
      std::string point = probe.name;
      if (probe.points.size() > 1) point.append("[").append(std::to_string(k)).append("]");
      if (probe.components == 1) {
        names.push_back(point);
        continue;
      }
      for (int c = 0; c < probe.components; ++c) {
        std::string column = point;
        if (probe.components <= 3) column.append(axes[c]);
        else column.append(".").append(std::to_string(c));
        names.push_back(std::move(column));
      }
    }
  return names;
}

template <int D>
void BasicProbeSeries<D>::write_csv(const std::filesystem::path& path) const {
  const std::vector<std::string> header = columns();
  std::vector<std::vector<double>> by_column(header.size());
  for (const std::vector<double>& row : rows_)
    for (std::size_t c = 0; c < row.size(); ++c) by_column[c].push_back(row[c]);
  mps::write_csv(path, header, by_column);
}

template <int D>
nlohmann::json BasicProbeSeries<D>::describe() const {
  nlohmann::json probes = nlohmann::json::array();
  for (const BasicProbe<D>& probe : probes_)
    probes.push_back({{"name", probe.name}, {"quantity", probe.quantity}, {"points_m", probe.points},
                      {"component_count", probe.components}});
  return {{"interval_s", interval_}, {"probes", probes}, {"columns", columns()}};
}

template <int D>
nlohmann::json BasicProbeSeries<D>::save_state() const {
  std::vector<double> values;
  for (const std::vector<double>& row : rows_) values.insert(values.end(), row.begin(), row.end());
  return {{"columns", columns()}, {"values", pack_array(values)}, {"first_time", first_time_},
          {"marks_passed", marks_passed_}};
}

template <int D>
void BasicProbeSeries<D>::restore_state(const nlohmann::json& state) {
  const std::vector<std::string> names = columns();
  if (state_part(state, "columns") != nlohmann::json(names))
    throw std::runtime_error("checkpoint: its probes' columns differ from this run's (other probes?)");
  std::vector<double> values;
  unpack_array(state, "values", values);
  if (values.size() % names.size() != 0)
    throw std::runtime_error("checkpoint: the probes' values are not whole rows");
  const double first_time = unpack_value<double>(state, "first_time");
  const auto marks = unpack_value<long long>(state, "marks_passed");
  std::vector<std::vector<double>> rows;
  for (std::size_t k = 0; k < values.size(); k += names.size())
    rows.emplace_back(values.begin() + static_cast<std::ptrdiff_t>(k),
                      values.begin() + static_cast<std::ptrdiff_t>(k + names.size()));
  rows_ = std::move(rows);
  first_time_ = first_time;
  marks_passed_ = marks;
}

#define MPS_PROBES(D)                                                                                                 \
  template std::vector<Vec<D>> line_points<D>(const Vec<D>&, const Vec<D>&, int);                                     \
  template std::vector<Vec<D>> plane_points<D>(const Vec<D>&, const Vec<D>&, const Vec<D>&, int, int);                \
  template double kernel_pressure<D>(const BasicParticles<D>&, const Vec<D>&, const Kernel&);                         \
  template Vec<D> kernel_velocity<D>(const BasicParticles<D>&, const Vec<D>&, const Kernel&);                         \
  template double patch_pressure<D>(const BasicParticles<D>&, const BasicSensorPatch<D>&);                            \
  template double water_level<D>(const BasicParticles<D>&, const Vec<D>&, double, LevelMethod);                       \
  template std::optional<double> outermost_with_fluid_neighbour<D>(const BasicParticles<D>&, std::vector<std::size_t>, \
                                                                   std::span<const double>, double);                 \
  template BasicProbe<D> pressure_probe<D>(std::string, std::vector<Vec<D>>, const Kernel&);                          \
  template BasicProbe<D> velocity_probe<D>(std::string, std::vector<Vec<D>>, const Kernel&);                          \
  template BasicProbe<D> patch_probe<D>(std::string, std::vector<Vec<D>>, const BasicSensorPatch<D>&);                \
  template BasicProbe<D> level_probe<D>(std::string, std::vector<Vec<D>>, double, LevelMethod);                       \
  template class BasicProbeSeries<D>;
MPS_PROBES(2)
MPS_PROBES(3)
#undef MPS_PROBES

}  // namespace mps
