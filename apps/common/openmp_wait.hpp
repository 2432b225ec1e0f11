#pragma once
// Two OpenMP threads must not run slower than one when another program shares the machine. libgomp's threads spin at
// every barrier; beside a busy process a spinning thread burns the time slice its partner needs, and the channel at
// 1e5 particles ran 1.4x slower on two threads than on one (docs/benchmarks.md). Sleeping threads cost little when
// the library keeps small loops on one thread. libgomp reads OMP_WAIT_POLICY once, when it loads, so an app that
// wants the passive policy sets it and starts itself again; a policy the user chose is left alone.
#include <omp.h>
#include <unistd.h>

#include <cstdlib>

inline void prefer_passive_openmp_wait(char** argv) {
  if (std::getenv("OMP_WAIT_POLICY") != nullptr || omp_get_max_threads() < 2) return;
  if (setenv("OMP_WAIT_POLICY", "passive", 1) != 0) return;
  execv("/proc/self/exe", argv);  // returns only if it failed: run on with libgomp's default policy
  unsetenv("OMP_WAIT_POLICY");
}
