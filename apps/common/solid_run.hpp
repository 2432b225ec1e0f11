#pragma once
// An elastic body stepped on its own (mps::ElasticSolid), as `structure` runs its scenes and sparsemps-run a scene file
// of one [[elastic]] body without fluid: frames, displacement probes and energies at the probes' samples,
// checkpoints and the progress line. One loop for both, so that a scene file gives its app's numbers.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "checkpoints.hpp"
#include "console.hpp"
#include "mps/core/particles.hpp"
#include "mps/io/io.hpp"
#include "mps/io/probes.hpp"
#include "mps/solids/elastic.hpp"

// The solid as particles for a frame: moving ones as fluid, clamped ones as wall, coloured by the mean normal stress
// of the first Piola-Kirchhoff tensor as a "pressure".
inline mps::Particles solid_frame_particles(const mps::ElasticSolid& s) {
  mps::Particles p;
  p.reserve(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    const bool moving = i < s.moving();
    p.add(s.x()[i], s.y()[i], moving ? mps::Kind::fluid : mps::Kind::wall, 0, s.u()[i], s.v()[i]);
    p.p.back() = moving ? -0.5 * (s.stress()[0][i] + s.stress()[3][i]) : 0.0;
  }
  return p;
}

// What a solid's run records: its displacement probes (mps::displacement_probe's readings, by
// ElasticSolid::displacement_at) and, at each of their samples, the energies (energy.csv's columns).
struct SolidSamples {
  mps::ProbeSeries probes;
  std::vector<double> t, ek, es, eg, et;

  explicit SolidSamples(mps::ProbeSeries series) : probes(std::move(series)) {}
  // Samples at the step nearest each of the probes' marks; returns whether it did.
  bool sample(const mps::ElasticSolid& solid) {
    static const mps::Particles none;  // displacement probes read the solid, not particles
    if (!probes.sample(solid.time(), none, 0.5 * solid.dt())) return false;
    const mps::ElasticEnergy& e = solid.energy();
    t.push_back(solid.time());
    ek.push_back(e.kinetic);
    es.push_back(e.strain);
    eg.push_back(e.gravity);
    et.push_back(e.total());
    return true;
  }
  // The largest |E(t) - E(0)| over the largest kinetic + strain energy of the samples (0 before any motion).
  [[nodiscard]] double energy_drift() const {
    double drift = 0, largest = 0;
    for (std::size_t k = 0; k < t.size(); ++k) {
      drift = std::max(drift, std::abs(et[k] - et[0]));
      largest = std::max(largest, ek[k] + es[k]);
    }
    return largest > 0 ? drift / largest : 0.0;
  }
  void write_energy(const std::filesystem::path& path) const {
    mps::write_csv(path, {"t", "kinetic", "strain", "gravity", "total"}, {t, ek, es, eg, et});
  }
  [[nodiscard]] nlohmann::json save_state() const {
    return {{"probes", probes.save_state()}, {"t", mps::pack_array(t)},  {"ek", mps::pack_array(ek)},
            {"es", mps::pack_array(es)},     {"eg", mps::pack_array(eg)}, {"et", mps::pack_array(et)}};
  }
  void restore_state(const nlohmann::json& state) {
    probes.restore_state(state.at("probes"));
    for (auto [name, series] : {std::pair{"t", &t}, {"ek", &ek}, {"es", &es}, {"eg", &eg}, {"et", &et}})
      mps::unpack_array(state, name, *series);
  }
};

// Samples the start, steps to `end_time` sampling after every step, writing `frames` frames (<name>.pvd, frames/
// <name>_NNNN.vtp), a line every tenth of the run (the first probe's first reading in it) and checkpoints when due;
// returns the seconds from the first step to the last. A SimulationError goes to the caller after the last good
// state's checkpoint, and so does RunStopped once a signal's checkpoint is written. A restart continues from its
// checkpoint.
inline double run_solid(mps::ElasticSolid& solid, double end_time, int frames, const std::filesystem::path& dir,
                        const std::string& name, SolidSamples& s, Progress& progress, Checkpoints& checkpoints) {
  mps::PvdSeries series(dir / (name + ".pvd"));
  int next_frame = 0;
  auto frame = [&] {
    char file[96];
    std::snprintf(file, sizeof file, "frames/%s_%04d.vtp", name.c_str(), next_frame++);
    mps::write_vtp(dir / file, solid_frame_particles(solid), solid.time());
    series.add(solid.time(), dir / file);
  };
  const double frame_interval = frames > 0 ? end_time / frames : 2 * end_time;
  double next_report = end_time / 10;
  auto save = [&]() -> nlohmann::json {
    return {{"samples", s.save_state()}, {"next_frame", next_frame}, {"next_report", next_report},
            {"frames", series.save_state()}};
  };
  auto save_solid = [&] { return solid.save_state(); };
  if (const nlohmann::json* restart = checkpoints.restart()) {
    solid.restore_state(restart->at("simulation"));
    const nlohmann::json& saved = checkpoints.scene();
    s.restore_state(saved.at("samples"));
    next_frame = saved.at("next_frame").get<int>();
    next_report = saved.at("next_report").get<double>();
    series.restore_state(saved.at("frames"));
    std::printf("restarted at step %d, t = %.4g s\n", solid.steps(), solid.time());
  } else {
    s.sample(solid);
    if (frames > 0) frame();
  }
  const auto stepping_start = std::chrono::steady_clock::now();
  while (solid.time() < end_time - 0.5 * solid.dt()) {
    try {
      solid.step();
    } catch (const mps::SimulationError&) {
      checkpoints.write(save_solid, save);  // the last good state, to restart from
      throw;
    }
    progress.update(solid.time(), solid.steps());
    s.sample(solid);
    if (frames > 0 && solid.time() >= next_frame * frame_interval - 0.5 * solid.dt()) frame();
    if (solid.time() >= next_report) {
      progress.clear();
      std::printf("t = %.3f s  step %d", solid.time(), solid.steps());
      if (!s.probes.rows().empty() && s.probes.rows().back().size() >= 3)
        std::printf("  %s (%.5f, %.5f) m", s.probes.probes().front().name.c_str(), s.probes.rows().back()[1],
                    s.probes.rows().back()[2]);
      std::printf("  energy: kinetic %.4g strain %.4g gravity %.4g total %.6g J/m\n", s.ek.back(), s.es.back(),
                  s.eg.back(), s.et.back());
      next_report += end_time / 10;
    }
    checkpoints.after_step(solid.steps(), solid.time(), true, false, save_solid, save, progress);
  }
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - stepping_start).count();
}
