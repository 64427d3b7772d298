// The width of the batched kernel's SIMD vectors, shared by its interface (batch_fitness.h) and
// its vector loop (batch_kernel.h), which must agree on it.
#pragma once

namespace insid {

/// Doubles per SIMD vector (one 512-bit register); one candidate per lane.
inline constexpr int kBatchLanes = 8;

}  // namespace insid
