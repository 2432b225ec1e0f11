#pragma once
// An app started by mpirun runs its scene on the ranks (an mps::RankExchange, docs/scaling.md); started
// plainly, or on one rank, it is the serial app and never starts MPI itself.
#include <CLI/CLI.hpp>
#include <mpi.h>
#include <omp.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>

#include "checks.hpp"

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
    // Apart from the library's: an agreement on failure must never match one of the step's collectives.
    MPI_Comm_dup(MPI_COMM_WORLD, &failures_);
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
  // Called by a rank that met an error. True when every rank met one and came here within a few seconds (a bad
  // option, a file no rank can read, the guard, which stops all ranks at one step): they may still gather and
  // report together. False when the others did not come: they wait in an exchange with this rank (an error of its
  // own, such as a component's or its output's), so it must end the job alone (end_alone). Serially: true.
  [[nodiscard]] bool every_rank_failed() const {
    if (!distributed()) return true;
    int failed = 1, count = 0;
    MPI_Request request = MPI_REQUEST_NULL;
    MPI_Iallreduce(&failed, &count, 1, MPI_INT, MPI_SUM, failures_, &request);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(kWaitSeconds);
    for (int done = 0; !done; std::this_thread::sleep_for(std::chrono::milliseconds(1))) {
      MPI_Test(&request, &done, MPI_STATUS_IGNORE);
      if (!done && std::chrono::steady_clock::now() > deadline) return false;
    }
    return true;
  }

  // After every_rank_failed(): rank 0 says its error; another rank says its own only if it differs. Collective.
  void say_error(const std::string& message) const {
    std::string first = message;
    if (distributed()) {
      int length = static_cast<int>(first.size());
      MPI_Bcast(&length, 1, MPI_INT, 0, failures_);
      first.resize(static_cast<std::size_t>(length));
      MPI_Bcast(first.data(), length, MPI_CHAR, 0, failures_);
    }
    if (root()) std::cerr << "error: " << message << "\n";
    else if (message != first) std::cerr << "error (rank " << rank_ << "): " << message << "\n";
  }

  // An error of this rank alone: says it, naming the rank, lets `record` keep what it can (a summary), and ends
  // every rank (MPI_Abort), so that no rank waits for it.
  [[noreturn]] void end_alone(const std::string& message, const std::function<void()>& record = {}) const {
    std::cerr << "error (rank " << rank_ << " of " << size_ << ", alone: ending every rank): " << message << "\n";
    if (record) {
      try {
        record();
      } catch (const std::exception& e) {
        std::cerr << "error: the failure could not be recorded: " << e.what() << "\n";
      }
    }
    std::cerr.flush();
    MPI_Abort(MPI_COMM_WORLD, 1);
    std::exit(1);
  }

 private:
  static bool launched_by_mpirun() {
    for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE"})
      if (std::getenv(name) != nullptr) return true;
    return false;
  }
  static constexpr int kWaitSeconds = 3;
  int rank_ = 0, size_ = 1;
  MPI_Comm failures_ = MPI_COMM_NULL;
};

// The apps whose scenes run on one process: under mpirun each rank would run the whole scene into the same files.
inline void require_one_process(const AppRanks& ranks, const std::string& app) {
  if (!ranks.distributed()) return;
  if (ranks.root())
    std::fprintf(stderr, "error: %s runs on one process, not on %d MPI ranks; run it without mpirun (dambreak and "
                 "poiseuille run on ranks: docs/scaling.md)\n", app.c_str(), ranks.size());
  std::exit(1);
}

// parse_options on ranks: every rank finds the same fault in the options; rank 0 says it (and prints --help).
inline std::optional<int> parse_options(CLI::App& app, const AppRanks& ranks, int argc, char** argv) {
  return parse_options(app, argc, argv, !ranks.root());
}
