#include "scenarios/synthesis.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "base/huge_pages.h"

namespace insid::scenarios {

ImuSynthesizer::ImuSynthesizer(Trajectory trajectory, const EarthModel& earth, double imu_rate_hz,
                               int substeps)
    : traj_(std::move(trajectory)), earth_(earth), rate_(imu_rate_hz), substeps_(substeps) {
  if (!(imu_rate_hz > 0.0 && imu_rate_hz <= 10000.0))
    throw std::invalid_argument("imu_rate_hz must be in (0, 10000], got " +
                                std::to_string(imu_rate_hz));
  if (substeps < 1 || substeps > 1000)
    throw std::invalid_argument("substeps must be in [1, 1000], got " + std::to_string(substeps));
  if (const std::string e = earth.validate(); !e.empty()) throw std::invalid_argument(e);
  breakpoints_ = traj_.breakpoints();
}

TrueState ImuSynthesizer::state_from(const Kinematics& k, double lat_rad, double lon_rad) const {
  TrueState s;
  s.t_s = k.t_s;
  s.lat_rad = lat_rad;
  s.lon_rad = lon_rad;
  s.h_m = k.h_m;
  s.v_eb_n = k.v_eb_n;
  s.a_n = k.a_n;
  s.attitude = k.attitude;
  s.C_b_n = k.C_b_n;
  s.omega_nb_b = k.omega_nb_b;
  const Eigen::Vector3d omega_ie_n = earth_.omega_ie_n(lat_rad);
  const Eigen::Vector3d omega_en_n = earth_.omega_en_n(lat_rad, k.h_m, k.v_eb_n);
  const Eigen::Matrix3d C_n_b = k.C_b_n.transpose();
  // ENU navigation equations read backwards (paper Eq. 1, rows 2-3; Groves 2013 eq. 5.54).
  s.omega_ib_b = k.omega_nb_b + C_n_b * (omega_ie_n + omega_en_n);
  s.f_ib_b = C_n_b * (k.a_n + (2.0 * omega_ie_n + omega_en_n).cross(k.v_eb_n) -
                      earth_.gravity_n(lat_rad, k.h_m));
  return s;
}

namespace {

struct PosRate {
  double lat_dot, lon_dot;
};

// Kahan-compensated sum += delta.
void kahan_add(double& sum, double& c, double delta) {
  const double y = delta - c;
  const double t = sum + y;
  c = (t - sum) - y;
  sum = t;
}

PosRate position_rate(const EarthModel& earth, double lat, const Kinematics& k) {
  const double rm_h = earth.meridian_radius_m(lat) + k.h_m;
  const double rn_h = earth.prime_vertical_radius_m(lat) + k.h_m;
  return {k.v_eb_n.y() / rm_h, k.v_eb_n.x() / (rn_h * std::cos(lat))};
}

}  // namespace

void ImuSynthesizer::advance_piece(double t0, double t1, int n, GeoPos& p, Eigen::Vector3d* dtheta,
                                   Eigen::Vector3d* dv) const {
  const double h = (t1 - t0) / n;
  Kinematics k0 = traj_.eval(t0);
  for (int i = 0; i < n; ++i) {
    const double ta = t0 + i * h;
    const double tb = (i + 1 == n) ? t1 : t0 + (i + 1) * h;
    const Kinematics km = traj_.eval(ta + 0.5 * h);
    const Kinematics k1 = traj_.eval(tb);
    // Classical RK4 on (lat, lon); the rates at the stage points integrate into increments.
    const double lat = p.lat, lon = p.lon;
    const PosRate p1 = position_rate(earth_, lat, k0);
    const double lat2 = lat + 0.5 * h * p1.lat_dot;
    const PosRate p2 = position_rate(earth_, lat2, km);
    const double lat3 = lat + 0.5 * h * p2.lat_dot;
    const PosRate p3 = position_rate(earth_, lat3, km);
    const double lat4 = lat + h * p3.lat_dot;
    const PosRate p4 = position_rate(earth_, lat4, k1);
    if (dtheta || dv) {
      const TrueState s1 = state_from(k0, lat, lon);
      const TrueState s2 = state_from(km, lat2, lon);
      const TrueState s3 = state_from(km, lat3, lon);
      const TrueState s4 = state_from(k1, lat4, lon);
      if (dtheta)
        *dtheta +=
            h / 6.0 * (s1.omega_ib_b + 2.0 * (s2.omega_ib_b + s3.omega_ib_b) + s4.omega_ib_b);
      if (dv) *dv += h / 6.0 * (s1.f_ib_b + 2.0 * (s2.f_ib_b + s3.f_ib_b) + s4.f_ib_b);
    }
    kahan_add(p.lat, p.lat_c,
              h / 6.0 * (p1.lat_dot + 2.0 * (p2.lat_dot + p3.lat_dot) + p4.lat_dot));
    kahan_add(p.lon, p.lon_c,
              h / 6.0 * (p1.lon_dot + 2.0 * (p2.lon_dot + p3.lon_dot) + p4.lon_dot));
    k0 = k1;
  }
}

template <class Piece>
void ImuSynthesizer::for_each_piece(double t0, double t1, Piece&& piece) const {
  const double dt_nominal = 1.0 / rate_;
  const auto cut = [&](double a, double b) {
    piece(
        a, b,
        std::max(1, static_cast<int>(std::ceil(substeps_ * std::fabs(b - a) / dt_nominal - 1e-9))));
  };
  // Split at breakpoints strictly inside (t0, t1), in the direction of travel.
  const double lo = std::min(t0, t1), hi = std::max(t0, t1);
  const auto first = std::upper_bound(breakpoints_.begin(), breakpoints_.end(), lo);
  const auto last = std::lower_bound(breakpoints_.begin(), breakpoints_.end(), hi);
  double a = t0;
  if (t0 < t1) {
    for (auto c = first; c != last; ++c) {
      cut(a, *c);
      a = *c;
    }
  } else {
    for (auto c = last; c != first;) {
      --c;
      cut(a, *c);
      a = *c;
    }
  }
  cut(a, t1);
}

void ImuSynthesizer::advance(double t0, double t1, GeoPos& p, Eigen::Vector3d* dtheta,
                             Eigen::Vector3d* dv) const {
  if (t1 == t0) return;
  for_each_piece(t0, t1, [&](double a, double b, int n) { advance_piece(a, b, n, p, dtheta, dv); });
}

void ImuSynthesizer::run(std::size_t num_steps, int threads) {
  if (num_steps < 1) throw std::invalid_argument("need at least one IMU step");
  if (threads < 1)
    throw std::invalid_argument("threads must be >= 1, got " + std::to_string(threads));
  // Storage advised for huge pages before it is first written (base/huge_pages.h).
  reserve_huge_pages(imu_, num_steps);
  reserve_huge_pages(truth_, num_steps);
  reserve_huge_pages(lat_grid_, num_steps + 1);
  reserve_huge_pages(lon_grid_, num_steps + 1);
  imu_.assign(num_steps, ImuSample{});
  truth_.assign(num_steps, TruthSample{});
  lat_grid_.assign(num_steps + 1, 0.0);
  lon_grid_.assign(num_steps + 1, 0.0);
  GeoPos p;
  p.lat = traj_.initial().lat_rad;
  p.lon = traj_.initial().lon_rad;
  lat_grid_[0] = p.lat;
  lon_grid_[0] = p.lon;
  // The arithmetic of advance() / advance_piece() from t_{k-1} to t_k, split by dependence: the
  // trajectory (most of the cost) does not depend on the position, and the increments depend on
  // it only through the latitudes of the RK4 stages. So, block by block of IMU steps: the
  // sub-steps' times (as advance() cuts them), the trajectory at their mid and end points (in
  // parallel), the position integrated in order, then the increments (in parallel). The blocks
  // are pipelined: while one thread integrates the position over block b, the others compute
  // the increments of block b - 1 and the trajectory of block b + 1 (the position, alone, kept
  // the second of two threads waiting about 40 % of the synthesis). Every value is the one
  // advance() computes, for any thread count.
  constexpr std::size_t kBlock = 4096;  // IMU steps
  struct Block {
    std::size_t k_begin = 0, k_stop = 0;  // IMU steps [k_begin, k_stop)
    std::vector<SubStep> sub;
    std::vector<std::size_t> first_sub;  // of each step of the block, and one past the last
    std::vector<Kinematics> k_mid, k_end;
    Kinematics k_start;  // at the first sub-step's start
  };
  const std::size_t n_blocks = (num_steps + kBlock - 1) / kBlock;
  std::array<Block, 3> ring;  // block b lives in ring[b % 3]
  const auto cut = [&](std::size_t b, const Kinematics& k_start) {
    Block& B = ring[b % 3];
    B.k_begin = 1 + b * kBlock;
    B.k_stop = std::min(num_steps + 1, B.k_begin + kBlock);
    B.sub.clear();
    B.first_sub.clear();
    for (std::size_t k = B.k_begin; k < B.k_stop; ++k) {
      B.first_sub.push_back(B.sub.size());
      const double t0 = static_cast<double>(k - 1) / rate_, t1 = static_cast<double>(k) / rate_;
      for_each_piece(t0, t1, [&](double a, double b_end, int n) {
        const double h = (b_end - a) / n;  // as advance_piece cuts it
        for (int i = 0; i < n; ++i)
          B.sub.push_back({a + i * h, (i + 1 == n) ? b_end : a + (i + 1) * h, h});
      });
    }
    B.first_sub.push_back(B.sub.size());
    B.k_mid.resize(B.sub.size());
    B.k_end.resize(B.sub.size());
    B.k_start = k_start;
  };
  // The trajectory at sub-step j's mid and end points.
  const auto trajectory = [&](Block& B, std::size_t j) {
    const SubStep& u = B.sub[j];
    B.k_mid[j] = traj_.eval(u.ta + 0.5 * u.h);
    B.k_end[j] = traj_.eval(u.tb);
  };
  // The position, in order (advance_piece's RK4 on lat/lon); each sub-step's stage latitudes
  // and starting longitude are kept for the increments.
  const auto position = [&](Block& B) {
    for (std::size_t j = 0; j < B.sub.size(); ++j) {
      SubStep& u = B.sub[j];
      const Kinematics& k0 = j == 0 ? B.k_start : B.k_end[j - 1];
      u.lat = p.lat;
      u.lon = p.lon;
      const PosRate p1 = position_rate(earth_, u.lat, k0);
      u.lat2 = u.lat + 0.5 * u.h * p1.lat_dot;
      const PosRate p2 = position_rate(earth_, u.lat2, B.k_mid[j]);
      u.lat3 = u.lat + 0.5 * u.h * p2.lat_dot;
      const PosRate p3 = position_rate(earth_, u.lat3, B.k_mid[j]);
      u.lat4 = u.lat + u.h * p3.lat_dot;
      const PosRate p4 = position_rate(earth_, u.lat4, B.k_end[j]);
      kahan_add(p.lat, p.lat_c,
                u.h / 6.0 * (p1.lat_dot + 2.0 * (p2.lat_dot + p3.lat_dot) + p4.lat_dot));
      kahan_add(p.lon, p.lon_c,
                u.h / 6.0 * (p1.lon_dot + 2.0 * (p2.lon_dot + p3.lon_dot) + p4.lon_dot));
      u.lat_end = p.lat;
      u.lon_end = p.lon;
    }
  };
  // The increments and the truth row of the block's step i.
  const auto increments = [&](const Block& B, std::size_t i) {
    const std::size_t k = B.k_begin + i;
    ImuSample& s = imu_[k - 1];
    s.t_s = static_cast<double>(k) / rate_;
    const std::size_t j_end = B.first_sub[i + 1];
    for (std::size_t j = B.first_sub[i]; j < j_end; ++j) {
      const SubStep& u = B.sub[j];
      const Kinematics& k0 = j == 0 ? B.k_start : B.k_end[j - 1];
      const TrueState s1 = state_from(k0, u.lat, u.lon);
      const TrueState s2 = state_from(B.k_mid[j], u.lat2, u.lon);
      const TrueState s3 = state_from(B.k_mid[j], u.lat3, u.lon);
      const TrueState s4 = state_from(B.k_end[j], u.lat4, u.lon);
      s.dtheta_b_rad +=
          u.h / 6.0 * (s1.omega_ib_b + 2.0 * (s2.omega_ib_b + s3.omega_ib_b) + s4.omega_ib_b);
      s.dv_b_mps += u.h / 6.0 * (s1.f_ib_b + 2.0 * (s2.f_ib_b + s3.f_ib_b) + s4.f_ib_b);
    }
    const SubStep& last = B.sub[j_end - 1];
    lat_grid_[k] = last.lat_end;
    lon_grid_[k] = last.lon_end;
    const Kinematics& kin = B.k_end[j_end - 1];  // traj_.eval(t_k)
    TruthSample& tr = truth_[k - 1];
    tr.t_s = s.t_s;
    tr.lat_rad = last.lat_end;
    tr.lon_rad = last.lon_end;
    tr.h_m = kin.h_m;
    tr.v_eb_n_mps = kin.v_eb_n;
    tr.attitude = kin.attitude;
  };

  cut(0, traj_.eval(0.0));
  {
    Block& B0 = ring[0];
    const std::ptrdiff_t n_sub = static_cast<std::ptrdiff_t>(B0.sub.size());
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1)
    for (std::ptrdiff_t j = 0; j < n_sub; ++j) trajectory(B0, static_cast<std::size_t>(j));
  }
  // Stage b: the position of block b (one thread) beside the increments of block b - 1 and the
  // trajectory of block b + 1 (shared out in chunks; the position's thread joins when done).
  constexpr std::ptrdiff_t kChunk = 64;
#pragma omp parallel num_threads(threads) if (threads > 1)
  for (std::size_t b = 0; b <= n_blocks; ++b) {
#pragma omp single
    if (b + 1 < n_blocks) cut(b + 1, ring[b % 3].k_end.back());
#pragma omp single nowait
    if (b < n_blocks) position(ring[b % 3]);
    Block* const before = b >= 1 ? &ring[(b - 1) % 3] : nullptr;
    Block* const after = b + 1 < n_blocks ? &ring[(b + 1) % 3] : nullptr;
    const std::ptrdiff_t n_before =
        before ? static_cast<std::ptrdiff_t>(before->k_stop - before->k_begin) : 0;
    const std::ptrdiff_t n_after = after ? static_cast<std::ptrdiff_t>(after->sub.size()) : 0;
#pragma omp for schedule(dynamic, kChunk) nowait
    for (std::ptrdiff_t w = 0; w < n_before + n_after; ++w) {
      if (w < n_before)
        increments(*before, static_cast<std::size_t>(w));
      else
        trajectory(*after, static_cast<std::size_t>(w - n_before));
    }
#pragma omp barrier
  }
}

