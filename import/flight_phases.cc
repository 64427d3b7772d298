#include "import/flight_phases.h"
#include "base/number_text.h"
#include "model/units.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace insid::importers {
namespace {

struct Block {
  double t_start_s = 0.0;
  double accel_sd_mps2 = 0.0;  // sample sd of |f|
  double f_z_mean_mps2 = 0.0;
  std::size_t n = 0;
};

nlohmann::json opt(const std::optional<double>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

}  // namespace

std::string FlightPhaseOptions::validate() const {
  const auto bad = [](double v, double lo, double hi) {
    return !(std::isfinite(v) && v > lo && v <= hi);
  };
  if (bad(block_s, 0.0, 10.0))
    return "block_s " + number_text(block_s, 3, Digits::kAfterPoint) + ": must be in (0, 10] s";
  if (bad(spin_accel_sd_mps2, 0.0, 100.0)) return "spin_accel_sd_mps2: must be in (0, 100]";
  if (spin_window_blocks < 1 || spin_window_blocks > 1000)
    return "spin_window_blocks: must be in 1-1000";
  if (bad(spin_fraction, 0.0, 1.0)) return "spin_fraction: must be in (0, 1]";
  if (bad(climb_m, 0.0, 1000.0)) return "climb_m: must be in (0, 1000]";
  if (bad(speed_mps, 0.0, 1000.0)) return "speed_mps: must be in (0, 1000]";
  if (bad(impact_g, 1.0, 1000.0)) return "impact_g: must be in (1, 1000]";
  if (bad(inverted_g, 0.0, 1.0)) return "inverted_g: must be in (0, 1]";
  if (bad(landed_m, 0.0, 1000.0)) return "landed_m: must be in (0, 1000]";
  if (!(std::isfinite(crash_margin_s) && crash_margin_s >= 0.0 && crash_margin_s <= 60.0))
    return "crash_margin_s: must be in [0, 60]";
  return "";
}

FlightPhases find_flight_phases(const FlightPhaseInput& in, const FlightPhaseOptions& options,
                                const std::vector<double>& ground_gaps_end_s) {
  if (const std::string e = options.validate(); !e.empty()) throw std::invalid_argument(e);
  const std::size_t n = in.imu_boot_s.size();
  if (n == 0 || in.f_b_mps2.size() != n || in.omega_b_rad_s.size() != n)
    throw std::invalid_argument("find_flight_phases: IMU series empty or of different lengths");
  if (in.gnss_alt_m.size() != in.gnss_boot_s.size() ||
      in.gnss_speed_mps.size() != in.gnss_boot_s.size())
    throw std::invalid_argument("find_flight_phases: GNSS series of different lengths");

  FlightPhases out;
  out.climb_m = options.climb_m;
  out.speed_mps = options.speed_mps;
  out.log_start_s = in.imu_boot_s.front();
  out.log_end_s = in.imu_boot_s.back();
  out.airborne_end_s = out.log_end_s;
  out.ended_by = "end of log";
  if (!in.gnss_boot_s.empty()) out.gnss_fix_from_s = in.gnss_boot_s.front();

  // 0.5 s blocks from the first record: the scatter of |f| (spinning propellers) and the mean
  // body-z specific force (upright: -1 g).
  std::vector<Block> blocks;
  for (std::size_t k = 0; k < n;) {
    Block b;
    b.t_start_s =
        out.log_start_s +
        std::floor((in.imu_boot_s[k] - out.log_start_s) / options.block_s) * options.block_s;
    double sum = 0, sum2 = 0, fz = 0;
    std::size_t j = k;
    // The record that opens the block always belongs to it: stamps so large that adding block_s
    // changes nothing (damage) must not leave an empty block and no progress.
    for (; j < n && (j == k || in.imu_boot_s[j] < b.t_start_s + options.block_s); ++j) {
      const double a = in.f_b_mps2[j].norm();
      sum += a, sum2 += a * a, fz += in.f_b_mps2[j].z();
    }
    b.n = j - k;
    const double mean = sum / static_cast<double>(b.n);
    b.accel_sd_mps2 =
        b.n > 1 ? std::sqrt(std::max(0.0, (sum2 - static_cast<double>(b.n) * mean * mean) /
                                              static_cast<double>(b.n - 1)))
                : 0.0;
    b.f_z_mean_mps2 = fz / static_cast<double>(b.n);
    blocks.push_back(b);
    k = j;
  }
  const auto spinning = [&](std::size_t k) {
    return blocks[k].n >= 3 && blocks[k].accel_sd_mps2 > options.spin_accel_sd_mps2;
  };
  // Block k starts a run of spinning (spin) or still (!spin) blocks: it is one, and so are
  // spin_fraction of the spin_window_blocks from it.
  const auto run_of = [&](std::size_t k, bool spin) {
    const auto w = static_cast<std::size_t>(options.spin_window_blocks);
    if (k + w > blocks.size() || spinning(k) != spin) return false;
    std::size_t agree = 0;
    for (std::size_t i = 0; i < w; ++i) agree += spinning(k + i) == spin;
    return static_cast<double>(agree) >= options.spin_fraction * static_cast<double>(w) - 1e-9;
  };

  std::size_t spin_block = blocks.size();
  for (std::size_t k = 0; k < blocks.size(); ++k)
    if (run_of(k, true)) {
      spin_block = k;
      break;
    }
  if (spin_block == blocks.size()) return out;  // the motors never turn: all ground
  out.motors_on_s = blocks[spin_block].t_start_s;

  // The ground altitude: the median of the fixes before the spin-up.
  std::vector<double> ground;
  for (std::size_t k = 0; k < in.gnss_boot_s.size(); ++k)
    if (in.gnss_boot_s[k] < *out.motors_on_s) ground.push_back(in.gnss_alt_m[k]);
  const bool have_ground = !ground.empty();
  if (have_ground) {
    std::nth_element(ground.begin(),
                     ground.begin() + static_cast<std::ptrdiff_t>(ground.size() / 2), ground.end());
    out.ground_alt_m = ground[ground.size() / 2];
  }
  for (std::size_t k = 0; k < in.gnss_boot_s.size(); ++k) {
    if (in.gnss_boot_s[k] < *out.motors_on_s) continue;
    if ((have_ground && in.gnss_alt_m[k] - out.ground_alt_m > options.climb_m) ||
        in.gnss_speed_mps[k] > options.speed_mps) {
      out.takeoff_s = in.gnss_boot_s[k];
      break;
    }
  }
  if (!out.takeoff_s) return out;

  // How the flight ended: the first impact, upside-down block or landing after the take-off.
  for (std::size_t k = 0; k < n; ++k)
    if (in.imu_boot_s[k] >= *out.takeoff_s &&
        in.f_b_mps2[k].norm() > options.impact_g * kStandardGravity_mps2) {
      out.crash_s = in.imu_boot_s[k];
      break;
    }
  for (std::size_t k = 0; k < blocks.size(); ++k)
    if (blocks[k].t_start_s >= *out.takeoff_s && blocks[k].n >= 3 &&
        blocks[k].f_z_mean_mps2 > options.inverted_g * kStandardGravity_mps2) {
      out.inverted_s = blocks[k].t_start_s;
      break;
    }
  for (std::size_t k = 0; k < blocks.size(); ++k) {
    if (blocks[k].t_start_s < *out.takeoff_s || !run_of(k, false)) continue;
    // Near the ground: the fix closest in time.
    std::size_t best = in.gnss_boot_s.size();
    for (std::size_t g = 0; g < in.gnss_boot_s.size(); ++g)
      if (best == in.gnss_boot_s.size() ||
          std::fabs(in.gnss_boot_s[g] - blocks[k].t_start_s) <
              std::fabs(in.gnss_boot_s[best] - blocks[k].t_start_s))
        best = g;
    if (best < in.gnss_boot_s.size() && have_ground &&
        std::fabs(in.gnss_alt_m[best] - out.ground_alt_m) <= options.landed_m) {
      out.landed_s = blocks[k].t_start_s;
      break;
    }
  }
  const std::pair<std::optional<double>, const char*> ends[] = {
      {out.crash_s, "crash"}, {out.inverted_s, "inverted"}, {out.landed_s, "landing"}};
  for (const auto& [t, why] : ends)
    if (t && *t < out.airborne_end_s) {
      out.airborne_end_s = *t;
      out.ended_by = why;
    }
  for (std::size_t k = 0; k < n; ++k)
    if (in.imu_boot_s[k] >= *out.takeoff_s && in.imu_boot_s[k] < out.airborne_end_s) {
      out.peak_airborne_g =
          std::max(out.peak_airborne_g, in.f_b_mps2[k].norm() / kStandardGravity_mps2);
      out.peak_airborne_rate_deg_s =
          std::max(out.peak_airborne_rate_deg_s, in.omega_b_rad_s[k].norm() * kRadToDeg);
    }

  // The suggested window: after the fix and any logging gap on the ground, up to the landing
  // or the log's end, or crash_margin_s before a crash.
  out.suggest_t_start_s = out.log_start_s;
  if (out.gnss_fix_from_s)
    out.suggest_t_start_s = std::max(out.suggest_t_start_s, *out.gnss_fix_from_s);
  for (const double end : ground_gaps_end_s)
    if (end < *out.takeoff_s) out.suggest_t_start_s = std::max(out.suggest_t_start_s, end);
  out.suggest_t_end_s = out.ended_by == "crash" || out.ended_by == "inverted"
                            ? out.airborne_end_s - options.crash_margin_s
                            : out.log_end_s;
  return out;
}

nlohmann::json FlightPhases::to_json() const {
  return {{"clock", "boot s (the autopilot's time since boot, the clock of --t-start/--t-end)"},
          {"method",
           "IMU: 0.5 s blocks of |specific force| scatter (motors), body-z specific "
           "force (upside down), |specific force| peaks (impact); GPS fixes: altitude "
           "above the ground median and horizontal speed (take-off)"},
          {"log_start_boot_s", log_start_s},
          {"log_end_boot_s", log_end_s},
          {"gnss_fix_from_boot_s", opt(gnss_fix_from_s)},
          {"motors_on_boot_s", opt(motors_on_s)},
          {"takeoff_boot_s", opt(takeoff_s)},
          {"ground_alt_m", ground_alt_m},
          {"crash_boot_s", opt(crash_s)},
          {"inverted_boot_s", opt(inverted_s)},
          {"landed_boot_s", opt(landed_s)},
          {"airborne", airborne() ? nlohmann::json{{"from_boot_s", *takeoff_s},
                                                   {"to_boot_s", airborne_end_s},
                                                   {"ended_by", ended_by},
                                                   {"peak_specific_force_g", peak_airborne_g},
                                                   {"peak_rate_deg_s", peak_airborne_rate_deg_s}}
                                  : nlohmann::json(nullptr)},
          {"suggested_window_boot_s",
           airborne() ? nlohmann::json{{"t_start", suggest_t_start_s}, {"t_end", suggest_t_end_s}}
                      : nlohmann::json(nullptr)}};
}

std::vector<std::string> FlightPhases::lines() const {
  std::vector<std::string> l;
  l.push_back(
      "flight phases (boot s; from the IMU's specific force and rates and the GPS "
      "altitude and speed):");
  const double ground_end = motors_on_s ? *motors_on_s : log_end_s;
  l.push_back("  ground       " + number_text(log_start_s, 2, Digits::kAfterPoint) + " - " +
              number_text(ground_end, 2, Digits::kAfterPoint) + " s" +
              (gnss_fix_from_s ? " (GPS fix from " +
                                     number_text(*gnss_fix_from_s, 2, Digits::kAfterPoint) + " s)"
                               : ""));
  if (!motors_on_s) {
    l.push_back("  the motors never turn (|specific force| never scatters): no flight found");
    return l;
  }
  l.push_back("  motors on    " + number_text(*motors_on_s, 2, Digits::kAfterPoint) + " s");
  if (!takeoff_s) {
    l.push_back("  no take-off found (no GPS fix above the ground altitude or moving)");
    return l;
  }
  l.push_back("  take-off     " + number_text(*takeoff_s, 2, Digits::kAfterPoint) +
              " s (the first GPS fix " + number_text(climb_m, 1, Digits::kAfterPoint) +
              " m above the ground's " + number_text(ground_alt_m, 1, Digits::kAfterPoint) +
              " m or faster than " + number_text(speed_mps, 1, Digits::kAfterPoint) + " m/s)");
  l.push_back("  airborne     " + number_text(*takeoff_s, 2, Digits::kAfterPoint) + " - " +
              number_text(airborne_end_s, 2, Digits::kAfterPoint) + " s (" +
              number_text(airborne_end_s - *takeoff_s, 1, Digits::kAfterPoint) + " s; peak " +
              number_text(peak_airborne_g, 1, Digits::kAfterPoint) + " g, " +
              number_text(peak_airborne_rate_deg_s, 0, Digits::kAfterPoint) + " deg/s)");
  if (crash_s)
    l.push_back("  crash        " + number_text(*crash_s, 2, Digits::kAfterPoint) + " s (impact)");
  if (inverted_s)
    l.push_back("  upside down  from " + number_text(*inverted_s, 2, Digits::kAfterPoint) + " s");
  if (landed_s)
    l.push_back("  landed       " + number_text(*landed_s, 2, Digits::kAfterPoint) +
                " s (motors stopped)");
  l.push_back("  flight without what ended it: --t-start " +
              number_text(suggest_t_start_s, 2, Digits::kAfterPoint) + " --t-end " +
              number_text(suggest_t_end_s, 2, Digits::kAfterPoint) +
              (ended_by == "crash" || ended_by == "inverted"
                   ? " (the " + ended_by + " and the seconds before it cut)"
                   : std::string()));
  return l;
}

}  // namespace insid::importers
