// The timestamps of a logged series (a ULog topic, a DataFlash message), read as a binary log
// gives them: mostly increasing, with a damaged stamp now and then. Which messages to keep, and
// what was dropped, said in the provenance and a note naming each place by its byte offset.
#pragma once

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace insid::importers {

/// A break in a series' timestamps (one flipped bit in a stamp must cost that message, not the
/// rows after it): a run of messages whose stamps do not continue the increasing series
/// (dropped), or a forward step that the stamps after it continue (kept: a gap in the data,
/// reported by the assembly as one).
struct TimestampJump {
  std::size_t message = 0;  ///< 1-based index in the topic of its first message
  std::size_t byte = 0;     ///< byte offset in the file of that message's timestamp field
  double stamp_s = 0.0;     ///< its stamp (s on the log's clock)
  double previous_s = std::numeric_limits<double>::quiet_NaN();  ///< the kept stamp before it
  std::size_t messages_dropped = 0;  ///< the run's length; 0 for a kept forward jump
};

struct TimestampSelection {
  std::vector<std::size_t> kept;  ///< 0-based indices of the messages kept, stamps increasing
  std::size_t repeated = 0;       ///< the same stamp as the message right before it
  std::size_t dropped_by_jumps = 0;
  std::vector<TimestampJump> jumps;  ///< in message order
};

/// The messages of one topic whose stamps (us, in file order) are consistent, and what was not:
///  1. a message with the same stamp as the one right before it is a repeat (the first is kept);
///  2. of the rest, the longest strictly increasing series is kept: a stamp that jumps ahead or
///     back and returns costs that message only, and after a clock that went back only the stamps
///     beyond the last one before it continue the series;
///  3. a forward step longer than kJumpMinS and kJumpMedianSteps median steps splits the series
///     into runs; a run shorter than kJumpMinRun messages (a stamp that jumped ahead at the end of
///     the log, or back at its start) is dropped, unless no run is that long.
/// Each maximal run of dropped messages is one jump; each forward step left longer than the
/// threshold is a kept jump. `byte_offsets` (the stamps' offsets in the file) name them.
TimestampSelection select_increasing_stamps(const std::vector<double>& stamps_us,
                                            const std::vector<std::size_t>& byte_offsets);
inline constexpr double kJumpMinS = 1.0;
inline constexpr double kJumpMedianSteps = 100.0;
inline constexpr std::size_t kJumpMinRun = 3;

/// The selection in `prov["timestamps"]` (counts and the first jumps, each with its message and
/// byte) and, when anything jumped, one note: "`series`: N timestamp jumps (K of M messages
/// dropped): message i (`field` at byte b) stamped ...". `stamps_us` as given to the selection.
void record_stamp_selection(const TimestampSelection& sel, const std::vector<double>& stamps_us,
                            const std::string& series, const std::string& field,
                            nlohmann::json& prov, std::vector<std::string>& notes);

}  // namespace insid::importers
