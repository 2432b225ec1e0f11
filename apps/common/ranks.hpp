#pragma once
// An app started by mpirun runs its scene on the ranks (mps::DistributedSimulation, docs/scaling.md); started
// plainly, or on one rank, it is the serial app and never starts MPI itself.
#include <mpi.h>
#include <omp.h>

#include <cstdio>
#include <cstdlib>
#include <string>

class AppRanks {
 public:
  AppRanks(int* argc, char*** argv) {
    if (!launched_by_mpirun()) return;
    int initialised = 0;
    MPI_Initialized(&initialised);
    if (!initialised) {
      MPI_Init(argc, argv);
      // Registered before hypre's handler (made at the first solver), so it runs after hypre has finalised.
      std::atexit([] {
        int finalised = 0;
        MPI_Finalized(&finalised);
        if (!finalised) MPI_Finalize();
      });
    }
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
    // One console: the other ranks' output would repeat rank 0's. Their errors still reach stderr.
    if (rank_ != 0 && !std::freopen("/dev/null", "w", stdout)) std::perror("stdout to /dev/null");
    // Ranks are the parallelism: two OpenMP threads per rank on two cores spin against each other.
    if (size_ > 1 && std::getenv("OMP_NUM_THREADS") == nullptr) omp_set_num_threads(1);
  }

  [[nodiscard]] int rank() const { return rank_; }
  [[nodiscard]] int size() const { return size_; }
  [[nodiscard]] bool root() const { return rank_ == 0; }
  [[nodiscard]] bool distributed() const { return size_ > 1; }
  [[nodiscard]] int comm() const { return static_cast<int>(MPI_Comm_c2f(MPI_COMM_WORLD)); }  // the library's handle
  // An error met by some ranks only would leave the others waiting in their next exchange: stop them all.
  [[noreturn]] void stop_all(int status) const {
    if (distributed()) MPI_Abort(MPI_COMM_WORLD, status);
    std::exit(status);
  }

 private:
  static bool launched_by_mpirun() {
    for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE"})
      if (std::getenv(name) != nullptr) return true;
    return false;
  }
  int rank_ = 0, size_ = 1;
};

// The apps whose scenes run on one process: under mpirun each rank would run the whole scene into the same files.
inline void require_one_process(const AppRanks& ranks, const std::string& app) {
  if (!ranks.distributed()) return;
  if (ranks.root())
    std::fprintf(stderr, "error: %s runs on one process, not on %d MPI ranks; run it without mpirun (dambreak and "
                 "poiseuille run on ranks: docs/scaling.md)\n", app.c_str(), ranks.size());
  std::exit(1);
}
