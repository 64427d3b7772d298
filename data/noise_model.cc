#include "data/noise_model.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

namespace insid {
namespace {

// Robust standard deviation: 1.4826 * median absolute deviation from the median.
double robust_sd(std::vector<double> v) {
  if (v.size() < 3) return 0.0;
  auto median = [](std::vector<double>& x) {
    const std::size_t mid = x.size() / 2;
    std::nth_element(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(mid), x.end());
    return x[mid];
  };
  const double m = median(v);
  for (double& x : v) x = std::abs(x - m);
  return 1.4826 * median(v);
}

// Spread of the white noise on a series sampled at equal steps: first differences (scale
// sqrt(2)) of a constant truth, or second differences (scale sqrt(6)) of a smooth one.
template <typename Get>
double white_sd(std::size_t begin, std::size_t end, bool second, Get get) {
  std::vector<double> d;
  if (end < begin + 3) return 0.0;
  d.reserve(end - begin);
  for (std::size_t k = begin + (second ? 2 : 1); k < end; ++k)
    d.push_back(second ? get(k) - 2.0 * get(k - 1) + get(k - 2) : get(k) - get(k - 1));
  return robust_sd(std::move(d)) / std::sqrt(second ? 6.0 : 2.0);
}

// Portable normal draws (Box-Muller on mt19937_64).
class Normal {
 public:
  explicit Normal(std::uint64_t seed) : engine_(seed) {}
  double operator()() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u1 = 0.0;
    do u1 = uniform();
    while (u1 <= 0.0);
    const double u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(2.0 * std::numbers::pi * u2);
    has_spare_ = true;
    return r * std::cos(2.0 * std::numbers::pi * u2);
  }

