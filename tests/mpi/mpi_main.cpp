// The main of the MPI test executables: MPI around GoogleTest, rank 0 reporting, the others printing only their
// failures (gtest's printer would repeat every line once per rank), and a failure on any rank failing every rank.
#include <gtest/gtest.h>
#include <mpi.h>

#include <cstdio>

#include "mpi_test.hpp"

namespace {

class FailurePrinter : public ::testing::EmptyTestEventListener {
  void OnTestPartResult(const ::testing::TestPartResult& result) override {
    if (result.failed())
      std::fprintf(stderr, "[rank %d] %s:%d: failure\n%s\n", mpi_test::rank(),
                   result.file_name() ? result.file_name() : "?", result.line_number(), result.message());
  }
};

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  ::testing::InitGoogleTest(&argc, argv);
  if (mpi_test::rank() != 0) {
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
    listeners.Append(new FailurePrinter);
  }
  int failed = RUN_ALL_TESTS();
  MPI_Allreduce(MPI_IN_PLACE, &failed, 1, MPI_INT, MPI_MAX, mpi_test::kComm);
  MPI_Finalize();
  return failed;
}