TrueState ImuSynthesizer::state_at(double t_s) const {
  if (lat_grid_.empty()) throw std::logic_error("ImuSynthesizer::state_at before run()");
  const double K = static_cast<double>(lat_grid_.size() - 1);
  const double kf = std::clamp(std::round(t_s * rate_), 0.0, K);
  const std::size_t k = static_cast<std::size_t>(kf);
  GeoPos p;
  p.lat = lat_grid_[k];
  p.lon = lon_grid_[k];
  advance(static_cast<double>(k) / rate_, t_s, p, nullptr, nullptr);
  return state_from(traj_.eval(t_s), p.lat, p.lon);
}

// ---------------------------------------------------------------------------------------------
// Geodesy

Eigen::Vector3d ecef_from_geodetic(const EarthModel& earth, double lat_rad, double lon_rad,
                                   double h_m) {
  const double rn = earth.prime_vertical_radius_m(lat_rad);
  const double e2 = earth.ellipsoid.e2();
  const double cl = std::cos(lat_rad), sl = std::sin(lat_rad);
  return {(rn + h_m) * cl * std::cos(lon_rad), (rn + h_m) * cl * std::sin(lon_rad),
          (rn * (1.0 - e2) + h_m) * sl};
}

void geodetic_from_ecef(const EarthModel& earth, const Eigen::Vector3d& r_e, double& lat_rad,
                        double& lon_rad, double& h_m) {
  const double e2 = earth.ellipsoid.e2();
  const double p = std::hypot(r_e.x(), r_e.y());
  lon_rad = std::atan2(r_e.y(), r_e.x());
  // Fixed-point iteration on latitude (converges to machine precision near the surface).
  double lat = std::atan2(r_e.z(), p * (1.0 - e2));
  double h = 0.0;
  for (int i = 0; i < 10; ++i) {
    const double rn = earth.prime_vertical_radius_m(lat);
    h = p / std::cos(lat) - rn;
    const double next = std::atan2(r_e.z(), p * (1.0 - e2 * rn / (rn + h)));
    const bool done = std::fabs(next - lat) < 1e-15;
    lat = next;
    if (done) break;
  }
  const double rn = earth.prime_vertical_radius_m(lat);
  h = p / std::cos(lat) - rn;
  lat_rad = lat;
  h_m = h;
}

