// The thread count of every parallel loop, from one rule.
#pragma once

#include <omp.h>

namespace insid {

/// `requested` threads when positive, else OpenMP's default (OMP_NUM_THREADS, or all cores).
inline int thread_count(int requested) { return requested > 0 ? requested : omp_get_max_threads(); }

}  // namespace insid
