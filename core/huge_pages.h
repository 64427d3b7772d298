// Transparent huge pages for the few large arrays that are written once from start to end.
//
// A 4 KiB page faults on its first touch; the paper flight's 860 000 IMU and truth rows and
// their GNSS epochs are about 130 MB, 32 000 faults, written by one thread before the threads
// have work (results/perf/README.md, "Serial preparation": 0.5 s of the simulation at 2 threads
// on this KVM machine). Where Linux sets transparent huge pages to "madvise" (Debian's default),
// a range marked MADV_HUGEPAGE faults 2 MiB at a time.
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
