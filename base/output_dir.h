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
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace insid {

/// What an output directory holds, as far as insid can tell.
struct OutputKind {
  std::string description;               ///< e.g. "an insid dataset", for messages
  std::vector<std::string> own_entries;  ///< names insid writes at the top level
  /// The subset of own_entries insid writes as directories (a campaign's runs/); an own name
  /// held by a directory is foreign unless listed here (a user's folder named provenance.json
  /// in a dataset is not insid's to delete).
  std::vector<std::string> own_directories = {};
};

/// Throws std::runtime_error when `dir` exists and holds an entry that is not insid's own:
/// a name outside `kind.own_entries` (and not one of insid's temporaries of one, see
/// is_insid_temporary), or an own name held by something insid did not write (a regular file
/// without insid's mark, see file_owner; a symbolic link; a directory where insid writes a file).
/// Names the first such entry and the way out (another directory, or `force_hint`). An absent
/// or empty directory passes; so do real directories of `kind.own_directories` (their contents
/// are checked where insid would delete them, remove_own_files).
void require_own_or_empty(const std::filesystem::path& dir, const OutputKind& kind,
                          std::string_view force_hint);

/// Who wrote a file, as far as insid can tell. insid marks every file it writes (the extended
/// attribute "user.insid.sha256", the SHA-256 of the bytes written, set before the file is
/// renamed into place); a file is insid's while its contents still match the mark. A file copied
/// without its extended attributes, edited since, or written by anyone else is not insid's, and
/// neither is a symbolic link or anything that is not a regular file.
enum class FileOwner {
  kAbsent,  ///< nothing at the path (not even a dangling link)
  kInsid,   ///< a regular file whose contents match insid's mark
  kOther,   ///< anything else: insid does not replace or delete it unless the user says --force
};
FileOwner file_owner(const std::filesystem::path& path);

/// How write_file_atomic treats an existing file at the destination.
struct WriteOptions {
  /// Replace an existing regular file that insid did not write (the command line's --force).
  /// Symbolic links and non-regular files are never replaced.
  bool replace_foreign = false;
  /// Create the missing directories of `relative` (write_file_atomic_under only).
  bool create_directories = false;
  /// What the refusal of a foreign file tells the user to do instead.
  std::string force_hint = "give --force to replace it";
};

/// Writes `contents` to `path` atomically (a marked temporary beside it, fsync, rename), so a
/// reader never sees half a file. A character device or FIFO (/dev/stdout, /dev/null, a pipe)
/// is written to instead. Throws std::runtime_error naming the path when the destination is a
/// symbolic link, not a regular file, or a file insid did not write (unless
/// options.replace_foreign), or when writing fails (the temporary is removed).
void write_file_atomic(const std::filesystem::path& path, std::string_view contents,
                       const WriteOptions& options = {});

/// Throws what write_file_atomic(path, ..., options) would throw about the destination, without
/// writing: for commands that check their outputs before the work.
void check_file_writable(const std::filesystem::path& path, const WriteOptions& options = {});

/// write_file_atomic for `root / relative` inside an output directory (a campaign's), without
/// following links below `root`: every directory of `relative` is opened with O_NOFOLLOW from
/// the one above it (openat), the temporary is created with O_EXCL | O_NOFOLLOW and renamed with
/// renameat in the same directory, so a symbolic link planted anywhere under `root` (runs/,
/// optimum/, the file itself) is refused, not followed, even if it appears while insid runs.
/// `relative` must be relative and free of "..". `root` itself is the user's and may be a link.
void write_file_atomic_under(const std::filesystem::path& root,
                             const std::filesystem::path& relative, std::string_view contents,
                             const WriteOptions& options = {});

/// A name for a temporary beside `target`: "<name><tag><host>-<pid>-<n>" (tag ".tmp-" or
/// ".old-"), unique among processes sharing a file system (MPI ranks on several hosts).
std::filesystem::path temporary_sibling(const std::filesystem::path& target, const char* tag);

/// The extended attribute insid sets on each temporary it creates (a file of an atomic write,
/// a dataset's directory being written or the old one being replaced) the moment it exists,
/// before anything is written into it; its value is "<host>-<pid>". A temporary is recognised by
/// this mark, never by its name alone: a user's "photos.tmp-laptop-12-3" is not insid's.
inline constexpr const char* kTemporaryMarkAttribute = "user.insid.temporary";

/// Marks the file or directory at `path` as one of insid's temporaries (kTemporaryMarkAttribute).
/// False where the file system keeps no user attributes: the temporary is then never removed by
/// a later run (left, not guessed at).
bool mark_as_temporary(const std::filesystem::path& path);

/// True when `path` (never followed if a link) is one of insid's temporaries: its name has the
/// form temporary_sibling() makes, and it is a directory or regular file carrying
/// kTemporaryMarkAttribute, or a regular file whose contents match insid's mark (a finished
/// write whose rename did not happen).
bool is_insid_temporary(const std::filesystem::path& path);

/// Throws std::runtime_error when writing `output` would replace one of `inputs`, the files the
/// same command reads (the same file, a hard link or a link to it), or, with `whole_directory`
/// (a directory replaced as a whole), when an input lies anywhere under `output`. No --force
/// lifts this: a command never destroys what it reads.
void refuse_replacing_inputs(const std::filesystem::path& output,
                             const std::vector<std::filesystem::path>& inputs,
                             bool whole_directory);

/// Removes under `dir` (recursively, never following links) the regular files insid wrote
/// (file_owner() == kInsid), those `also_own` accepts (given the path relative to `dir`: a
/// layout insid alone writes in a directory it owns, e.g. a campaign's run files written before
/// files were marked) and insid's temporaries (is_insid_temporary; a temporary directory is
/// emptied of insid's files the same way), then the directories left empty. Returns the paths
/// of what it kept (relative to `dir`): files of others, links, changed files.
std::vector<std::filesystem::path> remove_own_files(
    const std::filesystem::path& dir,
    const std::function<bool(const std::filesystem::path&)>& also_own = {});

/// True when `dir` is the current working directory or one of its parents.
bool contains_working_directory(const std::filesystem::path& dir);

/// `name` when it can be one path component under an output directory: non-empty, only
/// [A-Za-z0-9._-], not "." or "..", and not holding ".tmp-" or ".old-" (the marks of insid's
/// temporaries, which a resume removes). Otherwise throws std::invalid_argument naming `what`
/// (e.g. "scenario name") and the value. Every config string that becomes part of a path
/// goes through here, so no write leaves the output directory.
const std::string& checked_path_component(const std::string& name, std::string_view what);

/// Removes, under `dir` (recursively, never following links), insid's temporaries
/// (is_insid_temporary: the files of its atomic writes, "<name>.tmp-<host>-<pid>-<n>", and
/// datasets' "<name>.tmp-..." / ".old-..." directories, of which only insid's files go). Call it
/// only while no other process writes there (holding the campaign lock alone). Returns the
/// number of temporaries removed.
int remove_stale_temporaries(const std::filesystem::path& dir);

/// Removes the temporaries beside `target` (siblings named "<target's name>.tmp-..." or
/// ".old-...", is_insid_temporary) that a process of this host left and that has stopped
/// running (killed mid-write); those of live processes or of other hosts are left. Returns the
/// number removed. For outputs written without a lock (datasets).
int remove_abandoned_siblings(const std::filesystem::path& target);

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

  enum class Target {
    kFile,       ///< a regular lock file, created when absent; a symbolic link is refused
    kDirectory,  ///< a directory the user named (a link to one is followed)
  };
  /// Opens `path`; takes no lock yet. Throws std::runtime_error naming the path.
  explicit FileLock(const std::filesystem::path& path, Target target = Target::kFile);
  ~FileLock();
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

  /// Takes or converts the lock without waiting; false when another holder conflicts.
  /// (A conversion is not atomic in flock(2): hold a gate lock around it.)
  bool try_lock(Mode mode);
  /// Takes or converts the lock, waiting for conflicting holders.
  void lock(Mode mode);
  void unlock();
  /// The lock file's text (a regular file's lock only), read and replaced through the open
  /// descriptor: the file the lock lives on, never a path that could have been swapped for a link.
  std::string read_text() const;
  void write_text(const std::string& text);

 private:
  int fd_ = -1;
  std::filesystem::path path_;
};

}  // namespace insid
