// External optimizer over a pipe (external.h; protocol in optimizers/README.md).
//
// Process handling:
//  - One AF_UNIX stream socket pair, created close-on-exec; the child gets its end as stdin and
//    stdout (dup2 clears close-on-exec on fds 0/1 only), so no other run's child inherits it and
//    EOF on our end means the child (and its own children) closed their stdout or exited.
//    Writes use send(MSG_NOSIGNAL): a dead client is an EPIPE error, never a SIGPIPE for insid.
//  - The child runs `/bin/sh -c CMD` in its own process group (posix_spawn, POSIX_SPAWN_SETPGROUP),
//    so that a timeout kills the shell and the interpreter it started together.
//  - Every wait (reply, write) is bounded by timeout_s through poll(); the child's stderr is
//    insid's (tracebacks show up in the terminal or the test log).
#include "optimizers/external.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <thread>
#include <utility>

#include <nlohmann/json.hpp>

#include "base/json_object.h"
#include "base/json_reader.h"

extern char** environ;

namespace insid::opt {
namespace {

using Clock = std::chrono::steady_clock;

// A reply line longer than this is refused (a batch of 100000 points in 100-D fits easily).
constexpr std::size_t kMaxLineBytes = 256u << 20;
// How long a client may take to exit after "stop" before it is killed.
constexpr double kStopGraceS = 2.0;

std::string quoted_excerpt(const std::string& line) {
  // Built by append: GCC 12 reports a false -Wrestrict on "'" + line + "'".
  constexpr std::size_t kMax = 200;
  std::string text(1, '\'');
  text.append(line, 0, std::min(line.size(), kMax));
  if (line.size() <= kMax) return text.append(1, '\'');
  return text.append("...' (").append(std::to_string(line.size())).append(" bytes)");
}

int remaining_ms(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
  return static_cast<int>(std::clamp<std::chrono::milliseconds::rep>(left.count(), 0, 1 << 30));
}

std::string describe_status(int status) {
  if (WIFEXITED(status)) return "exited with status " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) return "was killed by signal " + std::to_string(WTERMSIG(status));
  return "ended (wait status " + std::to_string(status) + ")";
}

nlohmann::json vector_json(const Eigen::VectorXd& x) {
  nlohmann::json a = nlohmann::json::array();
  for (Eigen::Index j = 0; j < x.size(); ++j) a.push_back(x[j]);
  return a;
}

}  // namespace

ExternalReply parse_external_reply(std::string_view line, const Bounds& box,
                                   const std::string& where) {
  // The source of every message: where the line came from and the line (cut at 200 bytes).
  const std::string source = where + quoted_excerpt(std::string(line));
  // insid's one JSON reader, with its depth limit: no deeper value is ever built, so the
  // messages below (which print parts of the reply) never recurse deeply.
  const nlohmann::json reply = parse_json_strict(line, source, {.max_bytes = kMaxLineBytes});
  try {
    // Fields through the one typed reader (base/json_object.h): "<source>: points[1][0]: ...".
    const JsonObject r = JsonObject::document(reply, source, {"points", "error"});
    ExternalReply out;
    if (r.has("error")) {
      const nlohmann::json& e = r.field("error").value();
      out.error = e.is_string() ? e.get<std::string>() : e.dump().substr(0, 200);
      return out;
    }
    const JsonArray points = r.array("points");
    if (points.empty()) points.fail("expected at least one point, found an empty array");
    const int n = box.dimension();
    const std::string expected_point = "expected an array of " + std::to_string(n) + " numbers";
    out.points.reserve(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
      const JsonField point = points[i];
      if (!point.value().is_array() || point.value().size() != static_cast<std::size_t>(n))
        point.fail(expected_point + ", found " + describe_json_value(point.value()));
      // The coordinates read directly (a reply may hold millions); a JsonField names the one
      // at fault.
      const nlohmann::json& coordinates = point.value();
      Eigen::VectorXd x(n);
      for (int j = 0; j < n; ++j) {
        const nlohmann::json& v = coordinates[static_cast<std::size_t>(j)];
        x[j] = v.is_number() ? v.get<double>() : std::numeric_limits<double>::quiet_NaN();
        if (std::isfinite(x[j]) && x[j] >= box.lower[j] && x[j] <= box.upper[j]) continue;
        const JsonField coordinate = point.array()[static_cast<std::size_t>(j)];
        coordinate.finite_number();  // throws for anything but a finite number
        coordinate.fail("expected a number in the box [" + format_number(box.lower[j]) + ", " +
                        format_number(box.upper[j]) + "], found " + format_number(x[j]));
      }
      out.points.push_back(std::move(x));
    }
    return out;
  } catch (const JsonFieldError& e) {
    throw std::runtime_error(e.what());  // this reader's contract: a runtime_error
  }
}