Eigen::Matrix3d C_n_e(double lat_rad, double lon_rad) {
  const double sl = std::sin(lat_rad), cl = std::cos(lat_rad);
  const double so = std::sin(lon_rad), co = std::cos(lon_rad);
  Eigen::Matrix3d c;
  c << -so, -sl * co, cl * co,  //
      co, -sl * so, cl * so,    //
      0.0, cl, sl;
  return c;
}

GnssSample antenna_solution(const EarthModel& earth, const TrueState& s,
                            const Eigen::Vector3d& lever_arm_b_m) {
  GnssSample g;
  g.t_s = s.t_s;
  if (lever_arm_b_m.isZero(0)) {
    g.lat_rad = s.lat_rad;
    g.lon_rad = s.lon_rad;
    g.h_m = s.h_m;
    g.v_eb_n_mps = s.v_eb_n;
    return g;
  }
  const Eigen::Matrix3d Cne = C_n_e(s.lat_rad, s.lon_rad);
  const Eigen::Vector3d r_e = ecef_from_geodetic(earth, s.lat_rad, s.lon_rad, s.h_m);
  const Eigen::Vector3d r_ant_e = r_e + Cne * (s.C_b_n * lever_arm_b_m);
  geodetic_from_ecef(earth, r_ant_e, g.lat_rad, g.lon_rad, g.h_m);
  // Groves 2013 eq. 14.x: v_ea = v_eb + C_b (omega_eb_b x l), omega_eb_b = omega_ib_b - C_n_b w_ie.
  const Eigen::Vector3d omega_eb_b =
      s.omega_ib_b - s.C_b_n.transpose() * earth.omega_ie_n(s.lat_rad);
  const Eigen::Vector3d v_ant_e = Cne * (s.v_eb_n + s.C_b_n * omega_eb_b.cross(lever_arm_b_m));
  g.v_eb_n_mps = C_n_e(g.lat_rad, g.lon_rad).transpose() * v_ant_e;
  return g;
}

}  // namespace insid::scenarios
