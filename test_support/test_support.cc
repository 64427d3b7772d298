#include "test_support/test_support.h"

#include <random>

#include "model/earth.h"
#include "model/rotation.h"
#include "scenarios/scenario.h"

namespace insid::test {

SensorErrors paper_errors() {
  SensorErrors e;
  e.accel.bias.x() = -2.0 * kSigmaAccelMps2;
  e.accel.bias.y() = 1.5 * kSigmaAccelMps2;
  e.gyro.bias.x() = 2.0 * kSigmaGyroRadS;
  e.gyro.bias.y() = -1.5 * kSigmaGyroRadS;
  return e;
}

Dataset jittered_rows(const Dataset& fine, std::size_t min_rows, std::size_t max_rows,
                      std::uint64_t seed, double nominal_rate_hz,
                      std::vector<std::size_t>* group_last) {
  Dataset out = fine;
  out.meta.format = DatasetFormat::kV2;
  out.meta.imu_rate_hz = nominal_rate_hz;
  out.imu.clear();
  out.truth.clear();
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<std::size_t> rows(min_rows, max_rows);
  for (std::size_t k = 0; k + max_rows <= fine.imu.size();) {
    ImuSample s;
    for (std::size_t n = rows(rng), j = 0; j < n; ++j, ++k) {
      s.dtheta_b_rad += fine.imu[k].dtheta_b_rad;
      s.dv_b_mps += fine.imu[k].dv_b_mps;
    }
    s.t_s = fine.imu[k - 1].t_s;
    out.imu.push_back(s);
    if (!fine.truth.empty()) out.truth.push_back(fine.truth[k - 1]);
    if (group_last != nullptr) group_last->push_back(k - 1);
  }
  validate_dataset(out);
  return out;
}

std::shared_ptr<const Dataset> simulate_preset(const std::string& preset, double flight_s,
                                               const std::string& grade, std::uint64_t seed) {
  scenarios::ScenarioConfig cfg = scenarios::preset_scenario(preset);
  cfg.flight_s = flight_s;
  cfg.noise = scenarios::noise_grade(grade);
  cfg.seed = seed;
  return std::make_shared<const Dataset>(scenarios::simulate(cfg));
}

}  // namespace insid::test
