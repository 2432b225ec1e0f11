// A main for MPS-Basic (github.com/MPS-Basic/MPS-Basic) built for measurement by bench/mps_basic.py: its own main
// parses options with p-ranav/argparse, which Debian does not package; this one takes the same two paths.
#include <filesystem>
#include <iostream>

#include "simulation.hpp"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: mps-basic SETTINGS.yml OUTPUT_DIR\n";
    return 2;
  }
  std::filesystem::path settings(argv[1]), output(argv[2]);
  std::filesystem::create_directories(output);
  Simulation simulation(settings, output);
  simulation.run();
  return 0;
}
