// Writes frames of known particles for tests/read_frames_vtk.py: each frame NAME.vtp beside NAME.json, which holds
// every value written as a hexadecimal float (exact), so that VTK's reading of the frame can be compared bit for bit.
//   write_known_frames OUT_DIR
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mps/io/io.hpp"

namespace {

std::string hex(double v) {
  char s[40];
  std::snprintf(s, sizeof s, "%a", v);
  return s;
}

nlohmann::json hex_all(const std::vector<double>& v) {
  nlohmann::json out = nlohmann::json::array();
  for (double d : v) out.push_back(hex(d));
  return out;
}

// n particles with values a text format or a careless cast would change (signed zero, subnormals, thirds, huge
// exponents); every `ghost_every`-th one a ghost (0: none), which the frame must leave out.
void write_case(const std::filesystem::path& dir, const std::string& name, std::size_t n, std::size_t ghost_every,
                double time) {
  mps::Particles p;
  std::vector<double> density(n), fx(n), fy(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double k = static_cast<double>(i);
    const auto kind = ghost_every > 0 && i % ghost_every == 0 ? mps::Kind::ghost : static_cast<mps::Kind>(i % 3);
    p.add(std::cos(k) * 1e4, -1.0 / (k + 3.0), kind, static_cast<int>(i % 5) - 2, i == 1 ? -0.0 : k * 4.9e-324,
          std::ldexp(1.0 + k / 3.0, static_cast<int>(i % 1500) - 750));
    p.p.back() = k / 7.0 - 300.0;
    p.id.back() = static_cast<int>(3 * n - i);
    density[i] = 1.0 / (k + 0.25);
    fx[i] = -k * 1e-200;
    fy[i] = std::sqrt(k);
  }
  mps::write_vtp(dir / (name + ".vtp"), p, time, {.scalars = {{"density", density}}, .vectors = {{"force", {fx, fy}}}});
  nlohmann::json expected = {{"time", hex(time)}};
  std::vector<double> points, velocity, force, pressure, dens;
  std::vector<int> kind, group, id;
  for (std::size_t i = 0; i < n; ++i) {
    if (p.kind[i] == mps::Kind::ghost) continue;
    points.insert(points.end(), {p.x[i], p.y[i], 0.0});
    velocity.insert(velocity.end(), {p.u[i], p.v[i], 0.0});
    force.insert(force.end(), {fx[i], fy[i], 0.0});
    pressure.push_back(p.p[i]);
    dens.push_back(density[i]);
    kind.push_back(static_cast<int>(p.kind[i]));
    group.push_back(p.group[i]);
    id.push_back(p.id[i]);
  }
  expected["points"] = hex_all(points);
  expected["vectors"] = {{"velocity", hex_all(velocity)}, {"force", hex_all(force)}};
  expected["scalars"] = {{"pressure", hex_all(pressure)}, {"density", hex_all(dens)}};
  expected["integers"] = {{"kind", kind}, {"group", group}, {"id", id}};
  mps::write_json(dir / (name + ".json"), expected);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: write_known_frames OUT_DIR\n");
    return 2;
  }
  const std::filesystem::path dir = argv[1];
  write_case(dir, "partial_blocks", 5001, 1000, 0.1 + 0.2);  // 4995 points: arrays end in a partial 32 KiB block
  write_case(dir, "whole_blocks", 4096, 0, 1.0 / 3.0);       // every array a whole number of blocks
  write_case(dir, "no_points", 4, 1, 7.0);                   // all ghosts: an empty frame that still has its time
  return 0;
}
