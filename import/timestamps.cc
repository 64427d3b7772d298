#include "import/timestamps.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>

#include "base/number_text.h"

namespace insid::importers {
namespace {

std::string seconds(double s) {
  return number_text(s, 6, Digits::kAfterPoint) + " s";  // microseconds, as logged
}

// The jumps listed one by one in the provenance (all are counted) and in a note.
constexpr std::size_t kJumpsListed = 100;
constexpr std::size_t kJumpsInNote = 3;

}  // namespace

TimestampSelection select_increasing_stamps(const std::vector<double>& stamps_us,
                                            const std::vector<std::size_t>& byte_offsets) {
  if (byte_offsets.size() != stamps_us.size())
    throw std::logic_error("select_increasing_stamps: one byte offset per stamp");
  const std::size_t n = stamps_us.size();
  TimestampSelection out;
  // 1. Repeats of the stamp right before.
  std::vector<char> repeat(n, 0);
  std::vector<std::size_t> candidates;
  candidates.reserve(n);
  for (std::size_t k = 0; k < n; ++k) {
    if (k > 0 && stamps_us[k] == stamps_us[k - 1]) {
      repeat[k] = 1;
      ++out.repeated;
    } else {
      candidates.push_back(k);
    }
  }
  // 2. The longest strictly increasing series (patience sorting, O(n log n)), built from the end
  //    as the longest decreasing one backwards: of equally long series it takes the earlier
  //    messages, so after a clock that went back the stamps that repeat earlier times are dropped.
  std::vector<std::size_t> heads;  // heads[len - 1]: candidate starting the best series of len
  std::vector<std::ptrdiff_t> next(candidates.size(), -1);
  for (std::size_t i = candidates.size(); i-- > 0;) {
    const double t = stamps_us[candidates[i]];
    const auto pos = std::lower_bound(heads.begin(), heads.end(), t, [&](std::size_t c, double v) {
      return stamps_us[candidates[c]] > v;
    });
    if (pos != heads.begin()) next[i] = static_cast<std::ptrdiff_t>(*(pos - 1));
    if (pos == heads.end())
      heads.push_back(i);
    else
      *pos = i;
  }
  std::vector<std::size_t> kept;
  for (std::ptrdiff_t i = heads.empty() ? -1 : static_cast<std::ptrdiff_t>(heads.back()); i >= 0;
       i = next[static_cast<std::size_t>(i)])
    kept.push_back(candidates[static_cast<std::size_t>(i)]);
  // 3. Runs between long forward steps; runs too short to confirm their stamps are dropped.
  std::vector<double> steps;
  for (std::size_t i = 1; i < kept.size(); ++i)
    steps.push_back(stamps_us[kept[i]] - stamps_us[kept[i - 1]]);
  double jump_us = kJumpMinS * 1e6;
  if (!steps.empty()) {
    std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2),
                     steps.end());
    jump_us = std::max(jump_us, kJumpMedianSteps * steps[steps.size() / 2]);
  }
  {
    std::vector<std::pair<std::size_t, std::size_t>> runs;  // [begin, end) in kept
    std::size_t begin = 0, longest = 0;
    for (std::size_t i = 1; i <= kept.size(); ++i)
      if (i == kept.size() || stamps_us[kept[i]] - stamps_us[kept[i - 1]] > jump_us) {
        runs.emplace_back(begin, i);
        longest = std::max(longest, i - begin);
        begin = i;
      }
    if (runs.size() > 1 && longest >= kJumpMinRun) {
      std::vector<std::size_t> confirmed;
      for (const auto& [b, e] : runs)
        if (e - b >= kJumpMinRun)
          confirmed.insert(confirmed.end(), kept.begin() + b, kept.begin() + e);
      kept = std::move(confirmed);
    }
  }
  out.kept = kept;
  // 4. The jumps, in message order: runs of dropped messages, and forward steps kept.
  std::vector<char> is_kept(n, 0);
  for (std::size_t k : kept) is_kept[k] = 1;
  double last_kept = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t k = 0; k < n;) {
    if (is_kept[k]) {
      if (!std::isnan(last_kept) && stamps_us[k] - last_kept > jump_us)
        out.jumps.push_back({k + 1, byte_offsets[k], stamps_us[k] * 1e-6, last_kept * 1e-6, 0});
      last_kept = stamps_us[k++];
      continue;
    }
    if (repeat[k]) {
      ++k;
      continue;
    }
    TimestampJump j{k + 1, byte_offsets[k], stamps_us[k] * 1e-6, last_kept * 1e-6, 0};
    for (; k < n && !is_kept[k]; ++k)
      if (!repeat[k]) ++j.messages_dropped;
    out.dropped_by_jumps += j.messages_dropped;
    out.jumps.push_back(j);
  }
  return out;
}

void record_stamp_selection(const TimestampSelection& sel, const std::vector<double>& stamps_us,
                            const std::string& series, const std::string& field,
                            nlohmann::json& prov, std::vector<std::string>& notes) {
  nlohmann::json list = nlohmann::json::array();
  std::size_t dropped_jumps = 0;
  for (const TimestampJump& j : sel.jumps) {
    if (j.messages_dropped > 0) ++dropped_jumps;
    if (list.size() < kJumpsListed)
      list.push_back({{"message", j.message},
                      {"byte", j.byte},
                      {"stamp_s", j.stamp_s},
                      {"previous_s", std::isnan(j.previous_s) ? nlohmann::json(nullptr)
                                                              : nlohmann::json(j.previous_s)},
                      {"messages_dropped", j.messages_dropped}});
  }
  prov["timestamps"] = {{"field", field},
                        {"messages", stamps_us.size()},
                        {"kept", sel.kept.size()},
                        {"repeated", sel.repeated},
                        {"jumps", sel.jumps.size()},
                        {"jumps_dropped", dropped_jumps},
                        {"dropped_by_jumps", sel.dropped_by_jumps},
                        {"jump_list", list}};
  if (!sel.jumps.empty()) {
    std::string note = series + ": " + std::to_string(sel.jumps.size()) + " timestamp jump" +
                       (sel.jumps.size() == 1 ? "" : "s") + " (" +
                       std::to_string(sel.dropped_by_jumps) + " of " +
                       std::to_string(stamps_us.size()) + " messages dropped):";
    for (std::size_t i = 0; i < sel.jumps.size() && i < kJumpsInNote; ++i) {
      const TimestampJump& j = sel.jumps[i];
      note += std::string(i == 0 ? " " : "; ") + "message " + std::to_string(j.message) + " (" +
              field + " at byte " + std::to_string(j.byte) + ") stamped " + seconds(j.stamp_s) +
              (std::isnan(j.previous_s)
                   ? std::string(", before any kept stamp")
                   : std::string(", ") + (j.stamp_s > j.previous_s ? "+" : "-") +
                         seconds(std::fabs(j.stamp_s - j.previous_s)) +
                         " from the message kept before it (" + seconds(j.previous_s) + ")") +
              (j.messages_dropped > 0
                   ? ": dropped" + (j.messages_dropped > 1
                                        ? " with the " + std::to_string(j.messages_dropped - 1) +
                                              " messages after it"
                                        : std::string())
                   : ": kept, the stamps after it continue from it (a gap)");
    }
    if (sel.jumps.size() > kJumpsInNote)
      note +=
          "; and " + std::to_string(sel.jumps.size() - kJumpsInNote) + " more (provenance.json)";
    notes.push_back(note);
  }
}

}  // namespace insid::importers
