// Per-candidate pipeline of the paper (Sec. 2.3 step 2, docs/design.md sec. 2): compensate the
// sensor data with the candidate, align, navigate pure-inertially (height aided), and compare
// the INS velocity with the GNSS velocity at GNSS epochs after the alignment window.
//   fitness (Eq. 15) = sum_t sqrt(dvE_t^2 + dvN_t^2),
// also offered: the sum of squares and the residual vector (dvE_t, dvN_t).
//
// Windowed fitness (NavigationOptions::window_s = W > 0). On data whose pure-INS run
// diverges within minutes (MEMS), the INS is restarted from the GNSS solution every W seconds so
// that each residual holds only what the candidate's errors build in one window:
//   - The boundaries: T_j = t_{m_j} for j = 1, 2, ..., m_j the first IMU epoch at or after the
//     nominal time t0 + j W (t0 = nav_start_t_s(), 1e-9 s tolerance), for every nominal time
//     before the last IMU epoch. Nominal times that fall on an IMU epoch taken already are
//     skipped, so the T_j are distinct and increasing (window_restarts(); the same for every
//     candidate).
//   - A candidate with GNSS latency L restarts at the antenna time of each boundary, T_j - L:
//     after IMU step k_j, the first IMU epoch at or after T_j - L (1e-9 s tolerance), dropping a
//     boundary whose antenna time falls at or before t0, at or after the last IMU epoch, or on
//     an epoch restarted at already (window_starts(L); k_j = m_j for L = 0).
//   - The state after step k_j is replaced as at the navigation start ("Start state" below):
//     latitude, longitude and (vE, vN) per candidate from the GNSS solution at T_j, height and
//     vU the aided references; the attitude and the previous compensated increment
//     (coning/sculling memory) are carried on; the mid-point extrapolation restarts as at the
//     start (previous state = restart state).
//   - GNSS epoch e, compared at tau_e = t_e - L, belongs to window j when
//     t_{k_j} < tau_e <= t_{k_{j+1}} (k_0 = nav_begin() - 1; the epochs clamped to the start
//     belong to window 0, those past the data end to the last window): an epoch at a restart
//     epoch closes its window (is compared with the INS before the restart). With the windows
//     in antenna time, the epochs of a window do not change with L (t_{k_j} - tau_e =
//     T_j - t_e + the start's shift, in [0, one IMU interval)), unless a GNSS epoch lies within
//     one IMU interval after a boundary; so the fitness is continuous in L. (Shared restart
//     epochs moved an epoch to the next window as its tau_e passed one: a jump at every L that
//     puts an epoch on a restart, e.g. at 0.2 s exactly, where a latency fit landed with an sd
//     of 0.26 ms and not_converged.)
//   - Eq. 15, the sum of squares and the residual vector (same layout, one entry pair per
//     epoch) are therefore summed over all windows.
//   - W shorter than one GNSS period (1 / gnss_rate_hz) is refused (windows without an epoch).
//     W at or beyond the navigated span gives no restart: the result is bit-identical to W = 0.
//
// Start state (the navigation start t0 and every window start t_{k_j}; NavigationProblem::
// set_from_gnss). The GNSS solution tagged t is the antenna at t - L
// (model/sensor_errors.h), and the comparison above sees the candidate's antenna velocity at
// t_e - L. A start must hold the same model, per candidate, or it carries the effects' own
// signal into the window and cancels most of it there (a start from the GNSS solution at the
// restart epoch t_k, as the IMU's velocity, found a hidden 0.2 s latency as 38 +- 8 ms and a
// (1.0, 0.5) m lever arm as (-0.14, 0.17) m at W = 10 s on a 600 s nav racetrack). With g the
// GNSS solution at the start's reference time (at a window start g at T_j, the boundary: the
// antenna at T_j - L; at t0, g at t0, interpolate_gnss; both candidate-independent) and
// `shift` the start time minus the antenna time of g:
//   - shift: at a window start t_{k_j} - (T_j - L), less than one IMU interval; at t0 it is L.
//     To first order in it: position g + shift v_g (north over RM(lat_g) + h, east over
//     (RN + h) cos(lat)), velocity g + shift a_n, with a_n: at a window start the candidate's
//     antenna acceleration over the step ending there (its INS antenna velocity at t_k minus
//     that at t_{k-1}, over the interval: a start one step later lands where the earlier
//     start's INS goes, so the fitness stays continuous in L); at t0 (no INS state before) the
//     compensated increment ending there, C_b_n dv_b / dt + g_n - (2 omega_ie_n + omega_en_n)
//     x v_g (the start of a flight is static or slow; the term is L a, dropped terms L^2 / 2
//     times the jerk). Not g's own slope between GNSS epochs: the difference of two noisy
//     epochs over one GNSS period would move the start with L by noise that the window's
//     residuals share, a bias (4.3 sd at W = 10 s on the 300 s test flight, with g interpolated
//     to t_k + L).
//   - lever arm l_b: the IMU is the antenna less the lever arm, with the attitude C_b_n at the
//     start (at t0 the aligned one, at a window start the one carried on): position less
//     C_b_n l_b (north over RM(lat_g) + h, east over (RN + h) cos(lat); Groves 2013 sec.
//     2.5.5), velocity less C_b_n (omega_ib_b x l_b) - omega_ie_n x (C_b_n l_b) at the IMU's
//     latitude, with the rate the comparison uses there (at t0 the mean rate of the compensated
//     increment ending at t0, at a window start the mid-interval rates extrapolated to t_k):
//     the antenna velocity compared at the start is then g + shift a_n again.
//   - height and vU: the aided references (GNSS h and vU interpolated to the IMU epoch, the
//     same for every candidate; at t0 vU is the GNSS one at t0). The latency and the lever arm
//     leave them unshifted: their error (L times the vertical velocity or acceleration, the
//     vertical lever-arm terms: cm and cm/s on these flights) reaches the horizontal channels
//     only through the Coriolis term 2 omega_ie cos(lat) vU (~1e-4 of it) and the radii
//     (h / R), far below the GNSS noise. Measured on the noise-free 300 s racetrack of
//     tests/batch_fitness_test.cc (latency 0.2 s, lever arm (1, 0.5, 0) m) with the references
//     taken per candidate at t_k + L less the vertical lever-arm terms: Eq. 15 at the truth
//     0.0116 -> 0.0011 at W = 10 s, 0.030 -> 0.0045 at W = 0 (over 2900 epochs: ~4 um/s
//     each), the values 20 ms and 0.1 m to either side within 0.05 %; the minimum stays put.
//   - the IMU-side effects enter through the attitude C_b_n (per-candidate alignment, and the
//     window's navigation), the compensated rate and increment, and a_n (the candidate's own
//     navigation); the GNSS-side effects are only the latency and the lever arm.
//   - without latency and lever arm, the start is g as it is, at the same epochs, bit for bit
//     (W = 0 included): the start carries no GNSS-side model to undo.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "data/dataset.h"
#include "model/sensor_errors.h"
#include "nav/alignment.h"
#include "nav/mechanization.h"

