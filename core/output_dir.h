// Where insid may write: output directories of a known kind, paths that stay under them, a
// lock per directory, and the clean-up of temporary files a killed process left behind.
//
// The rules (every command that writes a directory follows them):
// - A directory is reused only when it is empty or holds insid's own output of the same kind
//   (a dataset, a campaign); a non-empty directory of anything else is refused, unless the user
//   says --force, and then insid still only writes its own files there, never deletes others.
// - The current directory and its parents are never replaced.
// - Names that come from configs become path components only through
//   checked_path_component(), which refuses anything that could leave the output directory.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace insid {

/// What an output directory holds, as far as insid can tell.
struct OutputKind {
  std::string description;               ///< e.g. "an insid dataset", for messages
  std::vector<std::string> own_entries;  ///< names insid writes at the top level
};

/// Throws std::runtime_error when `dir` exists and holds an entry that is not in
/// `kind.own_entries` (or a temporary of one: "<entry>.tmp-..."), naming the first such entry
/// and the way out (another directory, or `force_hint`). An absent or empty directory passes.
void require_own_or_empty(const std::filesystem::path& dir, const OutputKind& kind,
                          std::string_view force_hint);

/// True when `dir` is the current working directory or one of its parents.
bool contains_working_directory(const std::filesystem::path& dir);

/// `name` when it can be one path component under an output directory: non-empty, only
/// [A-Za-z0-9._-], not "." or "..". Otherwise throws std::invalid_argument naming `what`
/// (e.g. "scenario name") and the value. Every config string that becomes part of a path
/// goes through here, so no write leaves the output directory.
const std::string& checked_path_component(const std::string& name, std::string_view what);

/// Removes, under `dir` (recursively), the temporary files of insid's atomic writes
/// ("<name>.tmp-<host>-<pid>-<n>") and datasets ("<name>.tmp-..." / ".old-..." directories).
/// Call it only while no other process writes there (holding the campaign lock alone).
/// Returns the number of entries removed.
int remove_stale_temporaries(const std::filesystem::path& dir);

/// An advisory lock (flock(2)) on a file or directory, held until destruction or unlock().
/// Locks of one process are independent per FileLock object; every open descriptor is
/// close-on-exec. Campaigns use two: the directory itself as a short "gate" around checking
/// and writing the manifest, and `<dir>/.insid-lock`, held shared by every process running
/// that campaign (shards, ranks) and alone by a process that changes what the directory holds.
class FileLock {
 public:
  enum class Mode { kShared, kExclusive };
  /// The file a campaign directory's run lock lives in.
  static constexpr const char* kRunLockName = ".insid-lock";

  /// Opens `path` (a directory, or a regular file, created when absent); takes no lock yet.
  /// Throws std::runtime_error naming the path.
  explicit FileLock(const std::filesystem::path& path);
  ~FileLock();
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

  /// Takes or converts the lock without waiting; false when another holder conflicts.
  /// (A conversion is not atomic in flock(2): hold a gate lock around it.)
  bool try_lock(Mode mode);
  /// Takes or converts the lock, waiting for conflicting holders.
  void lock(Mode mode);
  void unlock();

 private:
  int fd_ = -1;
  std::filesystem::path path_;
};

}  // namespace insid
