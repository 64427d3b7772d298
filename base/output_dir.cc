#include "base/output_dir.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/xattr.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <system_error>

#include "base/digest.h"

namespace insid {
namespace {

namespace fs = std::filesystem;

// The parts of a temporary's name, "<base><tag><host>-<pid>-<counter>" (temporary_sibling();
// tag ".tmp-" or ".old-"); nullopt for any other name.
struct TemporaryName {
  std::string base;
  std::string host;
  long pid = 0;
};

std::optional<TemporaryName> parse_temporary_name(const std::string& name) {
  // "-<pid>-<counter>" at the end.
  std::size_t end = name.size();
  std::array<std::size_t, 2> dashes{};
  for (std::size_t& dash : dashes) {
    if (end == 0) return std::nullopt;
    dash = name.find_last_of('-', end - 1);
    if (dash == std::string::npos || dash + 1 >= end || dash + 20 < end) return std::nullopt;
    for (std::size_t i = dash + 1; i < end; ++i)
      if (name[i] < '0' || name[i] > '9') return std::nullopt;
    end = dash;
  }
  const std::string head = name.substr(0, end);  // "<base><tag><host>"
  const std::size_t tmp = head.rfind(".tmp-");
  const std::size_t old = head.rfind(".old-");
  const std::size_t tag = tmp == std::string::npos   ? old
                          : old == std::string::npos ? tmp
                                                     : std::max(tmp, old);
  if (tag == std::string::npos || tag == 0 || tag + 5 >= head.size()) return std::nullopt;
  TemporaryName parsed;
  parsed.base = head.substr(0, tag);
  parsed.host = head.substr(tag + 5);
  parsed.pid = std::stol(name.substr(dashes[1] + 1, dashes[0] - dashes[1] - 1));
  return parsed;
}

// This host's name as temporaries carry it ('/' and '\\' replaced).
const std::string& this_host() {
  static const std::string host = [] {
    std::array<char, 256> name{};
    if (::gethostname(name.data(), name.size() - 1) != 0 || name[0] == '\0')
      return std::string("host");
    std::string h(name.data());
    for (char& c : h)
      if (c == '/' || c == '\\') c = '_';
    return h;
  }();
  return host;
}

// The value of kTemporaryMarkAttribute: who made the temporary.
const std::string& temporary_mark_value() {
  static const std::string value = this_host() + "-" + std::to_string(::getpid());
  return value;
}

// The extended attribute that marks a file insid wrote: the SHA-256 of its bytes (hex).
constexpr const char* kMarkAttribute = "user.insid.sha256";

// A file descriptor closed on scope exit.
class Fd {
 public:
  explicit Fd(int fd = -1) : fd_(fd) {}
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  Fd& operator=(Fd&& other) noexcept {
    if (this != &other) {
      if (fd_ >= 0) ::close(fd_);
      fd_ = other.fd_;
      other.fd_ = -1;
    }
    return *this;
  }
  int get() const { return fd_; }
  explicit operator bool() const { return fd_ >= 0; }
  int release() {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }

