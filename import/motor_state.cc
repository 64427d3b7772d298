#include "import/motor_state.h"

#include <algorithm>
#include <limits>

#include "base/number_text.h"

namespace insid::importers {

std::optional<MotorRuns> motor_runs(const std::vector<std::vector<double>>& rows,
                                    const std::vector<std::size_t>& kept, double seconds_per_stamp,
                                    const std::string& series, std::vector<std::string>& notes) {
  std::vector<double> t_s;
  std::vector<std::array<double, kMotorChannels>> outputs;
  for (const std::size_t k : kept) {
    t_s.push_back(rows[k][0] * seconds_per_stamp);
    std::array<double, kMotorChannels> o;
    for (int c = 0; c < kMotorChannels; ++c) o[c] = rows[k][static_cast<std::size_t>(c) + 1];
    outputs.push_back(o);
  }
  std::vector<std::size_t> usable;
  for (std::size_t k = 0; k < outputs.size() && k < t_s.size(); ++k)
    if (std::all_of(outputs[k].begin(), outputs[k].end(),
                    [](double us) { return us >= kMotorPwmMinUs && us <= kMotorPwmMaxUs; }))
      usable.push_back(k);
  if (usable.size() < 2) {
    notes.push_back(series + ": fewer than 2 records with PWM widths (" +
                    number_text(kMotorPwmMinUs, 4) + "-" + number_text(kMotorPwmMaxUs, 4) +
                    " us): the motor state is unknown (no motor offsets)");
    return std::nullopt;
  }
  if (usable.size() < outputs.size())
    notes.push_back(series + ": " + std::to_string(outputs.size() - usable.size()) +
                    " records with an output outside " + number_text(kMotorPwmMinUs, 4) + "-" +
                    number_text(kMotorPwmMaxUs, 4) + " us left out of the motor state");
  std::array<double, kMotorChannels> lowest;
  lowest.fill(std::numeric_limits<double>::infinity());
  for (const std::size_t k : usable)
    for (int c = 0; c < kMotorChannels; ++c) lowest[c] = std::min(lowest[c], outputs[k][c]);
  MotorRuns out;
  bool running = false;
  for (const std::size_t k : usable) {
    bool on = false;
    for (int c = 0; c < kMotorChannels; ++c) on = on || outputs[k][c] > lowest[c] + kMotorRunningUs;
    if (on && !running && (out.on_s.empty() || t_s[k] - out.on_s.back().second >= kMotorOffMergeS))
      out.on_s.emplace_back(t_s[k], t_s[k]);
    if (on || running) out.on_s.back().second = t_s[k];  // until the first record off
    running = on;
  }
  std::erase_if(out.on_s, [](const std::pair<double, double>& run) {
    return run.second - run.first < kMotorMinRunS;
  });
  std::string lows;
  for (int c = 0; c < kMotorChannels; ++c) {
    if (c > 0) lows += '/';
    lows += number_text(lowest[c], 6);
  }
  out.source = series + " more than " + number_text(kMotorRunningUs, 4) +
               " us above their lowest (" + lows + " us)";
  return out;
}

}  // namespace insid::importers
