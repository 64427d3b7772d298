// Whole-file reads; see file_read.h.
#include "base/file_read.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <new>

namespace insid {

namespace {

[[noreturn]] void fail(const std::string& message) { throw FileReadError(message); }

std::string mib(std::uint64_t bytes) {
  return std::to_string((bytes + (1u << 20) - 1) >> 20) + " MiB";
}

// Closes the descriptor on every way out.
struct Fd {
  int fd;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

// Reads up to `count` bytes at `out` (fewer at the end of the file); returns how many.
std::size_t read_some(int fd, char* out, std::size_t count, const std::string& where) {
  std::size_t got = 0;
  while (got < count) {
    const ssize_t n = ::read(fd, out + got, count - got);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail(where + ": read error: " + std::strerror(errno));
    }
    if (n == 0) break;
    got += static_cast<std::size_t>(n);
  }
  return got;
}

}  // namespace

std::string read_file_whole(const std::filesystem::path& path, const std::string& where,
                            const FileReadOptions& options) {
  // O_NONBLOCK: opening a FIFO must not wait for a writer (it is refused below).
  const Fd f{::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK)};
  if (f.fd < 0) fail(where + ": cannot open: " + std::strerror(errno));
  struct stat st {};
  if (::fstat(f.fd, &st) != 0) fail(where + ": cannot stat: " + std::strerror(errno));
  if (!S_ISREG(st.st_mode))
    fail(where + ": not a regular file (" +
         (S_ISFIFO(st.st_mode)  ? "a FIFO"
          : S_ISDIR(st.st_mode) ? "a directory"
                                : "a special file") +
         ")" + options.not_regular_hint);
  const auto size = static_cast<std::uint64_t>(st.st_size);
  if (options.max_bytes > 0 && size > options.max_bytes)
    fail(
        where + ": " + mib(size) + " (" + std::to_string(size) + " bytes), over the limit of " +
        mib(options.max_bytes) +
        (options.limit_option.empty() ? std::string() : "; raise it with " + options.limit_option));
  if (!options.magic.empty()) {
    std::string head(options.magic.size(), '\0');
    const std::size_t n = read_some(f.fd, head.data(), head.size(), where);
    if (n < head.size() || head != options.magic)
      fail(where + ": not " + options.magic_name + " (its first " +
           std::to_string(options.magic.size()) + " bytes are not the format's magic)");
    if (::lseek(f.fd, 0, SEEK_SET) != 0) fail(where + ": cannot seek: " + std::strerror(errno));
  }
  if (options.text) {
    std::string head(65536, '\0');
    const std::size_t n = read_some(f.fd, head.data(), head.size(), where);
    head.resize(n);
    if (const std::size_t nul = head.find('\0'); nul != std::string::npos)
      fail(where + ": not a text file: byte " + std::to_string(nul) +
           " is a NUL byte (a binary file, or a file of zeros)");
    if (n == 65536 && head.find('\n') == std::string::npos && head.find('\r') == std::string::npos)
      fail(where + ": not a text file: no line break in its first 65536 bytes");
    if (::lseek(f.fd, 0, SEEK_SET) != 0) fail(where + ": cannot seek: " + std::strerror(errno));
  }
  try {
    std::string data;
    // One byte over the size: the read that finds the end then needs no room. (Sized exactly,
    // that read grew the string first, copying the whole file: 117 MB for a 2.4 h imu.csv.)
    data.resize(static_cast<std::size_t>(size) + 1);
    std::size_t got = 0;
    for (;;) {
      if (got == data.size()) data.resize(data.size() + 65536);  // the file grew
      const std::size_t n = read_some(f.fd, data.data() + got, data.size() - got, where);
      got += n;
      if (got < data.size()) break;  // end of file
    }
    data.resize(got);
    return data;
  } catch (const std::bad_alloc&) {
    fail(where + ": out of memory reading " + mib(size) + " (" + std::to_string(size) + " bytes)");
  }
}

}  // namespace insid
