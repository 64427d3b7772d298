#include "core/output_dir.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <system_error>

namespace insid {
namespace {

namespace fs = std::filesystem;

// Temporary names of insid's atomic writes: "<name>.tmp-<host>-<pid>-<counter>"
// (core/dataset.cc, sibling()).
bool is_temporary_name(const std::string& name) {
  const std::size_t tag = name.find(".tmp-");
  if (tag == std::string::npos || tag == 0) return false;
  // "-<pid>-<counter>" at the end, after a non-empty host.
  std::size_t end = name.size();
  for (int number = 0; number < 2; ++number) {
    const std::size_t dash = name.find_last_of('-', end - 1);
    if (dash == std::string::npos || dash + 1 >= end || dash <= tag + 4) return false;
    for (std::size_t i = dash + 1; i < end; ++i)
      if (name[i] < '0' || name[i] > '9') return false;
    end = dash;
  }
  return end > tag + 5;  // the host part is not empty
}

bool is_own_entry(const std::string& name, const OutputKind& kind) {
  for (const std::string& own : kind.own_entries) {
    if (name == own) return true;
    if (name.size() > own.size() + 5 && name.compare(0, own.size() + 5, own + ".tmp-") == 0 &&
        is_temporary_name(name))
      return true;
  }
  return false;
}

}  // namespace

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
    if (!is_own_entry(name, kind)) foreign.push_back(name);
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
  for (char c : name) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '.' || c == '_' || c == '-';
    if (!ok) refuse("only letters, digits, '.', '_' and '-' are allowed");
  }
  return name;
}

int remove_stale_temporaries(const fs::path& dir) {
  std::error_code ec;
  std::vector<fs::path> stale;
  for (fs::recursive_directory_iterator it(dir, fs::directory_options::none, ec), end;
       !ec && it != end; it.increment(ec)) {
    if (it->is_symlink(ec)) continue;
    if (is_temporary_name(it->path().filename().string())) {
      stale.push_back(it->path());
      if (it->is_directory(ec)) it.disable_recursion_pending();
    }
  }
  int removed = 0;
  for (const fs::path& p : stale) {
    std::error_code ignored;
    if (fs::remove_all(p, ignored) > 0) ++removed;
  }
  return removed;
}

FileLock::FileLock(const fs::path& path) : path_(path) {
  std::error_code ec;
  const int flags = fs::is_directory(path, ec) ? (O_RDONLY | O_DIRECTORY | O_CLOEXEC)
                                               : (O_RDWR | O_CREAT | O_CLOEXEC);
  fd_ = ::open(path.c_str(), flags, 0644);
  if (fd_ < 0)
    throw std::runtime_error("cannot open lock '" + path.string() + "': " + std::strerror(errno));
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
