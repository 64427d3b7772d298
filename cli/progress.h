// One progress printer for every long insid command: on a terminal one status line
// rewritten in place with '\r'; on a file or pipe plain newline-terminated lines at a bounded
// rate, so that a log stays one line per event; nothing with --quiet.
//
//   ProgressPrinter progress("insid sweep", verbosity);
//   progress.note("preparing scenario rich");          // a line of its own (not with --quiet)
//   progress.status("runs 3/20, elapsed 4 s, ETA 22 s"); // the live line
//   progress.finish();                                  // ends the live line
//
// Verbosity: kQuiet prints nothing (errors are main's); kNormal notes and the status line
// (rate-limited off a terminal: at most one line per min_interval_s, the last one always);
// kVerbose also detail() lines and every status update as a line of its own (no rate limit).
#pragma once

#include <chrono>
#include <cstdio>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

namespace insid::cli {

enum class Verbosity { kQuiet, kNormal, kVerbose };

/// Adds --quiet and --verbose (mutually exclusive) to `cmd`, stored in `verbosity`.
void add_verbosity_flags(CLI::App* cmd, Verbosity& verbosity);

class ProgressPrinter {
 public:
  /// Plain lines off a terminal: at most one per this many seconds (the last is always shown).
  static constexpr double kDefaultMinIntervalS = 5.0;

  /// `prefix` starts every line ("insid sweep"). `terminal`: whether `stream` is a terminal
  /// (default: isatty on its descriptor).
  ProgressPrinter(std::string prefix, Verbosity verbosity, std::FILE* stream = stderr,
                  std::optional<bool> terminal = std::nullopt,
                  double min_interval_s = kDefaultMinIntervalS);
  ~ProgressPrinter();
  ProgressPrinter(const ProgressPrinter&) = delete;
  ProgressPrinter& operator=(const ProgressPrinter&) = delete;

  /// A line of its own ("prefix: text"), unless quiet; ends a pending live line first.
  void note(const std::string& text);
  /// Like note(), only with --verbose.
  void detail(const std::string& text);
  /// The live status: rewrites the line on a terminal; off a terminal a plain line when
  /// min_interval_s has passed since the last (always with --verbose), else kept for finish().
  void status(const std::string& text);
  /// Ends the live line: a newline on a terminal; off a terminal the last status if it was held
  /// back by the rate limit. Safe to call twice.
  void finish();

  bool quiet() const { return verbosity_ == Verbosity::kQuiet; }
  bool verbose() const { return verbosity_ == Verbosity::kVerbose; }
  bool terminal() const { return terminal_; }

 private:
  void end_live_line();

  std::string prefix_;
  Verbosity verbosity_;
  std::FILE* stream_;
  bool terminal_;
  double min_interval_s_;
  bool live_line_open_ = false;  // terminal: a '\r' line is on screen
  std::string held_back_;        // non-terminal: the last status not yet printed
  std::optional<std::chrono::steady_clock::time_point> last_line_;
  std::size_t last_width_ = 0;  // terminal: pad over a longer previous status
};

}  // namespace insid::cli
