// Transparent huge pages for the few large arrays that are written once from start to end.
//
// A 4 KiB page faults on its first touch. The paper flight's 860 000 IMU and truth rows and its
// latitude/longitude grids are about 130 MB, 32 000 faults, written by one thread before the
// others have work. Where Linux sets transparent huge pages to "madvise" (Debian's default), a
// range marked MADV_HUGEPAGE faults 2 MiB at a time: the simulation's serial start went from
// 1.1 to 0.47 s on the 2-core KVM machine of results/perf/README.md ("The simulation's serial
// start: huge pages").
#pragma once

#include <cstddef>
#include <vector>

namespace insid {

/// Asks the kernel to back the whole 2 MiB pages inside [data, data + bytes) with transparent
/// huge pages (Linux madvise(MADV_HUGEPAGE)). A hint: nothing happens elsewhere, for a range
/// under 2 MiB, or when the kernel declines; the values stored are never affected.
void advise_huge_pages(void* data, std::size_t bytes);

/// v.reserve(n) with the new storage advised for huge pages before anything touches it.
template <class T>
void reserve_huge_pages(std::vector<T>& v, std::size_t n) {
  v.reserve(n);
  advise_huge_pages(v.data(), v.capacity() * sizeof(T));
}

}  // namespace insid
