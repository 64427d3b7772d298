#include "base/huge_pages.h"

#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace insid {
namespace {

// The kernel's transparent-huge-page mode ("always", "madvise" or "never"), empty if unknown.
std::string thp_mode() {
  std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string line;
  std::getline(in, line);
  const auto open = line.find('['), close = line.find(']');
  return open == std::string::npos || close == std::string::npos
             ? std::string()
             : line.substr(open + 1, close - open - 1);
}

// AnonHugePages (kB) summed over the mappings in /proc/self/smaps that overlap [p, p + bytes)
// (the hint splits a mapping at 2 MiB boundaries), -1 if none does.
long anon_huge_kb(const void* p, std::size_t bytes) {
  const auto begin = reinterpret_cast<std::uintptr_t>(p), end = begin + bytes;
  std::ifstream in("/proc/self/smaps");
  std::string line;
  bool overlaps = false, found = false;
  long kb = 0;
  while (std::getline(in, line)) {
    std::uintptr_t lo = 0, hi = 0;
    char dash = 0;
    std::istringstream range(line);
    if (range >> std::hex >> lo >> dash >> hi && dash == '-' &&
        line.find(':') > line.find(' ')) {  // a mapping's header line: "lo-hi perms ..."
      overlaps = lo < end && begin < hi;
      found = found || overlaps;
      continue;
    }
    if (overlaps && line.rfind("AnonHugePages:", 0) == 0) kb += std::stol(line.substr(14));
  }
  return found ? kb : -1;
}

// What the hint is for: a large array written from start to end (the IMU synthesis) is backed
// by 2 MiB pages where Linux allows it on request, and its values are unaffected.
TEST(HugePages, LargeArrayIsBackedByHugePagesWhereTheKernelAllows) {
  const std::string mode = thp_mode();
  if (mode != "madvise" && mode != "always")
    GTEST_SKIP() << "transparent huge pages are '" << mode
                 << "' here (/sys/kernel/mm/transparent_hugepage/enabled): nothing to check";
  std::vector<double> v;
  const std::size_t n = std::size_t{16} << 20 >> 3;  // 16 MiB of doubles
  reserve_huge_pages(v, n);
  ASSERT_GE(v.capacity(), n);
  const double* storage = v.data();
  v.assign(n, 0.5);
  EXPECT_EQ(v.data(), storage) << "assign within the reserved capacity must not move the storage";
  for (std::size_t i = 0; i < n; i += 4096) ASSERT_EQ(v[i], 0.5);
  const long huge_kb = anon_huge_kb(v.data(), n * sizeof(double));
  ASSERT_GE(huge_kb, 0) << "no mapping in /proc/self/smaps holds the array";
  EXPECT_GE(huge_kb, 2048) << "not one 2 MiB page backs the 16 MiB array (THP mode " << mode << ")";
}

TEST(HugePages, HintOnSmallOrEmptyRangesIsHarmless) {
  advise_huge_pages(nullptr, 0);
  advise_huge_pages(nullptr, std::size_t{64} << 20);
  std::vector<int> small(100, 7);
  advise_huge_pages(small.data(), small.size() * sizeof(int));
  for (int x : small) ASSERT_EQ(x, 7);
}

}  // namespace
}  // namespace insid
