// Forced-included (-include) by CMakeLists.txt on GCC 12.0-12.2 only: GCC's own AVX-512
// intrinsic headers raise false -W(maybe-)uninitialized warnings about their internal `__Y`
// placeholder once inlined into Eigen's AVX-512 reductions (GCC bug 105593, fixed in 12.3).
// Diagnostic pragmas act by source location, so including <immintrin.h> first between them
// silences exactly the warnings located inside those headers; the same warnings in insid's
// (or Eigen's) own lines still fire.
#pragma once
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop
#endif