std::span<const ParameterField<ExternalParams>> ExternalParams::fields() {
  static const ParameterField<ExternalParams> kFields[] = {
      {"timeout_s", &ExternalParams::timeout_s,
       "longest wait for one reply of the external process (s); it is then killed"},
  };
  return kFields;
}

std::string ExternalParams::validate() const {
  return check_range(kAlgorithm, "timeout_s", timeout_s, 0.001, 86400.0);
}

ExternalOptimizer::ExternalOptimizer(std::string command, const Bounds& bounds,
                                     const RunConfig& config, const ExternalParams& params)
    : Optimizer(std::string(kExternalPrefix) + command, bounds, config),
      command_(std::move(command)),
      params_(params) {
  if (command_.find_first_not_of(" \t") == std::string::npos) {
    throw std::invalid_argument(
        "external: give a command after 'external:', e.g. "
        "external:/usr/bin/python3 scripts/external_random_search.py");
  }
  if (const std::string error = params_.validate(); !error.empty()) {
    throw std::invalid_argument(error);
  }
  if (!this->config().initial_positions.empty()) {
    throw std::invalid_argument(
        "external: initial positions are not passed to an external "
        "optimizer (" +
        std::to_string(this->config().initial_positions.size()) + " given)");
  }
}

ExternalOptimizer::~ExternalOptimizer() {
  if (pid_ > 0) {
    if (fd_ >= 0 && !stopped_) {
      const std::string reason(done() ? to_string(result().termination) : "aborted");
      const std::string line = nlohmann::json{{"type", "stop"}, {"reason", reason}}.dump() + "\n";
      // Best effort, without blocking: a client that does not read is killed below.
      (void)::send(fd_, line.data(), line.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
      ::shutdown(fd_, SHUT_WR);
    }
    if (try_reap(kStopGraceS).empty()) kill_and_reap();
  }
  if (fd_ >= 0) ::close(fd_);
}

std::string ExternalOptimizer::context() const {
  return "external optimizer '" + command_ + "' (seed " + std::to_string(config().seed) + ")";
}

void ExternalOptimizer::fail(const std::string& message) {
  error_ = context() + ": " + message;
  throw ExternalOptimizerError(error_);
}

void ExternalOptimizer::start() {
  int sv[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0)
    fail(std::string("cannot create the socket pair: ") + std::strerror(errno));
  posix_spawn_file_actions_t actions;
  posix_spawnattr_t attr;
  posix_spawn_file_actions_init(&actions);
  posix_spawnattr_init(&attr);
  posix_spawn_file_actions_adddup2(&actions, sv[1], STDIN_FILENO);
  posix_spawn_file_actions_adddup2(&actions, sv[1], STDOUT_FILENO);
  posix_spawnattr_setpgroup(&attr, 0);
  sigset_t default_signals;
  sigemptyset(&default_signals);
  sigaddset(&default_signals, SIGPIPE);
  posix_spawnattr_setsigdefault(&attr, &default_signals);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGDEF);
  std::string shell = "/bin/sh", dash_c = "-c", command = command_;
  char* argv[] = {shell.data(), dash_c.data(), command.data(), nullptr};
  const int rc = ::posix_spawn(&pid_, "/bin/sh", &actions, &attr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  ::close(sv[1]);
  fd_ = sv[0];
  if (rc != 0) {
    pid_ = -1;
    fail(std::string("cannot start /bin/sh: ") + std::strerror(rc));
  }

  const Bounds& box = bounds();
  nlohmann::json problem = {{"type", "problem"},
                            {"protocol", 1},
                            {"dimension", box.dimension()},
                            {"lower", vector_json(box.lower)},
                            {"upper", vector_json(box.upper)},
                            {"seed", config().seed},
                            {"max_evaluations", config().max_evaluations},
                            {"max_iterations", config().max_iterations}};
  send_line(problem.dump(), "the problem message");
}

std::string ExternalOptimizer::try_reap(double wait_s) {
  const Clock::time_point deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                        std::chrono::duration<double>(wait_s));
  for (;;) {
    int status = 0;
    const pid_t r = ::waitpid(pid_, &status, WNOHANG);
    if (r == pid_) {
      pid_ = -1;
      return describe_status(status);
    }
    if (r < 0) {  // not our child any more (reaped elsewhere)
      pid_ = -1;
      return "ended";
    }
    if (Clock::now() >= deadline) return "";
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

std::string ExternalOptimizer::kill_and_reap() {
  if (pid_ <= 0) return "ended";
  ::kill(-pid_, SIGKILL);
  int status = 0;
  while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
  pid_ = -1;
  return describe_status(status);
}

void ExternalOptimizer::send_line(const std::string& line, std::string_view what) {
  const std::string data = line + "\n";
  const Clock::time_point deadline =
      Clock::now() +
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(params_.timeout_s));
  std::size_t sent = 0;
  while (sent < data.size()) {
    pollfd p{fd_, POLLOUT, 0};
    const int ready = ::poll(&p, 1, remaining_ms(deadline));
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) {
      const std::string how = kill_and_reap();
      fail("did not read " + std::string(what) +
           " within timeout_s = " + format_number(params_.timeout_s) + " s; killed (" + how + ")");
    }
    const ssize_t n =
        ::send(fd_, data.data() + sent, data.size() - sent, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n < 0 && (errno == EINTR || errno == EAGAIN || errno == EWOULDBLOCK)) continue;
    if (n < 0) {
      std::string how = try_reap(1.0);
      if (how.empty()) how = "closed its stdin; " + kill_and_reap();
      fail("could not be sent " + std::string(what) + ": the process " + how);
    }
    sent += static_cast<std::size_t>(n);
  }
}

