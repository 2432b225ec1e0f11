#pragma once
// What the distributed benchmarks share: reductions over the ranks, the machine's load at the start, and a main that
// runs the bench between MPI_Init and MPI_Finalize.
#include <mpi.h>

#include <exception>
#include <fstream>
#include <iostream>
#include <string>

template <class T>
T reduce(MPI_Comm comm, T value, MPI_Op op, MPI_Datatype type) {
  MPI_Allreduce(MPI_IN_PLACE, &value, 1, type, op, comm);
  return value;
}

// The 1-minute load average (-1 if unreadable): other jobs on the cores change what P ranks can gain.
inline double load_average() {
  double load = -1.0;
  std::ifstream("/proc/loadavg") >> load;
  return load;
}

// run(argc, argv) holds every MPI and hypre object, so that they are gone before MPI_Finalize.
template <class Run>
int run_under_mpi(int argc, char** argv, const std::string& name, Run run) {
  MPI_Init(&argc, &argv);
  int status = 0;
  try {
    status = run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << name << ": " << e.what() << '\n';
    status = 1;
  }
  MPI_Finalize();
  return status;
}
