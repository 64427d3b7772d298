#include "scenarios/trajectory.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "base/number_text.h"

namespace insid::scenarios {
namespace {

[[noreturn]] void fail(const std::string& what) { throw std::invalid_argument(what); }

}  // namespace

// ---------------------------------------------------------------------------------------------
// SmoothChannel

void SmoothChannel::ramp(double t0_s, double duration_s, double target) {
  if (!(duration_s > 0.0) || !std::isfinite(duration_s))
    fail("transition duration must be > 0 s, got " + number_text(duration_s, 10));
  if (!std::isfinite(t0_s) || !std::isfinite(target)) fail("transition values must be finite");
  const double last_end = last_ramp_end_s();
  if (t0_s < last_end - 1e-9)
    fail("transition at t = " + number_text(t0_s, 10) + " s starts before the previous one ends (" +
         number_text(last_end, 10) + " s)");
  Ramp r{t0_s, duration_s, final_value(), target, integral(t0_s)};
  ramps_.push_back(r);
}

double SmoothChannel::last_ramp_end_s() const {
  return ramps_.empty() ? -std::numeric_limits<double>::infinity()
                        : ramps_.back().t0 + ramps_.back().T;
}

int SmoothChannel::find(double t_s) const {
  // Last ramp with t0 <= t.
  const auto it = std::upper_bound(ramps_.begin(), ramps_.end(), t_s,
                                   [](double t, const Ramp& r) { return t < r.t0; });
  return static_cast<int>(it - ramps_.begin()) - 1;
}

double SmoothChannel::value(double t_s) const {
  const int i = find(t_s);
  if (i < 0) return initial_;
  const Ramp& r = ramps_[i];
  const double tau = t_s - r.t0;
  if (tau >= r.T) return r.to;
  return r.from + (r.to - r.from) * 0.5 * (1.0 - std::cos(kPi * tau / r.T));
}

double SmoothChannel::rate(double t_s) const {
  const int i = find(t_s);
  if (i < 0) return 0.0;
  const Ramp& r = ramps_[i];
  const double tau = t_s - r.t0;
  if (tau >= r.T) return 0.0;
  return (r.to - r.from) * 0.5 * kPi / r.T * std::sin(kPi * tau / r.T);
}

double SmoothChannel::integral(double t_s) const {
  const int i = find(t_s);
  if (i < 0) return initial_ * t_s;
  const Ramp& r = ramps_[i];
  const double tau = t_s - r.t0;
  if (tau >= r.T) {
    // Integral over the whole transition is T (from + to) / 2.
    return r.integral_at_t0 + 0.5 * r.T * (r.from + r.to) + r.to * (tau - r.T);
  }
  // integral of (1 - cos(pi s / T)) / 2 over [0, tau] = (tau - T/pi sin(pi tau / T)) / 2.
  return r.integral_at_t0 + r.from * tau +
         (r.to - r.from) * 0.5 * (tau - r.T / kPi * std::sin(kPi * tau / r.T));
}

void SmoothChannel::append_breakpoints(std::vector<double>& out) const {
  for (const Ramp& r : ramps_) {
    out.push_back(r.t0);
    out.push_back(r.t0 + r.T);
  }
}

// ---------------------------------------------------------------------------------------------
// Trajectory

Kinematics Trajectory::eval(double t_s) const {
  Kinematics k;
  k.t_s = t_s;
  const double vh = speed_.value(t_s), vh_dot = speed_.rate(t_s);
  const double vu = vup_.value(t_s), vu_dot = vup_.rate(t_s);
  const double r = turn_.value(t_s), r_dot = turn_.rate(t_s);
  const double psi = initial_.attitude.yaw_rad + turn_.integral(t_s);
  const double theta = pitch_.value(t_s), theta_dot = pitch_.rate(t_s);
  // Coordinated bank: tan(phi_c) = Vh r / g_ref.
  const double u = vh * r / g_ref_;
  const double u_dot = (vh_dot * r + vh * r_dot) / g_ref_;
  const double phi = roll_.value(t_s) + std::atan(u);
  const double phi_dot = roll_.rate(t_s) + u_dot / (1.0 + u * u);

  k.h_m = initial_.h_m + vup_.integral(t_s);
  const double sp = std::sin(psi), cp = std::cos(psi);
  k.v_eb_n = {vh * sp, vh * cp, vu};
  k.a_n = {vh_dot * sp + vh * r * cp, vh_dot * cp - vh * r * sp, vu_dot};
  k.attitude = {phi, theta, psi};
  k.C_b_n = C_b_n_from_euler(k.attitude);
  // Body rate w.r.t. n from 3-2-1 Euler-angle rates (FRD body; the ENU and NED frames share
  // their angular velocity, so the usual NED formula holds).
  const double sf = std::sin(phi), cf = std::cos(phi);
  const double st = std::sin(theta), ct = std::cos(theta);
  k.omega_nb_b = {phi_dot - r * st, theta_dot * cf + r * sf * ct, -theta_dot * sf + r * cf * ct};
  return k;
}

std::vector<double> Trajectory::breakpoints() const {
  std::vector<double> b;
  speed_.append_breakpoints(b);
  vup_.append_breakpoints(b);
  turn_.append_breakpoints(b);
  pitch_.append_breakpoints(b);
  roll_.append_breakpoints(b);
  std::sort(b.begin(), b.end());
  b.erase(std::unique(b.begin(), b.end()), b.end());
  return b;
}

// ---------------------------------------------------------------------------------------------
// TrajectoryBuilder

TrajectoryBuilder::TrajectoryBuilder(const InitialPose& initial, double g_ref_mps2) {
  if (!(std::fabs(initial.lat_rad) < 89.0 * kDegToRad))
    fail("initial latitude must lie within (-89, 89) deg, got " +
         number_text(initial.lat_rad * kRadToDeg, 10));
  if (!(std::fabs(initial.attitude.roll_rad) <= kMaxBankRad))
    fail("initial roll must lie within [-60, 60] deg, got " +
         number_text(initial.attitude.roll_rad * kRadToDeg, 10));
  if (!(std::fabs(initial.attitude.pitch_rad) <= kMaxPitchRad))
    fail("initial pitch must lie within [-45, 45] deg, got " +
         number_text(initial.attitude.pitch_rad * kRadToDeg, 10));
  if (!std::isfinite(initial.attitude.yaw_rad) || !std::isfinite(initial.lon_rad) ||
      !std::isfinite(initial.h_m))
    fail("initial yaw, longitude and height must be finite");
  if (!(g_ref_mps2 > 9.0 && g_ref_mps2 < 10.5))
    fail("reference gravity must be in (9, 10.5) m/s^2, got " + number_text(g_ref_mps2, 10));
  traj_.initial_ = initial;
  traj_.g_ref_ = g_ref_mps2;
  traj_.speed_ = SmoothChannel(0.0);
  traj_.vup_ = SmoothChannel(0.0);
  traj_.turn_ = SmoothChannel(0.0);
  traj_.pitch_ = SmoothChannel(initial.attitude.pitch_rad);
  traj_.roll_ = SmoothChannel(initial.attitude.roll_rad);
}

double TrajectoryBuilder::height_m() const { return traj_.initial_.h_m + traj_.vup_.integral(t_); }

void TrajectoryBuilder::hold_static(double duration_s) {
  if (!(duration_s > 0.0) || !std::isfinite(duration_s))
    fail("duration_s must be > 0, got " + number_text(duration_s, 10));
  if (speed_mps() != 0.0 || vertical_speed_mps() != 0.0)
    fail("a static segment needs the vehicle stopped, but its speed is " +
         number_text(speed_mps(), 10) + " m/s (add a speed segment to 0 first)");
  t_ += duration_s;
}

void TrajectoryBuilder::straight(double duration_s) {
  if (!(duration_s > 0.0) || !std::isfinite(duration_s))
    fail("duration_s must be > 0, got " + number_text(duration_s, 10));
  t_ += duration_s;
}

void TrajectoryBuilder::change_speed(double target_mps, double accel_mps2) {
  if (!(target_mps >= 0.0 && target_mps <= kMaxSpeedMps))
    fail("speed_mps must be in [0, " + number_text(kMaxSpeedMps, 10) + "] m/s, got " +
         number_text(target_mps, 10));
  if (!(accel_mps2 > 0.0 && accel_mps2 <= 20.0))
    fail("accel_mps2 must be in (0, 20] m/s^2, got " + number_text(accel_mps2, 10));
  const double dv = std::fabs(target_mps - speed_mps());
  if (dv == 0.0)
    fail("speed_mps = " + number_text(target_mps, 10) + " m/s equals the current speed");
  // Turning or banking must not be under way (turn segments end level).
  const double T = dv / accel_mps2;
  traj_.speed_.ramp(t_, T, target_mps);
  t_ += T;
}

double TrajectoryBuilder::turn_rate_for(const TurnSharpness& s) const {
  const bool has_bank = s.bank_rad > 0.0, has_rate = s.rate_rad_s > 0.0;
  if (has_bank == has_rate) fail("a turn needs exactly one of bank_deg or rate_deg_s (> 0)");
  if (has_bank) {
    if (!(s.bank_rad <= kMaxBankRad))
      fail("bank_deg must be in (0, 60] deg, got " + number_text(s.bank_rad * kRadToDeg, 10));
    if (!(speed_mps() >= 1.0))
      fail("a turn given by bank angle needs forward speed >= 1 m/s, the speed is " +
           number_text(speed_mps(), 10) + " m/s (give rate_deg_s to turn on the spot)");
    return traj_.g_ref_ * std::tan(s.bank_rad) / speed_mps();
  }
  if (!(s.rate_rad_s <= kMaxTurnRateRadS))
    fail("rate_deg_s must be in (0, 30] deg/s, got " + number_text(s.rate_rad_s * kRadToDeg, 10));
  const double bank = std::atan(speed_mps() * s.rate_rad_s / traj_.g_ref_);
  if (bank > kMaxBankRad)
    fail("rate_deg_s = " + number_text(s.rate_rad_s * kRadToDeg, 10) + " deg/s at " +
         number_text(speed_mps(), 10) + " m/s needs a bank of " +
         number_text(bank * kRadToDeg, 10) + " deg (> 60 deg)");
  return s.rate_rad_s;
}

void TrajectoryBuilder::turn(double turn_rad, TurnDirection direction,
                             const TurnSharpness& sharpness, double ramp_s) {
  if (!(turn_rad > 0.0) || !std::isfinite(turn_rad))
    fail("turn_deg must be > 0, got " + number_text(turn_rad * kRadToDeg, 10));
  if (!(ramp_s > 0.0) || !std::isfinite(ramp_s))
    fail("ramp_s must be > 0, got " + number_text(ramp_s, 10));
  const double rate = turn_rate_for(sharpness);
  // Heading change = rate * (hold + ramp_s): each cosine ramp contributes rate * ramp_s / 2.
  const double hold = turn_rad / rate - ramp_s;
  if (hold < -1e-9)
    fail("turn of " + number_text(turn_rad * kRadToDeg, 10) + " deg at " +
         number_text(rate * kRadToDeg, 10) +
         " deg/s is shorter than its roll-in and roll-out (ramp_s = " + number_text(ramp_s, 10) +
         " s): use a larger turn_deg or a smaller ramp_s");
  const double signed_rate = static_cast<double>(static_cast<int>(direction)) * rate;
  traj_.turn_.ramp(t_, ramp_s, signed_rate);
  traj_.turn_.ramp(t_ + ramp_s + std::max(hold, 0.0), ramp_s, 0.0);
  t_ += 2.0 * ramp_s + std::max(hold, 0.0);
}

void TrajectoryBuilder::climb(double dh_m, double vz_mps, double ramp_s, const double* pitch_rad) {
  if (!(dh_m != 0.0) || !std::isfinite(dh_m))
    fail("dh_m must be non-zero, got " + number_text(dh_m, 10));
  if (!(vz_mps > 0.0 && vz_mps <= 20.0))
    fail("vz_mps must be in (0, 20] m/s, got " + number_text(vz_mps, 10));
  if (!(ramp_s > 0.0) || !std::isfinite(ramp_s))
    fail("ramp_s must be > 0, got " + number_text(ramp_s, 10));
  if (height_m() + dh_m < -400.0)
    fail("descent by " + number_text(dh_m, 10) + " m goes below -400 m (height now " +
         number_text(height_m(), 10) + " m)");
  // Height change = vz * (hold + ramp_s).
  const double hold = std::fabs(dh_m) / vz_mps - ramp_s;
  if (hold < -1e-9)
    fail("climb of " + number_text(dh_m, 10) + " m at " + number_text(vz_mps, 10) +
         " m/s is shorter than its ramps (ramp_s = " + number_text(ramp_s, 10) +
         " s): use a larger dh_m or a smaller ramp_s");
  const double vz = dh_m > 0 ? vz_mps : -vz_mps;
  const double pitch_before = traj_.pitch_.final_value();
  double pitch_target = pitch_before;
  if (pitch_rad) {
    if (!(std::fabs(*pitch_rad) <= kMaxPitchRad))
      fail("pitch_deg must be within [-45, 45] deg, got " +
           number_text(*pitch_rad * kRadToDeg, 10));
    pitch_target = *pitch_rad;
  } else if (speed_mps() >= 1.0) {
    pitch_target = pitch_before + std::atan(vz / speed_mps());
    pitch_target = std::clamp(pitch_target, -kMaxPitchRad, kMaxPitchRad);
  }
  const double h = std::max(hold, 0.0);
  traj_.vup_.ramp(t_, ramp_s, vz);
  traj_.vup_.ramp(t_ + ramp_s + h, ramp_s, 0.0);
  if (pitch_target != pitch_before) {
    traj_.pitch_.ramp(t_, ramp_s, pitch_target);
    traj_.pitch_.ramp(t_ + ramp_s + h, ramp_s, pitch_before);
  }
  t_ += 2.0 * ramp_s + h;
}

void TrajectoryBuilder::takeoff(double dh_m, double vz_mps, double ramp_s) {
  if (speed_mps() != 0.0)
    fail("takeoff needs the vehicle stopped, but its speed is " + number_text(speed_mps(), 10) +
         " m/s");
  if (!(dh_m > 0.0)) fail("takeoff dh_m must be > 0, got " + number_text(dh_m, 10));
  climb(dh_m, vz_mps, ramp_s);
}

Trajectory TrajectoryBuilder::build() const { return traj_; }

}  // namespace insid::scenarios
