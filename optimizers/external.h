// An optimizer that runs in another process and speaks a JSON-lines protocol on its stdin/stdout
// (e.g. `--algo "external:/usr/bin/python3 scripts/external_random_search.py"`). The
// protocol is documented in optimizers/README.md ("External optimizers"); in short, insid sends
//   {"type":"problem", "protocol":1, "dimension":n, "lower":[...], "upper":[...], "seed":s,
//    "max_evaluations":E, "max_iterations":I}                       once, no reply;
//   {"type":"ask", "iteration":k, "remaining_evaluations":r}     -> {"points":[[...], ...]};
//   {"type":"tell", "iteration":k, "fitness":[...]}                 no reply;
//   {"type":"stop", "reason":"iterations"}                          no reply, then EOF.
// One process per run (a campaign's lock-step wave holds one per run), started by launch() or
// at the first ask() (never by the constructor, so that validating a campaign config starts
// nothing). A campaign launches a wave's processes before its first ask, so that their start-up
// (0.1-0.3 s for a Python interpreter with numpy) overlaps instead of adding up.
//
// Failures (ExternalOptimizerError, message naming the command, the run's seed and the
// offending line): the process exits or closes its stdout before replying (with its exit
// status or signal), does not reply within `timeout_s` (it is then killed), or replies with a
// line that is not a JSON object with valid "points" (not strict JSON within insid's reader's
// limits, base/json_reader.h: nested deeper than 64, a key twice; a key other than "points" or
// "error"; points not an array of arrays of `dimension` finite numbers inside the box, no
// point), or writes a line that no ask asked for (a second reply: one reply line per ask). A
// client may also reply {"error":"text"} to give up with its own reason. After a failure the run
// stays failed.
#pragma once

#include <sys/types.h>

#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "optimizers/optimizer.h"
#include "optimizers/parameters.h"

namespace insid::opt {

/// The `--algo` prefix of an external optimizer: "external:CMD".
inline constexpr std::string_view kExternalPrefix = "external:";
/// True for "external:..." names.
inline bool is_external_algorithm(std::string_view algorithm) {
  return algorithm.substr(0, kExternalPrefix.size()) == kExternalPrefix;
}

struct ExternalParams {
  static constexpr std::string_view kAlgorithm = "external";

  double timeout_s = 60.0;  ///< longest wait for one reply (s); the process is then killed

  static std::span<const ParameterField<ExternalParams>> fields();
  std::string validate() const;
  ParameterList list() const { return list_parameters(*this); }
  ParameterInfoList info() const { return list_parameter_info(*this); }
  void set(std::string_view name, double value) { set_parameter(*this, name, value); }
  static ExternalParams from_map(const ParameterMap& overrides) {
    return parameters_from_map<ExternalParams>(overrides);
  }
};

/// A failure of the external process or of its replies.
class ExternalOptimizerError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// One reply line of the protocol: the points, or the client's own reason to give up.
struct ExternalReply {
  std::vector<Eigen::VectorXd> points;
  std::optional<std::string> error;  ///< {"error": "..."}: the client gives up
};

/// Reads one reply line (strict JSON within base/json_reader.h's limits, the line at most
/// 256 MiB; its fields through base/json_object.h: keys "points" or "error" only) against `box`.
/// Throws std::runtime_error starting with `where` and the line (e.g. "reply to ask 1 (line 1 of
/// its output) '{...}'"), then the path of the field at fault and what was expected and found
/// (": points[0][2]: expected a number in the box [-1, 1], found 2").
ExternalReply parse_external_reply(std::string_view line, const Bounds& box,
                                   const std::string& where);

class ExternalOptimizer final : public Optimizer {
 public:
  /// `command` runs under /bin/sh -c in the current directory. Throws std::invalid_argument on
  /// an empty command, invalid params, bounds or config, or initial positions (not passed on).
  ExternalOptimizer(std::string command, const Bounds& bounds, const RunConfig& config,
                    const ExternalParams& params = {});
  /// Sends "stop" when the process still runs, waits briefly for it to exit, else kills it.
  ~ExternalOptimizer() override;

  ParameterList parameters() const override { return params_.list(); }
  const std::string& command() const { return command_; }
  /// Starts the process and sends the problem message now, without waiting for any reply (a
  /// no-op once started). Throws ExternalOptimizerError as ask() would (the run then stays
  /// failed).
  void launch();

 protected:
  void propose(std::vector<Eigen::VectorXd>& batch) override;
  void accept(std::span<const Eigen::VectorXd> batch, std::span<const double> fitness) override;
  std::string phase() const override { return iteration() == 0 ? "initial" : "external"; }

 private:
  void start();
  /// Writes one line (a '\n' is appended) within the timeout; throws on failure.
  void send_line(const std::string& line, std::string_view what);
  /// Reads the next non-empty line within the timeout; throws on EOF or timeout.
  std::string read_line(std::string_view what);
  /// Fails when the process has written anything but blank lines that no ask asked for (read
  /// without waiting): after the problem message, or after `after`, the reply it already gave.
  void refuse_unasked_output(const std::string& after);
  /// The run's last batch was told: sends "stop" (`reason`), closes the pipe's write side and
  /// reads what the process writes until it exits (at most the stop grace). A line left there
  /// answers no ask: a second reply that arrived after the next ask was sent, and was taken as
  /// that ask's reply, is caught here whatever the timing. Throws ExternalOptimizerError then.
  void stop_and_refuse_leftover(const std::string& reason, const std::string& after);
  /// Kills the process group and reaps it; returns how it ended ("exited with status 3").
  std::string kill_and_reap();
  /// Reaps the process if it has ended within `wait_s`; returns how it ended or "".
  std::string try_reap(double wait_s);
  [[noreturn]] void fail(const std::string& message);
  std::string context() const;

  std::string command_;
  ExternalParams params_;
  pid_t pid_ = -1;
  int fd_ = -1;           ///< our end of the socket pair (the child's stdin and stdout)
  std::string buffer_;    ///< bytes read past the last line
  int lines_read_ = 0;    ///< lines of the child's stdout read so far (for messages)
  std::string error_;     ///< set once the run has failed
  bool stopped_ = false;  ///< "stop" sent and the write side closed (stop_and_refuse_leftover)
};

}  // namespace insid::opt
