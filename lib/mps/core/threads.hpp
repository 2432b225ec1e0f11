#pragma once
// Private to the library's .cpp files: when a loop is worth a second thread.
#include <cstddef>

namespace mps::detail {

// A loop over fewer items runs on the calling thread alone: a sleeping thread takes tens of microseconds to wake,
// and on a loaded machine the barrier waits a time slice for a descheduled one (docs/benchmarks.md, threads).
inline constexpr std::ptrdiff_t kMinParallelItems = 2048;

inline bool worth_threads(std::ptrdiff_t items) { return items >= kMinParallelItems; }

}  // namespace mps::detail
