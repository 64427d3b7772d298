#include "cli/progress.h"

#include <unistd.h>

#include <utility>

namespace insid::cli {

void add_verbosity_flags(CLI::App* cmd, Verbosity& verbosity) {
  CLI::Option* quiet = cmd->add_flag_callback(
      "--quiet,-q", [&verbosity] { verbosity = Verbosity::kQuiet; },
      "no progress or closing summary on stderr (errors are still printed)");
  CLI::Option* verbose = cmd->add_flag_callback(
      "--verbose,-v", [&verbosity] { verbosity = Verbosity::kVerbose; },
      "every progress update on a line of its own (no rate limit) and extra detail");
  quiet->excludes(verbose);
}

ProgressPrinter::ProgressPrinter(std::string prefix, Verbosity verbosity, std::FILE* stream,
                                 std::optional<bool> terminal, double min_interval_s)
    : prefix_(std::move(prefix)),
      verbosity_(verbosity),
      stream_(stream),
      terminal_(terminal ? *terminal : ::isatty(::fileno(stream)) == 1),
      min_interval_s_(min_interval_s) {}

ProgressPrinter::~ProgressPrinter() { finish(); }

void ProgressPrinter::end_live_line() {
  if (!live_line_open_) return;
  std::fputc('\n', stream_);
  live_line_open_ = false;
  last_width_ = 0;
}

void ProgressPrinter::note(const std::string& text) {
  if (quiet()) return;
  end_live_line();
  std::fprintf(stream_, "%s: %s\n", prefix_.c_str(), text.c_str());
  std::fflush(stream_);
}

void ProgressPrinter::detail(const std::string& text) {
  if (verbose()) note(text);
}

void ProgressPrinter::status(const std::string& text) {
  if (quiet()) return;
  const std::string line = prefix_ + ": " + text;
  if (terminal_ && !verbose()) {
    // Pad with spaces over the rest of a longer previous line.
    const std::size_t pad = last_width_ > line.size() ? last_width_ - line.size() : 0;
    std::fprintf(stream_, "\r%s%s", line.c_str(), std::string(pad, ' ').c_str());
    std::fflush(stream_);
    live_line_open_ = true;
    last_width_ = line.size();
    return;
  }
  const auto now = std::chrono::steady_clock::now();
  if (verbose() || !last_line_ ||
      std::chrono::duration<double>(now - *last_line_).count() >= min_interval_s_) {
    std::fprintf(stream_, "%s\n", line.c_str());
    std::fflush(stream_);
    last_line_ = now;
    held_back_.clear();
  } else {
    held_back_ = line;
  }
}

void ProgressPrinter::finish() {
  end_live_line();
  if (!held_back_.empty()) {
    std::fprintf(stream_, "%s\n", held_back_.c_str());
    std::fflush(stream_);
    held_back_.clear();
  }
}

}  // namespace insid::cli
