#pragma once
// What the MPI tests share: the communicator they run on, their rank, the rank count and the communicator's handle as
// the library takes it (MPI_Comm_c2f).
#include <mpi.h>

namespace mpi_test {

inline const MPI_Comm kComm = MPI_COMM_WORLD;

inline int rank() {
  int r = 0;
  MPI_Comm_rank(kComm, &r);
  return r;
}
inline int ranks() {
  int s = 1;
  MPI_Comm_size(kComm, &s);
  return s;
}
inline int comm() { return static_cast<int>(MPI_Comm_c2f(kComm)); }

}  // namespace mpi_test