namespace insid {

enum class AlignmentMode {
  kPerCandidate,  ///< align from the data compensated with each candidate (paper, default)
  kFixed,         ///< align once from the data as recorded; same attitude for every candidate
};
std::string to_string(AlignmentMode mode);
/// "per-candidate" | "fixed"; throws std::invalid_argument otherwise.
AlignmentMode alignment_mode_from_string(const std::string& text);

enum class FitnessKind { kEq15, kSumSquares };

/// The fitness of a residual vector r = (dvE_0, dvN_0, dvE_1, dvN_1, ...) (m/s), as
/// NavigationProblem::residuals orders it: Eq. 15, sum_t sqrt(dvE_t^2 + dvN_t^2), or the sum of
/// squares. The one implementation of the sum (NavigationProblem::fitness and the
/// identification problem's residual path both call it, so their results are bit-identical).
double fitness_from_residuals(std::span<const double> r, FitnessKind kind = FitnessKind::kEq15);

struct NavigationOptions {
  AlignmentMode alignment = AlignmentMode::kPerCandidate;
  /// Windowed fitness (see the top of this file): 0 = one pure-INS run over the whole flight
  /// (the paper's Eq. 15, the default); W > 0 = the INS restarted from GNSS position and
  /// velocity every W seconds after the navigation start, attitude carried on (s).
  double window_s = 0.0;
  /// "" when valid, else what is wrong, naming the bad value: window_s must be finite and >= 0
  /// (the project's one convention for options). The data-dependent check, W at least one GNSS
  /// period, is NavigationProblem's.
  std::string validate() const;
  /// How the attitude at the navigation start is found (nav/alignment.h).
  InitialAttitudeOptions initial_attitude{};
};

/// One window boundary of the windowed fitness (top of this file): a candidate without latency
/// restarts after IMU step `imu_index`, its position and horizontal velocity replaced by the
/// GNSS solution at t_s (less its lever arm); a latency L moves the restart to the antenna time
/// t_s - L (WindowStart), from the same GNSS values.
struct WindowRestart {
  std::size_t imu_index = 0;  ///< index into Dataset::imu of the step the restart follows
  double t_s = 0.0;           ///< its time (s)
  double lat_rad = 0.0;       ///< GNSS latitude at t_s (rad)
  double lon_rad = 0.0;       ///< GNSS longitude at t_s (rad)
  double vE_mps = 0.0;        ///< GNSS east velocity at t_s (m/s)
  double vN_mps = 0.0;        ///< GNSS north velocity at t_s (m/s)
};

/// One window start of a candidate with GNSS latency L (top of this file, "Windowed fitness"):
/// restart `restart` of NavigationProblem::window_restarts() (epoch T_j) moved to the antenna
/// time of its boundary, T_j - L. It follows IMU step `imu_index`, the first at or after
/// T_j - L, and starts from the GNSS solution at T_j shifted by `shift_s` = t_imu_index -
/// (T_j - L), in [0, one IMU interval).
struct WindowStart {
  std::size_t imu_index = 0;  ///< index into Dataset::imu of the step the restart follows
  std::size_t restart = 0;    ///< index into window_restarts()
  double shift_s = 0.0;       ///< start time minus the boundary's antenna time (s)
};

/// Everything about one dataset that does not depend on the candidate, computed once:
/// alignment window sums, the navigation start, the height reference at every IMU epoch and
/// the GNSS epochs that are compared. Thread-safe to evaluate from several threads.
class NavigationProblem {
 public:
  NavigationProblem(std::shared_ptr<const Dataset> dataset, NavigationOptions options = {});

