// Reading a whole input file, the one way insid does it (issues 35 and 37): regular files only
// (a FIFO, directory or device is refused without waiting for a writer), an optional size limit
// checked before anything is read, an optional magic checked on the first bytes before the rest
// is read, and running out of memory reported with the file named, never as a bare bad_alloc.
#pragma once

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

namespace insid {

/// A file that could not be read as asked; what() names it (`where`) and why.
class FileReadError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct FileReadOptions {
  /// Larger files are refused before they are read (0: no limit).
  std::uint64_t max_bytes = 0;
  /// What lifts the limit, named in the refusal (e.g. "--max-input-mb").
  std::string limit_option;
  /// The file must start with these bytes (empty: anything); checked before the rest is read.
  std::string_view magic;
  /// What the magic identifies, for the refusal (e.g. "a PX4 ULog").
  std::string magic_name;
  /// The file must be text: its first 64 KiB hold no NUL byte and (when the file is longer) a
  /// line break; checked before the rest is read, so that a 2 GB file of zeros given as a CSV
  /// is refused at once, not after gigabytes of parsing.
  bool text = false;
  /// Added to the refusal of a FIFO, directory or device (e.g. "; a dataset's files must be ...").
  std::string not_regular_hint;
};

/// The whole of `path`. `where` names the file in every message (e.g. "--imu walk/imu.csv").
/// Throws FileReadError.
std::string read_file_whole(const std::filesystem::path& path, const std::string& where,
                            const FileReadOptions& options = {});

}  // namespace insid