std::string ExternalOptimizer::read_line(std::string_view what) {
  const Clock::time_point deadline =
      Clock::now() +
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(params_.timeout_s));
  for (;;) {
    // A complete line in the buffer (empty lines are skipped).
    for (std::size_t eol; (eol = buffer_.find('\n')) != std::string::npos;) {
      std::string line = buffer_.substr(0, eol);
      buffer_.erase(0, eol + 1);
      ++lines_read_;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (line.find_first_not_of(" \t") != std::string::npos) return line;
    }
    if (buffer_.size() > kMaxLineBytes)
      fail("reply to " + std::string(what) + " is longer than " + std::to_string(kMaxLineBytes) +
           " bytes without a newline");
    pollfd p{fd_, POLLIN, 0};
    const int ready = ::poll(&p, 1, remaining_ms(deadline));
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) {
      const std::string how = kill_and_reap();
      fail("no reply to " + std::string(what) +
           " within timeout_s = " + format_number(params_.timeout_s) + " s; killed (" + how + ")");
    }
    char chunk[65536];
    const ssize_t n = ::recv(fd_, chunk, sizeof(chunk), 0);
    if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
    if (n <= 0) {
      // EOF: the process closed its stdout, normally by exiting.
      std::string how = try_reap(1.0);
      if (how.empty()) how = "closed its stdout; " + kill_and_reap();
      std::string message = "the process " + how + " before replying to " + std::string(what);
      if (!buffer_.empty()) message += " (unterminated output " + quoted_excerpt(buffer_) + ")";
      fail(message);
    }
    buffer_.append(chunk, static_cast<std::size_t>(n));
  }
}