 private:
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

std::uint64_t mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

}  // namespace

nlohmann::json NoiseEstimate::to_json() const {
  auto lv = [](const NoiseLevels& l) {
    return nlohmann::json{{"arw_deg_rth", l.arw_deg_rth},
                          {"vrw_mps_rth", l.vrw_mps_rth},
                          {"gnss_vel_sigma_mps", l.gnss_vel_sigma_mps},
                          {"gnss_pos_sigma_m", l.gnss_pos_sigma_m}};
  };
  return {{"used", lv(levels)},
          {"source", source},
          {"estimated_from_data", lv(estimated)},
          {"estimate_method", estimate_method}};
}

NoiseLevels estimate_noise_levels(const Dataset& ds, std::string* method) {
  NoiseLevels out;
  const double dt = 1.0 / ds.meta.imu_rate_hz;
  const double t0 = ds.imu.empty() ? 0.0 : ds.imu.front().t_s - dt;
  const double t_align_end = t0 + ds.meta.align_s;
  std::size_t n_imu = 0;
  while (n_imu < ds.imu.size() && ds.imu[n_imu].t_s <= t_align_end + 1e-9) ++n_imu;
  std::size_t n_gnss = 0;
  while (n_gnss < ds.gnss.size() && ds.gnss[n_gnss].t_s <= t_align_end + 1e-9) ++n_gnss;
  const bool static_window = n_imu >= 100 && n_gnss >= 10;
  const std::size_t imu_end = static_window ? n_imu : ds.imu.size();
  const std::size_t gnss_end = static_window ? n_gnss : ds.gnss.size();
  const bool second = !static_window;

  double arw = 0.0, vrw = 0.0, sv = 0.0, sp = 0.0;
  for (int a = 0; a < 3; ++a) {
    arw += white_sd(0, imu_end, second, [&](std::size_t k) { return ds.imu[k].dtheta_b_rad[a]; });
    vrw += white_sd(0, imu_end, second, [&](std::size_t k) { return ds.imu[k].dv_b_mps[a]; });
  }
  arw /= 3.0;
  vrw /= 3.0;
  // Per-sample sd = level * sqrt(dt) with the level in rad/sqrt(s); 1/sqrt(s) = 60/sqrt(h).
  out.arw_deg_rth = arw / std::sqrt(dt) * kRadToDeg * 60.0;
  out.vrw_mps_rth = vrw / std::sqrt(dt) * 60.0;
  for (int a = 0; a < 2; ++a)
    sv += white_sd(0, gnss_end, second, [&](std::size_t k) { return ds.gnss[k].v_eb_n_mps[a]; });
  sv /= 2.0;
  out.gnss_vel_sigma_mps = sv;
  const EarthModel& earth = ds.meta.earth;
  const double lat0 = ds.gnss.empty() ? 0.0 : ds.gnss.front().lat_rad;
  const double rn = earth.meridian_radius_m(lat0), re = earth.prime_vertical_radius_m(lat0);
  sp += white_sd(0, gnss_end, second, [&](std::size_t k) { return ds.gnss[k].lat_rad * rn; });
  sp += white_sd(0, gnss_end, second,
                 [&](std::size_t k) { return ds.gnss[k].lon_rad * re * std::cos(lat0); });
  sp += white_sd(0, gnss_end, second, [&](std::size_t k) { return ds.gnss[k].h_m; });
  out.gnss_pos_sigma_m = sp / 3.0;
  if (method)
    *method = static_window
                  ? "robust (MAD) spread of first differences inside the static alignment window"
                  : "robust (MAD) spread of second differences over the whole data (no static "
                    "alignment window of at least 100 IMU samples)";
  return out;
}

NoiseLevels estimate_flight_imu_noise(const Dataset& ds) {
  NoiseLevels out;
  const double dt = 1.0 / ds.meta.imu_rate_hz;
  const double t0 = ds.imu.empty() ? 0.0 : ds.imu.front().t_s - dt;
  std::size_t begin = 0;
  while (begin < ds.imu.size() && ds.imu[begin].t_s <= t0 + ds.meta.align_s + 1e-9) ++begin;
  if (ds.imu.size() < begin + 100) begin = 0;
  double arw = 0.0, vrw = 0.0;
  for (int a = 0; a < 3; ++a) {
    arw += white_sd(begin, ds.imu.size(), true,
                    [&](std::size_t k) { return ds.imu[k].dtheta_b_rad[a]; });
    vrw +=
        white_sd(begin, ds.imu.size(), true, [&](std::size_t k) { return ds.imu[k].dv_b_mps[a]; });
  }
  // Per-sample sd = level * sqrt(dt) with the level in rad/sqrt(s); 1/sqrt(s) = 60/sqrt(h).
  out.arw_deg_rth = arw / 3.0 / std::sqrt(dt) * kRadToDeg * 60.0;
  out.vrw_mps_rth = vrw / 3.0 / std::sqrt(dt) * 60.0;
  return out;
}

NoiseEstimate noise_levels_for(const Dataset& dataset) {
  NoiseEstimate e;
  e.estimated = estimate_noise_levels(dataset, &e.estimate_method);
  if (dataset.meta.noise) {
    e.levels = *dataset.meta.noise;
    e.source = "meta.json";
  } else {
    e.levels = e.estimated;
    e.source = "estimated from the data (" + e.estimate_method + ")";
  }
  // Noise-free data would give degenerate replicas: keep a tiny GNSS velocity floor.
  if (!(e.levels.gnss_vel_sigma_mps > 1e-4)) {
    e.levels.gnss_vel_sigma_mps = 1e-4;
    e.source += "; GNSS velocity noise floored at 1e-4 m/s";
  }
  return e;
}

Dataset noise_replica(const Dataset& dataset, const NoiseLevels& levels, std::uint64_t seed) {
  Dataset out = dataset;
  Normal normal(mix(seed));
  const double dt = 1.0 / dataset.meta.imu_rate_hz;
  const double s_theta = levels.arw_deg_rth / kRadToDeg / 60.0 * std::sqrt(dt);
  const double s_v = levels.vrw_mps_rth / 60.0 * std::sqrt(dt);
  for (ImuSample& s : out.imu)
    for (int a = 0; a < 3; ++a) {
      s.dtheta_b_rad[a] += s_theta * normal();
      s.dv_b_mps[a] += s_v * normal();
    }
  const EarthModel& earth = dataset.meta.earth;
  for (GnssSample& g : out.gnss) {
    for (int a = 0; a < 3; ++a) g.v_eb_n_mps[a] += levels.gnss_vel_sigma_mps * normal();
    const double rn = earth.meridian_radius_m(g.lat_rad) + g.h_m;
    const double re = (earth.prime_vertical_radius_m(g.lat_rad) + g.h_m) * std::cos(g.lat_rad);
    g.lat_rad += levels.gnss_pos_sigma_m * normal() / rn;
    g.lon_rad += levels.gnss_pos_sigma_m * normal() / re;
    g.h_m += levels.gnss_pos_sigma_m * normal();
  }
  return out;
}

}  // namespace insid