  const Dataset& dataset() const { return *dataset_; }
  const NavigationOptions& options() const { return options_; }
  /// Index of the first IMU sample navigated (the one after the alignment window).
  std::size_t nav_begin() const { return nav_begin_; }
  double nav_start_t_s() const;
  /// Number of GNSS epochs compared (residual vector length is twice this).
  std::size_t num_epochs() const { return epoch_gnss_index_.size(); }
  /// Number of navigation (IMU) steps in one run.
  std::size_t num_steps() const { return dataset_->imu.size() - nav_begin_; }
  /// Precomputed, candidate-independent data (read by the batched kernel, kernel/batch_fitness.h):
  /// height and vertical velocity references at every IMU epoch, the GNSS rows compared.
  const std::vector<double>& height_reference_m() const { return h_ref_m_; }
  const std::vector<double>& vertical_velocity_reference_mps() const { return vU_ref_mps_; }
  const std::vector<std::size_t>& epoch_gnss_indices() const { return epoch_gnss_index_; }
  /// The part of IMU row k's step the motors ran (DatasetMeta::motors; row 0's step is one
  /// nominal period long); 0 for every row when the dataset has no motor state.
  double motor_on(std::size_t k) const { return motor_on_.empty() ? 0.0 : motor_on_[k]; }
  /// Window sums of the alignment (count == 0 when align_s = 0).
  const AlignmentWindow& alignment_window() const { return window_; }
  /// The restarts of the windowed fitness in time order (empty when window_s = 0 or W covers
  /// the navigated span); read by the batched kernel too.
  const std::vector<WindowRestart>& window_restarts() const { return restarts_; }
  /// Number of fitness windows (1 + the restarts).
  std::size_t num_windows() const { return restarts_.size() + 1; }
  /// The window starts of a candidate with this GNSS latency, in time order (the restarts as
  /// they are for 0; a boundary whose antenna time falls at or before the navigation start, or
  /// at or after the last IMU epoch, or on an IMU epoch started at already, is dropped).
  std::vector<WindowStart> window_starts(double gnss_latency_s) const;

