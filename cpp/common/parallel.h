// A parallel loop over [0, n) on `threads` std::threads (work handed out one index at a
// time): the tools' per-image and per-pair work. The first exception a body throws stops
// the loop and is rethrown in the caller once every thread has joined.
#pragma once

#include <functional>

namespace mound {

void ParallelFor(int n, int threads, const std::function<void(int)>& body);

// The number of hardware threads (at least 1): the tools' default for --threads.
int DefaultThreads();

}  // namespace mound
