#include "nav/fitness.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "base/enum_table.h"
#include "base/number_text.h"
#include "data/gnss_interpolation.h"

namespace insid {

constexpr EnumTable<AlignmentMode, 2> kAlignmentModeNames{
    "alignment mode",
    {{{AlignmentMode::kPerCandidate, "per-candidate"}, {AlignmentMode::kFixed, "fixed"}}}};

std::string to_string(AlignmentMode mode) { return std::string(kAlignmentModeNames.name(mode)); }

AlignmentMode alignment_mode_from_string(const std::string& text) {
  return kAlignmentModeNames.value(text);
}

std::string NavigationOptions::validate() const {
  if (!std::isfinite(window_s) || window_s < 0.0) {
    return "window_s = " + number_text(window_s, 12) +
           " s: expected a finite number of seconds >= 0 (0 = one pure-INS run over the whole "
           "flight)";
  }
  return "";
}

NavigationProblem::NavigationProblem(std::shared_ptr<const Dataset> dataset,
                                     NavigationOptions options)
    : dataset_(std::move(dataset)), options_(options) {
  if (const std::string why = options_.validate(); !why.empty()) throw std::invalid_argument(why);
  if (!dataset_) throw std::invalid_argument("NavigationProblem: null dataset");
  const Dataset& ds = *dataset_;
  if (ds.imu.size() < 3 || ds.gnss.size() < 2)
    throw std::invalid_argument("NavigationProblem: need at least 3 IMU and 2 GNSS samples");
  const double dt_nominal = 1.0 / ds.meta.imu_rate_hz;
  // The alignment window: /1, the first round(align_s * imu_rate_hz) rows of the constant rate
  // (the first row's interval is 1/imu_rate_hz long); /2 (measured timing), the rows after the
  // first within align_s of the first row's time: the first row only marks the start, since
  // its own interval is unknown (taking it as long as the next step biases the window means).
  std::size_t window_begin = 0, n_align = 0;
  double t_window_start = ds.imu.front().t_s - dt_nominal;
  if (ds.meta.format == DatasetFormat::kV1) {
    n_align = static_cast<std::size_t>(std::llround(ds.meta.align_s * ds.meta.imu_rate_hz));
  } else if (ds.meta.align_s > 0.0) {
    window_begin = 1;
    t_window_start = ds.imu.front().t_s;
    n_align = 1;
    while (n_align < ds.imu.size() &&
           ds.imu[n_align].t_s - t_window_start <= ds.meta.align_s + 1e-9)
      ++n_align;
    if (n_align < 2)
      throw std::invalid_argument(
          "NavigationProblem: align_s = " + number_text(ds.meta.align_s, 12) +
          " s holds no IMU step after the first row");
  }
  if (n_align + 1 >= ds.imu.size())
    throw std::invalid_argument("NavigationProblem: align_s = " + number_text(ds.meta.align_s, 12) +
                                " s leaves no IMU data to navigate");
  nav_begin_ = std::max<std::size_t>(n_align, 1);
  if (n_align > 0)
    window_ =
        AlignmentWindow::from_imu(ds.imu, window_begin, n_align, t_window_start, ds.meta.motors);

  if (!ds.meta.motors.empty()) {
    motor_on_.resize(ds.imu.size());
    for (std::size_t k = 0; k < ds.imu.size(); ++k) {
      const double t_before = k > 0 ? ds.imu[k - 1].t_s : ds.imu[0].t_s - dt_nominal;
      motor_on_[k] = ds.meta.motors.fraction(t_before, ds.imu[k].t_s);
    }
  }

  // Height and vertical-velocity reference at every IMU epoch (GNSS, linear interpolation).
  h_ref_m_.resize(ds.imu.size());
  vU_ref_mps_.resize(ds.imu.size());
  std::size_t j = 0;
  for (std::size_t k = 0; k < ds.imu.size(); ++k) {
    const double t = ds.imu[k].t_s;
    while (j + 1 < ds.gnss.size() && ds.gnss[j + 1].t_s <= t) ++j;
    if (t <= ds.gnss.front().t_s || j + 1 >= ds.gnss.size()) {
      const GnssSample& g = t <= ds.gnss.front().t_s ? ds.gnss.front() : ds.gnss.back();
      h_ref_m_[k] = g.h_m;
      vU_ref_mps_[k] = g.v_eb_n_mps.z();
    } else {
      const GnssSample& a = ds.gnss[j];
      const GnssSample& b = ds.gnss[j + 1];
      const double w = (t - a.t_s) / (b.t_s - a.t_s);
      h_ref_m_[k] = a.h_m + w * (b.h_m - a.h_m);
      vU_ref_mps_[k] = a.v_eb_n_mps.z() + w * (b.v_eb_n_mps.z() - a.v_eb_n_mps.z());
    }
  }

  // GNSS epochs compared: after the navigation start, up to the last IMU epoch.
  const double t_nav0 = nav_start_t_s();
  const double t_last = ds.imu.back().t_s;
  constexpr double kTimeTol = 1e-9;
  for (std::size_t i = 0; i < ds.gnss.size(); ++i) {
    const double t = ds.gnss[i].t_s;
    if (t > t_nav0 + kTimeTol && t <= t_last + kTimeTol) epoch_gnss_index_.push_back(i);
  }
  if (epoch_gnss_index_.empty())
    throw std::invalid_argument("NavigationProblem: no GNSS epoch after the alignment window");

  // Windowed fitness: the restart epochs (nav/fitness.h, "Windowed fitness").
  const double window_s = options_.window_s;
  if (window_s > 0.0) {
    const double gnss_period_s = 1.0 / ds.meta.gnss_rate_hz;
    if (window_s < gnss_period_s - kTimeTol)
      throw std::invalid_argument(
          "window_s = " + number_text(window_s, 12) + " s is shorter than one GNSS period (" +
          number_text(gnss_period_s, 12) +
          " s at gnss_rate_hz = " + number_text(ds.meta.gnss_rate_hz, 12) +
          "): windows would hold no GNSS epoch; give window_s >= " +
          number_text(gnss_period_s, 12) + " s, or 0 for one run over the whole flight");
    std::size_t k = nav_begin_ - 1;
    for (double window = 1.0;; window += 1.0) {
      const double t_nominal = t_nav0 + window * window_s;
      if (!(t_nominal < t_last - kTimeTol)) break;  // no restart at or after the last epoch
      const std::size_t k_before = k;
      while (k + 1 < ds.imu.size() && ds.imu[k].t_s < t_nominal - kTimeTol) ++k;
      if (k + 1 >= ds.imu.size()) break;
      if (k == k_before) continue;  // this epoch is restarted at already
      const GnssSample g = interpolate_gnss(ds.gnss, ds.imu[k].t_s);
      restarts_.push_back(
          {k, ds.imu[k].t_s, g.lat_rad, g.lon_rad, g.v_eb_n_mps.x(), g.v_eb_n_mps.y()});
    }
  }
  // The initial attitude's mode against the data (refusals name what to give instead).
  attitude_source_ = InitialAttitude(ds, options_.initial_attitude, window_, window_begin, n_align,
                                     t_window_start, nav_begin_);
  if (attitude_source_.depends_on_candidate()) C_b_n_fixed_ = aligned(SensorErrors{});
}

double NavigationProblem::nav_start_t_s() const { return dataset_->imu[nav_begin_ - 1].t_s; }

Eigen::Matrix3d NavigationProblem::initial_attitude(const SensorErrors& candidate) const {
  if (!attitude_source_.depends_on_candidate())  // given / truth: the same for every candidate
    return attitude_source_.attitude(ImuCompensator(SensorErrors{}));
  if (options_.alignment == AlignmentMode::kFixed) return C_b_n_fixed_;
  return aligned(candidate);
}

// Coarse alignment on the window, its failures named with the window's lines and the
// candidate's compensation (a huge value there, or in the data, makes the levelling fail).
Eigen::Matrix3d NavigationProblem::aligned(const SensorErrors& candidate) const {
  try {
    return attitude_source_.attitude(ImuCompensator(candidate));
  } catch (const std::exception& e) {
    std::string compensation;
    for (const auto& [name, value] : nonzero_effects(candidate))
      compensation += (compensation.empty() ? "" : ", ") + name + "=" + number_text(value, 12);
    throw std::invalid_argument(
        "alignment on imu.csv lines 2-" + std::to_string(window_.count + 1) +
        " (align_s = " + number_text(dataset_->meta.align_s, 12) + " s)" +
        (compensation.empty() ? std::string() : " compensated with " + compensation) + ": " +
        e.what());
  }
}

NavState NavigationProblem::initial_state(const Eigen::Matrix3d& C_b_n) const {
  return initial_state(C_b_n, SensorErrors{}, ImuSample{}, 0.0);
}

NavState NavigationProblem::initial_state(const Eigen::Matrix3d& C_b_n,
                                          const SensorErrors& candidate, const ImuSample& previous,
                                          double previous_dt_s) const {
  const double t0 = nav_start_t_s();
  const GnssSample g = interpolate_gnss(dataset_->gnss, t0);
  NavState s;
  s.t_s = t0;
  s.h_m = h_ref_m_[nav_begin_ - 1];
  s.v_eb_n = g.v_eb_n_mps;  // vU: the GNSS one at t0, as the aided references (candidate-free)
  s.q_b_n = Eigen::Quaterniond(C_b_n).normalized();
  const double latency = candidate.gnss_latency_s;
  const Eigen::Vector3d& l_b = candidate.lever_arm_b_m;
  if (latency == 0.0 && l_b.isZero(0)) {  // the GNSS solution as it is, bit for bit
    set_from_gnss(g, 0.0, Eigen::Vector3d::Zero(), l_b, Eigen::Vector3d::Zero(), s);
    return s;
  }
  // The acceleration at t0 from the increment ending there (no INS state before t0): Eq. 1 row 2
  // without the sculling terms, dv_n/dt = C_b_n f_ib_b + g_n - (2 omega_ie_n + omega_en_n) x v_n,
  // at the GNSS position and velocity.
  const EarthModel& earth = dataset_->meta.earth;
  const Eigen::Vector3d a_n =
      C_b_n * (previous.dv_b_mps / previous_dt_s) + earth.gravity_n(g.lat_rad, s.h_m) -
      (2.0 * earth.omega_ie_n(g.lat_rad) + earth.omega_en_n(g.lat_rad, s.h_m, g.v_eb_n_mps))
          .cross(g.v_eb_n_mps);
  set_from_gnss(g, latency, a_n, l_b, previous.dtheta_b_rad / previous_dt_s, s);
  return s;
}

std::vector<WindowStart> NavigationProblem::window_starts(double gnss_latency_s) const {
  std::vector<WindowStart> out;
  out.reserve(restarts_.size());
  const std::vector<ImuSample>& imu = dataset_->imu;
  constexpr double kTimeTol = 1e-9;
  for (std::size_t j = 0; j < restarts_.size(); ++j) {
    if (gnss_latency_s == 0.0) {  // the problem's restarts as they are
      out.push_back({restarts_[j].imu_index, j, 0.0});
      continue;
    }
    // The boundary's antenna time T_j - latency; the first IMU epoch at or after it.
    const double target = restarts_[j].t_s - gnss_latency_s;
    if (target <= nav_start_t_s() + kTimeTol) continue;  // before the navigation: no window
    const auto it =
        std::partition_point(imu.begin() + static_cast<std::ptrdiff_t>(nav_begin_), imu.end(),
                             [&](const ImuSample& m) { return m.t_s < target - kTimeTol; });
    const auto k = static_cast<std::size_t>(it - imu.begin());
    if (k + 1 >= imu.size()) break;  // no restart at or after the last epoch
    if (!out.empty() && k <= out.back().imu_index) continue;  // restarted at already
    out.push_back({k, j, imu[k].t_s - target});
  }
  return out;
}

void NavigationProblem::set_from_gnss(const GnssSample& g, double shift_s,
                                      const Eigen::Vector3d& a_n, const Eigen::Vector3d& l_b,
                                      const Eigen::Vector3d& omega_ib_b, NavState& s) const {
  const EarthModel& earth = dataset_->meta.earth;
  // The start epoch t_k is shift_s after the antenna time of g (g describes the antenna at
  // t_k - shift_s): to first order in shift_s, position g + shift_s v_g and velocity
  // g + shift_s a_n with a_n the acceleration at t_k from the IMU (not g's own slope between GNSS
  // epochs: the difference of two noisy epochs over one GNSS period, which would move the start
  // with the latency by noise that the window's residuals share, a bias). The lever arm:
  // r_ant = r_imu + C_b_n l_b, in curvilinear form to first order in |l_b| / R (Groves 2013 sec.
  // 2.5.5, transposition of navigation solutions), and the antenna velocity of `run`'s
  // comparison, v_ant_n = v_eb_n + C_b_n (omega_ib_b x l_b) - omega_ie_n x (C_b_n l_b) (ibid.),
  // with the rate the comparison uses at t_k and the Earth rate at the IMU's latitude, so that
  // the antenna velocity compared at t_k is the shifted GNSS one again.
  const bool lever = !l_b.isZero(0);
  s.lat_rad = g.lat_rad;
  s.lon_rad = g.lon_rad;
  s.v_eb_n.x() = g.v_eb_n_mps.x();
  s.v_eb_n.y() = g.v_eb_n_mps.y();
  if (shift_s == 0.0 && !lever) return;  // the GNSS solution as it is, bit for bit
  const Eigen::Matrix3d C_b_n = s.q_b_n.toRotationMatrix();
  const Eigen::Vector3d l_n = lever ? Eigen::Vector3d(C_b_n * l_b) : Eigen::Vector3d::Zero();
  const Eigen::Vector3d& v_g = g.v_eb_n_mps;
  s.lat_rad =
      g.lat_rad + (shift_s * v_g.y() - l_n.y()) / (earth.meridian_radius_m(g.lat_rad) + s.h_m);
  s.lon_rad =
      g.lon_rad + (shift_s * v_g.x() - l_n.x()) /
                      ((earth.prime_vertical_radius_m(s.lat_rad) + s.h_m) * std::cos(s.lat_rad));
  if (shift_s != 0.0) {
    s.v_eb_n.x() = v_g.x() + shift_s * a_n.x();
    s.v_eb_n.y() = v_g.y() + shift_s * a_n.y();
  }
  if (!lever) return;
  const Eigen::Vector3d lever_n =
      C_b_n * omega_ib_b.cross(l_b) - earth.omega_ie_n(s.lat_rad).cross(l_n);
  s.v_eb_n.x() -= lever_n.x();
  s.v_eb_n.y() -= lever_n.y();
}

double fitness_from_residuals(std::span<const double> r, FitnessKind kind) {
  double sum = 0.0;
  for (std::size_t e = 0; e + 1 < r.size(); e += 2) {
    const double d2 = r[e] * r[e] + r[e + 1] * r[e + 1];
    sum += kind == FitnessKind::kEq15 ? std::sqrt(d2) : d2;  // Eq. 15
  }
  return sum;
}

double NavigationProblem::fitness(const SensorErrors& candidate, FitnessKind kind) const {
  std::vector<double> r;
  residuals(candidate, r);
  return fitness_from_residuals(r, kind);
}

void NavigationProblem::residuals(const SensorErrors& candidate, std::vector<double>& r) const {
  run(candidate, std::nullopt, {}, r);
}

std::string NavigationProblem::non_finite_report(
    const SensorErrors& candidate, const std::optional<Eigen::Matrix3d>& C_b_n_override) const {
  const auto finite_state = [](const NavState& s) {
    return std::isfinite(s.t_s) && std::isfinite(s.lat_rad) && std::isfinite(s.lon_rad) &&
           std::isfinite(s.h_m) && s.v_eb_n.allFinite() && s.q_b_n.coeffs().allFinite();
  };
  std::size_t steps = 0;
  std::optional<std::size_t> first_bad_imu;  // index into dataset().imu
  double t_bad_s = 0.0;
  std::vector<double> r;
  try {
    run(
        candidate, C_b_n_override,
        [&](const NavState& s) {
          ++steps;
          if (first_bad_imu || finite_state(s)) return;
          first_bad_imu = nav_begin_ + steps - 1;
          t_bad_s = dataset_->imu[*first_bad_imu].t_s;
        },
        r);
  } catch (const std::exception& e) {
    return e.what();
  }
  if (first_bad_imu)
    return "the navigation became non-finite at t = " + number_text(t_bad_s, 12) +
           " s (the step to imu.csv line " + std::to_string(*first_bad_imu + 2) + ")";
  for (std::size_t k = 0; k < r.size(); ++k)
    if (!std::isfinite(r[k]))
      return "the velocity residual at GNSS epoch " + std::to_string(k / 2) + " (gnss.csv line " +
             std::to_string(epoch_gnss_index_[k / 2] + 2) + ") is non-finite";
  return "";
}

void NavigationProblem::run(const SensorErrors& candidate,
                            const std::optional<Eigen::Matrix3d>& C_b_n_override,
                            const std::function<void(const NavState&)>& on_step,
                            std::vector<double>& r) const {
  const Dataset& ds = *dataset_;
  const EarthModel& earth = ds.meta.earth;
  const ImuCompensator compensator(candidate);
  const Eigen::Matrix3d C_b_n0 = C_b_n_override ? *C_b_n_override : initial_attitude(candidate);

  // The increment ending at the navigation start seeds the coning/sculling corrections and
  // gives the rate of the start's lever-arm term.
  ImuSample prev = ds.imu[nav_begin_ - 1];
  const double t_before =
      nav_begin_ >= 2 ? ds.imu[nav_begin_ - 2].t_s : prev.t_s - 1.0 / ds.meta.imu_rate_hz;
  compensator.compensate(prev.t_s, prev.t_s - t_before, prev.dtheta_b_rad, prev.dv_b_mps,
                         motor_on(nav_begin_ - 1));
  Strapdown ins(earth, initial_state(C_b_n0, candidate, prev, prev.t_s - t_before), prev,
                prev.t_s - t_before);

  // INS velocity at the GNSS antenna (lever arm, docs/design.md sec. 4):
  //   v_ant_n = v_eb_n + C_b_n (omega_ib_b x l_b) - omega_ie_n x (C_b_n l_b),
  // with omega_ib_b extrapolated from the last two increments (mid-interval rates) to the epoch.
  const Eigen::Vector3d& l_b = candidate.lever_arm_b_m;
  const bool has_lever_arm = !l_b.isZero(0);
  auto antenna_velocity = [&](const NavState& s, const Eigen::Vector3d& omega_ib_b) {
    if (!has_lever_arm) return Eigen::Vector3d(s.v_eb_n);
    const Eigen::Matrix3d C = s.q_b_n.toRotationMatrix();
    return Eigen::Vector3d(s.v_eb_n + C * omega_ib_b.cross(l_b) -
                           earth.omega_ie_n(s.lat_rad).cross(C * l_b));
  };

  // GNSS tagged t is the antenna state at t - latency: compare with the INS at that time.
  const double latency = candidate.gnss_latency_s;
  const std::size_t n_epochs = epoch_gnss_index_.size();
  r.assign(2 * n_epochs, 0.0);
  std::size_t e = 0;
  auto emit = [&](const Eigen::Vector3d& v_ins_n) {
    const GnssSample& g = ds.gnss[epoch_gnss_index_[e]];
    r[2 * e] = v_ins_n.x() - g.v_eb_n_mps.x();
    r[2 * e + 1] = v_ins_n.y() - g.v_eb_n_mps.y();
    ++e;
  };
  auto epoch_time = [&](std::size_t i) { return ds.gnss[epoch_gnss_index_[i]].t_s - latency; };

  double t_prev = ins.state().t_s;
  Eigen::Vector3d omega_mid_prev = prev.dtheta_b_rad / (prev.t_s - t_before);
  Eigen::Vector3d v_prev = antenna_velocity(ins.state(), omega_mid_prev);
  while (e < n_epochs && epoch_time(e) <= t_prev) emit(v_prev);  // clamped to the start

  // Windowed fitness: this candidate's window starts (restarts_ moved by its latency).
  const std::vector<WindowStart> starts = window_starts(latency);
  std::size_t next_restart = 0;  // the next in starts
  for (std::size_t k = nav_begin_; k < ds.imu.size(); ++k) {
    ImuSample inc = ds.imu[k];
    compensator.compensate(inc.t_s, inc.t_s - ds.imu[k - 1].t_s, inc.dtheta_b_rad, inc.dv_b_mps,
                           motor_on(k));
    ins.step_aided(inc, h_ref_m_[k], vU_ref_mps_[k]);
    const NavState& s = ins.state();
    const Eigen::Vector3d omega_at_epoch = 1.5 * ins.omega_ib_b() - 0.5 * omega_mid_prev;
    omega_mid_prev = ins.omega_ib_b();
    Eigen::Vector3d v_now = antenna_velocity(s, omega_at_epoch);
    // INS velocity linearly interpolated to GNSS epochs inside (t_prev, t_k].
    while (e < n_epochs && epoch_time(e) <= s.t_s) {
      const double w = (epoch_time(e) - t_prev) / (s.t_s - t_prev);
      emit(v_prev + w * (v_now - v_prev));
    }
    if (on_step) on_step(s);
    t_prev = s.t_s;
    if (next_restart < starts.size() && starts[next_restart].imu_index == k) {
      // Windowed fitness: the epochs up to t_k closed the window; restart as at the navigation
      // start (nav/fitness.h, "Start state"): position and horizontal velocity of the IMU from
      // the GNSS solution at the boundary T_j, shifted by t_k - (T_j - latency) (with the
      // antenna's INS acceleration over this step), less the candidate's lever arm (attitude
      // carried on, the rate extrapolated to t_k); aided h and vU; this compensated increment as
      // the coning/sculling memory, previous state = restart state.
      const WindowStart& start = starts[next_restart++];
      const WindowRestart& restart = restarts_[start.restart];
      NavState s0 = s;
      GnssSample g;
      g.lat_rad = restart.lat_rad;
      g.lon_rad = restart.lon_rad;
      g.v_eb_n_mps = Eigen::Vector3d(restart.vE_mps, restart.vN_mps, 0.0);
      // The antenna's acceleration over this step (so that a start one step later, shifted by
      // one more step, lands where this one's INS goes: the fitness is continuous in latency).
      const Eigen::Vector3d a_n = (v_now - v_prev) / (inc.t_s - ds.imu[k - 1].t_s);
      set_from_gnss(g, start.shift_s, a_n, l_b, omega_at_epoch, s0);
      ins = Strapdown(earth, s0, inc, inc.t_s - ds.imu[k - 1].t_s);
      v_now = antenna_velocity(ins.state(), omega_at_epoch);
    }
    v_prev = v_now;
  }
  while (e < n_epochs) emit(v_prev);  // epochs past the data end (latency > 0): clamped
}

}  // namespace insid