  /// Initial attitude the candidate would get from alignment (per options).
  Eigen::Matrix3d initial_attitude(const SensorErrors& candidate) const;
  /// The initial-attitude mode set up for this dataset (course epochs, feasibility figures).
  const InitialAttitude& initial_attitude_source() const { return attitude_source_; }
  /// State at the navigation start for a given attitude (see the top of this file, "Start
  /// state"): position and horizontal velocity from the GNSS solution at t0 shifted by the
  /// candidate's latency and less its lever arm; `previous` is the compensated increment ending
  /// at t0 (its rate and specific force give the lever-arm term and the acceleration), over
  /// `previous_dt_s`; height and vU the candidate-independent references at t0.
  NavState initial_state(const Eigen::Matrix3d& C_b_n, const SensorErrors& candidate,
                         const ImuSample& previous, double previous_dt_s) const;
  /// The same for a candidate without latency or lever arm (the GNSS solution at t0 as it is).
  NavState initial_state(const Eigen::Matrix3d& C_b_n) const;

  /// Eq. 15 fitness of a candidate.
  double fitness(const SensorErrors& candidate, FitnessKind kind = FitnessKind::kEq15) const;
  /// Residuals r = (dvE_0, dvN_0, dvE_1, dvN_1, ...), INS minus GNSS (m/s), size 2*num_epochs.
  void residuals(const SensorErrors& candidate, std::vector<double>& r) const;

  /// Why a candidate's run is not finite, "" when it is (one full run; for error messages):
  /// "the navigation became non-finite at t = 12.3 s (the step to imu.csv line 1235)", the first
  /// non-finite residual's GNSS epoch and gnss.csv line, or the set-up error (e.g. alignment).
  std::string non_finite_report(const SensorErrors& candidate,
                                const std::optional<Eigen::Matrix3d>& C_b_n_override = {}) const;

  /// Full run with callbacks (for `insid navigate` and diagnostics). `C_b_n_override` replaces
  /// the aligned initial attitude (e.g. truth). `on_step` sees the state after every IMU step
  /// (with window_s > 0, at a restart epoch the state before the restart).
  /// Returns the residual vector as `residuals` does.
  void run(const SensorErrors& candidate, const std::optional<Eigen::Matrix3d>& C_b_n_override,
           const std::function<void(const NavState&)>& on_step, std::vector<double>& r) const;

 private:
  Eigen::Matrix3d aligned(const SensorErrors& candidate) const;
  /// Start state of the navigation or of a window (top of this file, "Start state"): latitude,
  /// longitude, vE and vN of `s` from the GNSS solution `g` at the boundary, shifted in time by
  /// `shift_s` (position with g's velocity, velocity with the IMU's acceleration `a_n`) and less
  /// the lever arm `l_b` (with the attitude and height of `s` and the body rate `omega_ib_b`);
  /// the other fields are kept.
  void set_from_gnss(const GnssSample& g, double shift_s, const Eigen::Vector3d& a_n,
                     const Eigen::Vector3d& l_b, const Eigen::Vector3d& omega_ib_b,
                     NavState& s) const;
  std::shared_ptr<const Dataset> dataset_;
  NavigationOptions options_;
  std::size_t nav_begin_ = 0;
  AlignmentWindow window_;
  InitialAttitude attitude_source_;
  Eigen::Matrix3d C_b_n_fixed_ = Eigen::Matrix3d::Identity();
  std::vector<double> h_ref_m_;     // GNSS height interpolated at every IMU epoch
  std::vector<double> vU_ref_mps_;  // GNSS vertical velocity interpolated at every IMU epoch
  std::vector<std::size_t> epoch_gnss_index_;  // GNSS rows compared, in time order
  std::vector<WindowRestart> restarts_;        // windowed fitness, in time order
  std::vector<double> motor_on_;  // motor part of every IMU row's step; empty without motors
};

}  // namespace insid