void ExternalOptimizer::refuse_unasked_output(const std::string& after) {
  // What has arrived so far, without waiting (EOF is left to the next read to report).
  for (;;) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, 0) <= 0) break;
    char chunk[65536];
    const ssize_t n = ::recv(fd_, chunk, sizeof(chunk), MSG_DONTWAIT);
    if (n <= 0) break;
    buffer_.append(chunk, static_cast<std::size_t>(n));
    if (buffer_.size() > kMaxLineBytes) break;
  }
  const std::size_t start = buffer_.find_first_not_of(" \t\r\n");
  if (start == std::string::npos) return;
  // The line number of the unasked output: the blank lines before it count.
  const int line_no = lines_read_ + 1 +
                      static_cast<int>(std::count(buffer_.begin(), buffer_.begin() + start, '\n'));
  std::string line = buffer_.substr(start, buffer_.find('\n', start) - start);
  if (!line.empty() && line.back() == '\r') line.pop_back();
  fail("line " + std::to_string(line_no) + " of its output " + quoted_excerpt(line) +
       " answers no ask (it follows " + after + "; the protocol is one reply line per ask)");
}

void ExternalOptimizer::stop_and_refuse_leftover(const std::string& reason,
                                                 const std::string& after) {
  const std::string line = nlohmann::json{{"type", "stop"}, {"reason", reason}}.dump() + "\n";
  stopped_ = true;
  (void)::send(fd_, line.data(), line.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  ::shutdown(fd_, SHUT_WR);
  const auto deadline =
      Clock::now() + std::chrono::milliseconds(static_cast<int>(kStopGraceS * 1e3));
  while (buffer_.size() <= kMaxLineBytes) {
    pollfd p{fd_, POLLIN, 0};
    const int ready = ::poll(&p, 1, remaining_ms(deadline));
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) break;  // it has not exited within the grace: the destructor kills it
    char chunk[65536];
    const ssize_t n = ::recv(fd_, chunk, sizeof(chunk), 0);
    if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
    if (n <= 0) break;  // EOF: it exited
    buffer_.append(chunk, static_cast<std::size_t>(n));
  }
  refuse_unasked_output(after);
}

void ExternalOptimizer::launch() {
  if (!error_.empty()) throw ExternalOptimizerError(error_);
  if (pid_ < 0 && fd_ < 0) start();
}

void ExternalOptimizer::propose(std::vector<Eigen::VectorXd>& batch) {
  launch();
  const int k = iteration() + 1;
  const std::string what = "ask " + std::to_string(k);
  nlohmann::json ask = {{"type", "ask"}, {"iteration", k}};
  if (config().max_evaluations > 0)
    ask["remaining_evaluations"] = config().max_evaluations - result().evaluations;
  else
    ask["remaining_evaluations"] = nullptr;
  refuse_unasked_output(iteration() == 0 ? "the problem message"
                                         : "its reply to ask " + std::to_string(k - 1));
  send_line(ask.dump(), what);

  const std::string line = read_line(what);
  const std::string where =
      "reply to " + what + " (line " + std::to_string(lines_read_) + " of its output) ";
  refuse_unasked_output("its reply to " + what);
  ExternalReply reply;
  try {
    reply = parse_external_reply(line, bounds(), where);
  } catch (const std::runtime_error& e) {
    fail(e.what());
  }
  if (reply.error) fail("gave up at " + what + ": " + *reply.error);
  batch.reserve(batch.size() + reply.points.size());
  for (Eigen::VectorXd& x : reply.points) batch.push_back(std::move(x));
}

void ExternalOptimizer::accept(std::span<const Eigen::VectorXd>, std::span<const double> fitness) {
  const int k = iteration() + 1;
  nlohmann::json tell = {{"type", "tell"},
                         {"iteration", k},
                         {"fitness", std::vector<double>(fitness.begin(), fitness.end())}};
  // A failure here fails the run at its next ask (the batch just told is complete and counted).
  try {
    send_line(tell.dump(), "tell " + std::to_string(k));
  } catch (const ExternalOptimizerError&) {
    return;
  }
  // The run ends with this batch: no ask follows that would see a line left over, so look for
  // one now.
  if (const Termination ends = termination_after(k); ends != Termination::kNone)
    stop_and_refuse_leftover(std::string(to_string(ends)), "its reply to ask " + std::to_string(k));
}

}  // namespace insid::opt
