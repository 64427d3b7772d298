// libFuzzer target for the dataset reader (data/dataset.h): the input's first byte picks the
// file it replaces in a small valid dataset (imu.csv, gnss.csv, truth.csv, meta.json or
// heading.csv, the dataset holding a dual-antenna heading), the rest is that file's contents.
// load_dataset must either load the dataset or throw DatasetError; any other exception, a crash or
// a sanitizer report is a finding.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

#include "data/dataset.h"
#include "test_support/test_support.h"

namespace {
namespace fs = std::filesystem;

const fs::path& valid_dataset() {
  static const fs::path dir = [] {
    const fs::path d =
        fs::temp_directory_path() / ("insid-dataset-fuzz-" + std::to_string(getpid()));
    fs::remove_all(d);
    constexpr double kLat = 0.6;
    insid::Dataset ds =
        insid::test::make_static_dataset(insid::EarthModel::paper(kLat, 50.0), kLat, 2.0, 50.0,
                                         {0.0, 0.0, 0.7}, 3.0, 1.0, {}, 100.0, 10.0);
    ds.truth.clear();
    for (std::size_t k = 0; k < ds.imu.size(); k += 10)
      ds.heading.push_back({ds.imu[k].t_s, 0.7, 0.01});
    ds.meta.heading = insid::HeadingMeta{};
    insid::write_dataset(d, ds);
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  static const char* kFiles[] = {"imu.csv", "gnss.csv", "truth.csv", "meta.json", "heading.csv"};
  const fs::path work = valid_dataset().string() + "-case";
  fs::remove_all(work);
  // libFuzzer's own signals (its time limits) can interrupt the copy's system calls: retried, so
  // that the harness never reports itself as a finding.
  for (int attempt = 0;; ++attempt) {
    try {
      fs::copy(valid_dataset(), work);
      break;
    } catch (const fs::filesystem_error& e) {
      if (e.code() != std::errc::interrupted || attempt >= 100) throw;
      fs::remove_all(work);
    }
  }
  {
    std::ofstream out(work / kFiles[data[0] % 5], std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data + 1), static_cast<std::streamsize>(size - 1));
  }
  try {
    insid::load_dataset(work);
  } catch (const insid::DatasetError&) {
    // refused with a message: fine
  } catch (const std::exception& e) {
    std::fprintf(stderr, "finding: not a DatasetError: %s\n", e.what());
    std::abort();
  }
  return 0;
}