 private:
  int fd_;
};

std::string os_error(int err) { return std::strerror(err); }

// SHA-256 of what remains to be read from `fd`, "" on a read error.
std::string sha256_of_fd(int fd) {
  Sha256 sha;
  std::array<char, 1 << 16> buffer{};
  for (;;) {
    const ssize_t n = ::read(fd, buffer.data(), buffer.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      return "";
    }
    if (n == 0) break;
    sha.update(buffer.data(), static_cast<std::size_t>(n));
  }
  return sha.hex();
}

// Owner of `name` in the directory `dir_fd`, never following a link.
FileOwner owner_at(int dir_fd, const char* name) {
  struct stat st {};
  if (::fstatat(dir_fd, name, &st, AT_SYMLINK_NOFOLLOW) != 0)
    return errno == ENOENT ? FileOwner::kAbsent : FileOwner::kOther;
  if (!S_ISREG(st.st_mode)) return FileOwner::kOther;
  const Fd fd(::openat(dir_fd, name, O_RDONLY | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK));
  if (!fd) return FileOwner::kOther;
  std::array<char, 65> mark{};
  const ssize_t n = ::fgetxattr(fd.get(), kMarkAttribute, mark.data(), mark.size());
  if (n != 64) return FileOwner::kOther;
  return sha256_of_fd(fd.get()) == std::string(mark.data(), 64) ? FileOwner::kInsid
                                                                : FileOwner::kOther;
}

bool is_own_entry(const fs::path& dir, const std::string& name, const OutputKind& kind) {
  for (const std::string& own : kind.own_entries) {
    if (const auto temporary = parse_temporary_name(name);
        temporary && temporary->base == own && is_insid_temporary(dir / name))
      return true;
    if (name != own) continue;
    std::error_code ec;
    const fs::file_status st = fs::symlink_status(dir / name, ec);
    const auto& dirs = kind.own_directories;
    if (fs::is_directory(st))  // a real directory (symlink_status: not a link)
      return std::find(dirs.begin(), dirs.end(), name) != dirs.end();
    // A lock file is only ever locked and written in place through its descriptor (FileLock):
    // a starting campaign's is still empty and unmarked.
    if (name == FileLock::kRunLockName) return fs::is_regular_file(st);
    return file_owner(dir / name) == FileOwner::kInsid;
  }
  return false;
}

// Writes all of `contents` to `fd`; false with errno set on failure.
bool write_all(int fd, std::string_view contents) {
  const char* p = contents.data();
  std::size_t left = contents.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  return true;
}

// Sets insid's mark on an open file (ignored where the file system keeps no user attributes:
// the file is then not recognised as insid's, so a later run asks for --force).
void mark_as_insid(int fd, std::string_view contents) {
  const std::string hex = sha256_hex(contents);
  (void)::fsetxattr(fd, kMarkAttribute, hex.data(), hex.size(), 0);
}

std::string foreign_file_message(const std::string& shown, const WriteOptions& options) {
  return "cannot write '" + shown +
         "': the file exists and insid did not write it (or it was changed or copied since); "
         "insid does not overwrite other files: choose another path, remove it yourself, or " +
         options.force_hint;
}

}  // namespace

FileOwner file_owner(const fs::path& path) {
  const fs::path parent = path.has_parent_path() ? path.parent_path() : fs::path(".");
  const Fd dir(::open(parent.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (!dir) return errno == ENOENT ? FileOwner::kAbsent : FileOwner::kOther;
  return owner_at(dir.get(), path.filename().c_str());
}

fs::path temporary_sibling(const fs::path& target, const char* tag) {
  static std::atomic<unsigned> counter{0};
  return target.parent_path() /
         (target.filename().string() + tag + this_host() + "-" + std::to_string(::getpid()) + "-" +
          std::to_string(counter.fetch_add(1)));
}

bool mark_as_temporary(const fs::path& path) {
  const std::string& value = temporary_mark_value();
  return ::lsetxattr(path.c_str(), kTemporaryMarkAttribute, value.data(), value.size(), 0) == 0;
}

bool is_insid_temporary(const fs::path& path) {
  if (!parse_temporary_name(path.filename().string())) return false;
  std::error_code ec;
  const fs::file_status st = fs::symlink_status(path, ec);
  if (!fs::is_directory(st) && !fs::is_regular_file(st)) return false;
  if (::lgetxattr(path.c_str(), kTemporaryMarkAttribute, nullptr, 0) >= 0) return true;
  return fs::is_regular_file(st) && file_owner(path) == FileOwner::kInsid;
}

void write_file_atomic_under(const fs::path& root, const fs::path& relative,
                             std::string_view contents, const WriteOptions& options) {
  const std::string shown = (root / relative).string();
  auto fail = [&](const std::string& why) -> void {
    throw std::runtime_error("cannot write '" + shown + "': " + why);
  };
  if (relative.empty() || relative.is_absolute() || !relative.has_filename() ||
      relative.filename() == "." || relative.filename() == "..")
    fail("not a file name under '" + root.string() + "'");
  Fd dir(::open(root.empty() ? "." : root.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (!dir) fail("cannot open the directory '" + root.string() + "': " + os_error(errno));
  fs::path walked = root;
  for (const fs::path& part : relative.parent_path()) {
    if (part.empty() || part == ".") continue;
    if (part == "..") fail("'..' leaves the output directory");
    walked /= part;
    const int flags = O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC;
    int fd = ::openat(dir.get(), part.c_str(), flags);
    if (fd < 0 && errno == ENOENT && options.create_directories) {
      if (::mkdirat(dir.get(), part.c_str(), 0755) != 0 && errno != EEXIST)
        fail("cannot create the directory '" + walked.string() + "': " + os_error(errno));
      fd = ::openat(dir.get(), part.c_str(), flags);
    }
    if (fd < 0) {
      const int err = errno;
      if (err == ELOOP || err == ENOTDIR)
        fail("'" + walked.string() +
             "' is a symbolic link or not a directory; insid writes only into real directories "
             "under '" +
             root.string() + "', never through links");
      fail("cannot open the directory '" + walked.string() + "': " + os_error(err));
    }
    dir = Fd(fd);
  }
  const std::string name = relative.filename().string();
  struct stat st {};
  if (::fstatat(dir.get(), name.c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0) {
    if (S_ISLNK(st.st_mode))
      fail("it is a symbolic link; insid neither writes through links nor replaces them");
    if (!S_ISREG(st.st_mode)) fail("it exists and is not a regular file");
    if (!options.replace_foreign && owner_at(dir.get(), name.c_str()) != FileOwner::kInsid)
      throw std::runtime_error(foreign_file_message(shown, options));
  }
  const std::string tmp = temporary_sibling(name, ".tmp-").string();
  Fd out(
      ::openat(dir.get(), tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644));
  if (!out) fail("cannot create a temporary beside it: " + os_error(errno));
  // Marked before anything is written: a kill from here on leaves a temporary a later run
  // recognises as insid's (is_insid_temporary).
  const std::string& mark = temporary_mark_value();
  (void)::fsetxattr(out.get(), kTemporaryMarkAttribute, mark.data(), mark.size(), 0);
  auto abandon = [&](const std::string& why) {
    out = Fd();
    ::unlinkat(dir.get(), tmp.c_str(), 0);
    fail(why);
  };
  if (!write_all(out.get(), contents)) abandon(os_error(errno));
  if (::fsync(out.get()) != 0 && errno != EINVAL && errno != EROFS)
    abandon("fsync: " + os_error(errno));
  mark_as_insid(out.get(), contents);
  (void)::fremovexattr(out.get(), kTemporaryMarkAttribute);  // the file it becomes is no temporary
  if (::close(out.release()) != 0) abandon("close: " + os_error(errno));
  if (::renameat(dir.get(), tmp.c_str(), dir.get(), name.c_str()) != 0)
    abandon("cannot rename the temporary into place: " + os_error(errno));
}

void check_file_writable(const fs::path& path, const WriteOptions& options) {
  auto fail = [&](const std::string& why) {
    throw std::runtime_error("cannot write '" + path.string() + "': " + why);
  };
  if (!path.has_filename()) fail("not a file name");
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (fs::is_character_file(st) || fs::is_fifo(st)) return;
  const fs::file_status own = fs::symlink_status(path, ec);
  if (!fs::exists(own)) return;
  if (fs::is_symlink(own))
    fail("it is a symbolic link; insid neither writes through links nor replaces them");
  if (!fs::is_regular_file(own)) fail("it exists and is not a regular file");
  if (!options.replace_foreign && file_owner(path) != FileOwner::kInsid)
    throw std::runtime_error(foreign_file_message(path.string(), options));
}

void write_file_atomic(const fs::path& path, std::string_view contents,
                       const WriteOptions& options) {
  if (!path.has_filename())
    throw std::runtime_error("cannot write '" + path.string() + "': not a file name");
  // A character device or FIFO (/dev/null, /dev/stdout, a pipe) is written to, never replaced
  // by a rename (which would put a regular file in place of /dev/null).
  std::error_code status_ec;
  const fs::file_status st = fs::status(path, status_ec);
  if (fs::is_character_file(st) || fs::is_fifo(st)) {
    const Fd fd(::open(path.c_str(), O_WRONLY | O_CLOEXEC));
    if (!fd || !write_all(fd.get(), contents))
      throw std::runtime_error("cannot write '" + path.string() + "': " + os_error(errno));
    return;
  }
  write_file_atomic_under(path.has_parent_path() ? path.parent_path() : fs::path("."),
                          path.filename(), contents, options);
}

void refuse_replacing_inputs(const fs::path& output, const std::vector<fs::path>& inputs,
                             bool whole_directory) {
  std::error_code ec;
  const fs::path out = fs::weakly_canonical(fs::absolute(output, ec), ec);
  for (const fs::path& input : inputs) {
    std::error_code in_ec;
    if (!fs::exists(input, in_ec)) continue;
    const fs::path in = fs::weakly_canonical(fs::absolute(input, in_ec), in_ec);
    bool hit = false;
    std::error_code eq_ec;
    if (fs::exists(output, eq_ec) && fs::equivalent(output, input, eq_ec)) hit = true;
    if (!hit && whole_directory && !out.empty()) {
      auto o = out.begin();
      auto i = in.begin();
      for (; o != out.end() && i != in.end() && *o == *i; ++o, ++i) {
      }
      hit = o == out.end() || (std::next(o) == out.end() && o->empty());
    }
    if (hit)
      throw std::runtime_error(
          "cannot write '" + output.string() + "': it would " +
          (whole_directory ? "replace the directory holding" : "overwrite") + " '" +
          input.string() +
          "', which this command reads; write the output somewhere else (--force does not "
          "change this)");
  }
}

std::vector<fs::path> remove_own_files(const fs::path& dir,
                                       const std::function<bool(const fs::path&)>& also_own) {
  std::vector<fs::path> kept;
  std::error_code ec;
  const fs::file_status top = fs::symlink_status(dir, ec);
  if (!fs::exists(top)) return kept;
  if (!fs::is_directory(top)) return {fs::path(".")};  // a link or a file: not insid's to clear
  std::vector<fs::path> own_files;
  std::vector<fs::path> temporary_directories;
  std::vector<fs::path> directories;
  for (fs::recursive_directory_iterator it(dir, fs::directory_options::none, ec), end;
       !ec && it != end; it.increment(ec)) {
    const fs::file_status st = it->symlink_status(ec);
    const fs::path rel = it->path().lexically_relative(dir);
    if (fs::is_directory(st)) {
      if (is_insid_temporary(it->path())) {
        temporary_directories.push_back(it->path());  // a dataset's, emptied below
        it.disable_recursion_pending();
      } else {
        directories.push_back(it->path());
      }
    } else if (fs::is_regular_file(st) &&
               (is_insid_temporary(it->path()) || (also_own && also_own(rel)) ||
                file_owner(it->path()) == FileOwner::kInsid)) {
      own_files.push_back(it->path());
    } else {
      kept.push_back(rel);
    }
  }
  if (ec) throw std::runtime_error("cannot list '" + dir.string() + "': " + ec.message());
  for (const fs::path& p : own_files) {
    std::error_code ignored;
    fs::remove(p, ignored);
  }
  // A temporary directory holds what insid was writing (or replacing): only insid's files go.
  for (const fs::path& t : temporary_directories)
    for (const fs::path& p : remove_own_files(t)) kept.push_back(t.lexically_relative(dir) / p);
  // Deepest first: a directory is removed only when nothing is left in it.
  std::sort(directories.begin(), directories.end(),
            [](const fs::path& a, const fs::path& b) { return a.string() > b.string(); });
  for (const fs::path& d : directories) {
    std::error_code ignored;
    fs::remove(d, ignored);  // fails, harmlessly, when not empty
  }
  std::error_code ignored;
  fs::remove(dir, ignored);
  return kept;
}

void require_own_or_empty(const fs::path& dir, const OutputKind& kind,
                          std::string_view force_hint) {
  std::error_code ec;
  const fs::file_status st = fs::status(dir, ec);
  if (!fs::exists(st)) return;
  if (!fs::is_directory(st))
    throw std::runtime_error("'" + dir.string() + "' exists and is not a directory");
  std::vector<std::string> foreign;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (!is_own_entry(dir, name, kind)) foreign.push_back(name);
  }
  if (ec) throw std::runtime_error("cannot list '" + dir.string() + "': " + ec.message());
  if (foreign.empty()) return;
  std::sort(foreign.begin(), foreign.end());
  throw std::runtime_error(
      "'" + dir.string() + "' is not empty and not " + kind.description + ": it holds '" +
      foreign.front() + "'" +
      (foreign.size() > 1 ? " and " + std::to_string(foreign.size() - 1) + " more entries"
                          : std::string()) +
      ". insid does not write into other files' directories; choose a new "
      "or empty directory" +
      (force_hint.empty() ? std::string(".") : ", or " + std::string(force_hint) + "."));
}

bool contains_working_directory(const fs::path& dir) {
  std::error_code ec;
  const fs::path cwd = fs::weakly_canonical(fs::current_path(ec), ec);
  if (ec) return false;
  const fs::path target = fs::weakly_canonical(fs::absolute(dir, ec), ec);
  if (ec) return false;
  // target contains cwd when target's components are a prefix of cwd's.
  auto t = target.begin();
  auto c = cwd.begin();
  for (; t != target.end(); ++t, ++c) {
    if (t->empty()) continue;  // a trailing separator
    if (c == cwd.end() || *t != *c) return false;
  }
  return true;
}

const std::string& checked_path_component(const std::string& name, std::string_view what) {
  auto refuse = [&](const std::string& why) {
    throw std::invalid_argument(std::string(what) + " '" + name +
                                "' cannot be used as a file or "
                                "directory name: " +
                                why);
  };
  if (name.empty()) refuse("it is empty");
  if (name == "." || name == "..") refuse("'.' and '..' are not names");
  if (name.find(".tmp-") != std::string::npos || name.find(".old-") != std::string::npos)
    refuse("'.tmp-' and '.old-' mark insid's temporary files, which a resumed run removes");
  for (char c : name) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '.' || c == '_' || c == '-';
    if (!ok) refuse("only letters, digits, '.', '_' and '-' are allowed");
  }
  return name;
}

namespace {

// Removes one of insid's temporaries: a file, or a directory's files insid wrote and then the
// directory when nothing else is left in it. True when it is gone.
bool remove_temporary(const fs::path& path) {
  std::error_code ec;
  if (fs::is_directory(fs::symlink_status(path, ec))) {
    remove_own_files(path);
    return !fs::exists(fs::symlink_status(path, ec));
  }
  return fs::remove(path, ec);
}

}  // namespace

int remove_stale_temporaries(const fs::path& dir) {
  std::error_code ec;
  std::vector<fs::path> stale;
  for (fs::recursive_directory_iterator it(dir, fs::directory_options::none, ec), end;
       !ec && it != end; it.increment(ec)) {
    if (it->is_symlink(ec)) continue;
    if (is_insid_temporary(it->path())) {
      stale.push_back(it->path());
      if (it->is_directory(ec)) it.disable_recursion_pending();
    }
  }
  int removed = 0;
  for (const fs::path& p : stale)
    if (remove_temporary(p)) ++removed;
  return removed;
}

int remove_abandoned_siblings(const fs::path& target) {
  const fs::path parent = target.has_parent_path() ? target.parent_path() : fs::path(".");
  const std::string base = target.filename().string();
  std::vector<fs::path> abandoned;
  std::error_code ec;
  for (fs::directory_iterator it(parent, ec), end; !ec && it != end; it.increment(ec)) {
    const auto name = parse_temporary_name(it->path().filename().string());
    if (!name || name->base != base || name->host != this_host()) continue;
    // Signal 0 only asks whether the process exists; ESRCH: it does not any more.
    if (name->pid <= 0 || ::kill(static_cast<pid_t>(name->pid), 0) == 0 || errno != ESRCH) continue;
    if (is_insid_temporary(it->path())) abandoned.push_back(it->path());
  }
  int removed = 0;
  for (const fs::path& p : abandoned)
    if (remove_temporary(p)) ++removed;
  return removed;
}

FileLock::FileLock(const fs::path& path, Target target) : path_(path) {
  const bool directory = target == Target::kDirectory;
  const int flags = directory ? (O_RDONLY | O_DIRECTORY | O_CLOEXEC)
                              : (O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK);
  fd_ = ::open(path.c_str(), flags, 0644);
  if (fd_ < 0) {
    const int err = errno;
    if (err == ELOOP)
      throw std::runtime_error("cannot open lock '" + path.string() +
                               "': it is a symbolic link; insid does not write through links "
                               "(remove it)");
    throw std::runtime_error("cannot open lock '" + path.string() + "': " + std::strerror(err));
  }
  struct stat st {};
  if (!directory && (::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode))) {
    ::close(fd_);
    fd_ = -1;
    throw std::runtime_error("cannot open lock '" + path.string() + "': it is not a regular file");
  }
}

std::string FileLock::read_text() const {
  std::string text;
  std::array<char, 4096> buffer{};
  for (off_t offset = 0;;) {
    const ssize_t n = ::pread(fd_, buffer.data(), buffer.size(), offset);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    text.append(buffer.data(), static_cast<std::size_t>(n));
    offset += n;
  }
  return text;
}

void FileLock::write_text(const std::string& text) {
  bool ok = ::ftruncate(fd_, 0) == 0;
  for (std::size_t done = 0; ok && done < text.size();) {
    const ssize_t n =
        ::pwrite(fd_, text.data() + done, text.size() - done, static_cast<off_t>(done));
    if (n < 0 && errno == EINTR) continue;
    ok = n > 0;
    if (ok) done += static_cast<std::size_t>(n);
  }
  if (!ok)
    throw std::runtime_error("cannot write the lock '" + path_.string() +
                             "': " + std::strerror(errno));
  mark_as_insid(fd_, text);
}

FileLock::~FileLock() {
  if (fd_ >= 0) ::close(fd_);  // releases the lock
}

bool FileLock::try_lock(Mode mode) {
  const int op = (mode == Mode::kShared ? LOCK_SH : LOCK_EX) | LOCK_NB;
  while (::flock(fd_, op) != 0) {
    if (errno == EINTR) continue;
    if (errno == EWOULDBLOCK) return false;
    throw std::runtime_error("cannot lock '" + path_.string() + "': " + std::strerror(errno));
  }
  return true;
}

void FileLock::lock(Mode mode) {
  const int op = mode == Mode::kShared ? LOCK_SH : LOCK_EX;
  while (::flock(fd_, op) != 0) {
    if (errno == EINTR) continue;
    throw std::runtime_error("cannot lock '" + path_.string() + "': " + std::strerror(errno));
  }
}

void FileLock::unlock() { ::flock(fd_, LOCK_UN); }

}  // namespace insid
