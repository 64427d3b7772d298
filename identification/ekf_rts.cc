// Loosely coupled INS/GNSS error-state EKF with closed-loop feedback + Rauch-Tung-Striebel
// smoother.
//
// Error-state model: the local-level (here ENU) psi/phi-angle error model of Groves (2013,
// "Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems", 2nd ed.,
// sec. 14.2.4 and ch. 14.3 loosely coupled integration) and Shin (2001, UCGE 20156, ch. 3),
// the 15-state (21 with scale factors) form also used by KF-GINS; our own code, simplified where
// the terms are negligible over a GNSS interval. States (estimate minus truth, except sensor
// errors, which are truth minus estimate so that the correction adds):
//   dr (E, N, U metres), dv (ENU), phi (attitude error: C_b_n_est = (I - [phi x]) C_b_n_true),
//   db_g, db_a [, ds_g, ds_a].
// Dynamics (continuous, F):
//   dr'  = dv
//   dv'  = [f_n x] phi - (2 w_ie + w_en) x dv + C_b_n (db_a + diag(f_b) ds_a) + (0, 0, 2g/R dr_U)
//   phi' = -w_in x phi + d(w_en)/dv dv - C_b_n (db_g + diag(w_b) ds_g)
//   sensor errors: random constants (the dataset's noise block has no bias instability).
// Discretisation every propagation_interval_s: Phi = I + F dt + (F dt)^2 / 2 with F at the
// current state and the interval's mean specific force and rate; Q = diag(VRW^2, ARW^2) dt on
// dv and phi (isotropic noise: the body-to-n rotation leaves it diagonal).
// Measurements every update_interval_s at the IMU epoch (GNSS interpolated linearly to it):
// INS minus GNSS position (ENU metres) and velocity, H = [I 0 ...; 0 I ...], Joseph update. The
// lever arm and GNSS latency are not modelled. After each update the error estimate is fed back
// (position, velocity, attitude, sensor errors) and the strapdown restarts from the corrected
// state.
// Smoother: for closed-loop feedback the error state is zero after each reset, so with A_k =
// P_k|k Phi_k^T P_k+1|k^-1 the smoothed error relative to the corrected state at update k is
//   e_k = A_k (e_k+1 + dx_k+1),   P_k|N = P_k|k + A_k (P_k+1|N - P_k+1|k) A_k^T,   e_N = 0,
// where dx_k+1 is the correction applied at update k+1. Reported: the smoothed sensor errors at
// the navigation start (the estimate of the constant biases given all the data) and their
// standard deviations, and the forward filter's final values.
#include "identification/ekf_rts.h"
#include "data/gnss_interpolation.h"

#include <cmath>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <Eigen/Dense>

#include "data/grade_table.h"
#include "data/noise_model.h"
#include "identification/search_fitness.h"
#include "model/rotation.h"
#include "model/units.h"
#include "nav/mechanization.h"
#include "optimizers/registry.h"

namespace insid {
namespace {

// Floors that keep the filter numerically healthy on noise-free data (the defaults without a
// noise block are the nav grade's levels, data/grade_table.h).
constexpr NoiseLevels kNoiseFloor{1e-4, 1e-4, 1e-3, 1e-2};

enum : int { kR = 0, kV = 3, kPhi = 6, kBg = 9, kBa = 12, kSg = 15, kSa = 18 };

struct UpdateRecord {
  Eigen::MatrixXd P_post;        // after the update (or the initial P)
  Eigen::MatrixXd Phi_next;      // to the next update
  Eigen::MatrixXd P_prior_next;  // prior covariance at the next update
  Eigen::VectorXd dx;            // correction applied at this update (0 for the initial)
  Eigen::VectorXd sensor_est;    // sensor-error estimates after this update (bg, ba, [sg, sa])
};

std::vector<std::string> sensor_names(bool scale) {
  std::vector<std::string> n = {"gyro_bias_x",  "gyro_bias_y",  "gyro_bias_z",
                                "accel_bias_x", "accel_bias_y", "accel_bias_z"};
  if (scale)
    for (const char* s : {"gyro_scale_x", "gyro_scale_y", "gyro_scale_z", "accel_scale_x",
                          "accel_scale_y", "accel_scale_z"})
      n.emplace_back(s);
  return n;
}

double pick(double override_value, std::optional<double> data, double fallback, double floor) {
  const double v = override_value >= 0.0 ? override_value : (data ? *data : fallback);
  return std::max(v, floor);
}

}  // namespace

std::span<const opt::ParameterField<EkfRtsParams>> EkfRtsParams::fields() {
  static const opt::ParameterField<EkfRtsParams> kFields[] = {
      {"update_interval_s", &EkfRtsParams::update_interval_s, "GNSS update interval (s)"},
      {"propagation_interval_s", &EkfRtsParams::propagation_interval_s,
       "covariance propagation step (s)"},
      {"scale_factors", &EkfRtsParams::scale_factors, "1: estimate scale factors too"},
      {"use_position", &EkfRtsParams::use_position, "1: GNSS position and velocity, 0: velocity"},
      {"arw_deg_rth", &EkfRtsParams::arw_deg_rth, "angle random walk; < 0: from the dataset"},
      {"vrw_mps_rth", &EkfRtsParams::vrw_mps_rth, "velocity random walk; < 0: from the dataset"},
      {"gnss_vel_sigma_mps", &EkfRtsParams::gnss_vel_sigma_mps,
       "GNSS velocity noise; < 0: from the dataset"},
      {"gnss_pos_sigma_m", &EkfRtsParams::gnss_pos_sigma_m,
       "GNSS position noise; < 0: from the dataset"},
      {"initial_bias_sigma", &EkfRtsParams::initial_bias_sigma,
       "prior std of each bias, catalogue sigma units"},
      {"initial_scale_ppm", &EkfRtsParams::initial_scale_ppm, "prior std of each scale factor"},
  };
  return kFields;
}

std::string EkfRtsParams::validate() const {
  for (std::string error :
       {opt::check_positive(kAlgorithm, "update_interval_s", update_interval_s),
        opt::check_positive(kAlgorithm, "propagation_interval_s", propagation_interval_s),
        opt::check_range(kAlgorithm, "scale_factors", scale_factors, 0, 1),
        opt::check_range(kAlgorithm, "use_position", use_position, 0, 1),
        opt::check_positive(kAlgorithm, "initial_bias_sigma", initial_bias_sigma),
        opt::check_positive(kAlgorithm, "initial_scale_ppm", initial_scale_ppm)}) {
    if (!error.empty()) return error;
  }
  return {};
}

nlohmann::json EkfRtsResult::to_json() const {
  nlohmann::json j;
  j["smoothed_estimate"] = estimate;
  j["smoothed_std"] = std;
  j["filtered_estimate"] = filtered_estimate;
  j["filtered_std"] = filtered_std;
  j["noise_used"] = {{"arw_deg_rth", noise_used.arw_deg_rth},
                     {"vrw_mps_rth", noise_used.vrw_mps_rth},
                     {"gnss_vel_sigma_mps", noise_used.gnss_vel_sigma_mps},
                     {"gnss_pos_sigma_m", noise_used.gnss_pos_sigma_m},
                     {"source", noise_source}};
  j["updates"] = updates;
  j["states"] = states;
  j["nis_per_dof"] = nis_per_dof;
  j["nis_dof"] = nis_dof;
  if (setup) {
    j["setup"] = {{"grade", setup->grade.name},
                  {"passes", setup->passes},
                  {"relinearisation_prior_factor", setup->relinearisation_prior_factor},
                  {"prior",
                   "bias sd initial_bias_sigma x grade sigma; attitude error tied to "
                   "the bias errors through the initial-attitude mode"},
                  {"initial_tilt_sd_rad", initial_tilt_sd_rad},
                  {"initial_heading_sd_rad", initial_heading_sd_rad}};
  }
  j["filter_wall_s"] = filter_wall_s;
  j["smoother_wall_s"] = smoother_wall_s;
  return j;
}

namespace {

// The initial attitude's error model of the grade-aware set-up (ekf_rts.h): G = d phi0 / d
// (gyro bias, accel bias) of the problem's initial-attitude mode at `base`, by central
// differences (step 1 % of the grade's sigma; the mode's attitude is smooth in the biases and
// O(1) per candidate), and the sd of the mode's own noise (tilt, heading).
struct AttitudeErrorModel {
  Eigen::Matrix3d C_b_n;  // the mode's attitude at `base`
  Eigen::Matrix<double, 3, 6> G = Eigen::Matrix<double, 3, 6>::Zero();
  double tilt_sd_rad = 0.0, heading_sd_rad = 0.0;
};

AttitudeErrorModel attitude_error_model(const NavigationProblem& navigation,
                                        const SensorErrors& base, const SensorGrade& grade,
                                        const NoiseLevels& noise) {
  const InitialAttitude& source = navigation.initial_attitude_source();
  AttitudeErrorModel m;
  m.C_b_n = source.attitude(ImuCompensator(base));
  if (source.depends_on_candidate()) {
    for (int i = 0; i < 6; ++i) {
      const double h = 0.01 * (i < 3 ? grade.gyro_bias_rad_s : grade.accel_bias_mps2);
      SensorErrors plus = base, minus = base;
      (i < 3 ? plus.gyro.bias : plus.accel.bias)[i % 3] += h;
      (i < 3 ? minus.gyro.bias : minus.accel.bias)[i % 3] -= h;
      // C(b + d) ~ (I + [g d x]) C(b): g from the skew part of C(b + h) C(b - h)^T.
      const Eigen::Matrix3d R = source.attitude(ImuCompensator(plus)) *
                                source.attitude(ImuCompensator(minus)).transpose();
      const Eigen::Matrix3d A = 0.5 * (R - R.transpose());
      m.G.col(i) = Eigen::Vector3d(A(2, 1), A(0, 2), A(1, 0)) / (2.0 * h);
    }
  }
  const Dataset& ds = navigation.dataset();
  const double window_s = navigation.alignment_window().sum_dt_s;
  const double g = kStandardGravity_mps2;
  const double vrw_rts = noise.vrw_mps_rth / 60.0, arw_rts = noise.arw_deg_rth * kDegToRad / 60.0;
  const InitialAttitudeOptions& options = source.options();
  switch (options.mode) {
    case InitialAttitudeMode::kGyrocompass:
      m.tilt_sd_rad = window_s > 0.0 ? vrw_rts / (g * std::sqrt(window_s)) : 0.01;
      m.heading_sd_rad = source.feasibility() ? source.feasibility()->heading_sd_rad : 0.1;
      break;
    case InitialAttitudeMode::kLevelHeading: {
      m.tilt_sd_rad = window_s > 0.0 ? vrw_rts / (g * std::sqrt(window_s)) : 0.01;
      if (options.heading_deg) {
        m.heading_sd_rad = 1.0 * kDegToRad;  // a given heading: taken to 1 deg
        break;
      }
      if (const auto& measured = source.measured_heading()) {
        // The mean's own sd, and the carry's gyro noise when taken after the start.
        const double t_carry =
            measured->carried ? measured->t_last_s - navigation.nav_start_t_s() : 0.0;
        m.heading_sd_rad =
            std::sqrt(std::pow(measured->sd_rad, 2) + arw_rts * arw_rts * std::max(t_carry, 0.0));
        break;
      }
      double var_course = 0.0, t_carry = 0.0;
      const auto& fixes = source.course_fixes();
      for (const CourseFix& f : fixes) {
        var_course += std::pow(noise.gnss_vel_sigma_mps / std::max(f.speed_mps, 1e-3), 2);
        t_carry = std::max(t_carry, f.t_s - navigation.nav_start_t_s());
      }
      const double n = std::max<double>(static_cast<double>(fixes.size()), 1.0);
      m.heading_sd_rad = std::sqrt(var_course / (n * n) + arw_rts * arw_rts * t_carry);
      break;
    }
    case InitialAttitudeMode::kGiven:
    case InitialAttitudeMode::kTruth:
      m.tilt_sd_rad = m.heading_sd_rad = 1e-3;
      break;
  }
  (void)ds;
  m.tilt_sd_rad = std::max(m.tilt_sd_rad, 1e-4);
  m.heading_sd_rad = std::max(m.heading_sd_rad, 1e-4);
  return m;
}

// The filter's noise levels: each from the parameters when given, else the dataset's noise block,
// else the defaults, never below kNoiseFloor (pick). Defaults: nav's levels without a grade
// set-up (the original set-up, bit for bit); with one, the IMU random walks measured in the
// data's flight (estimate_flight_imu_noise) and the grade's GNSS levels. A grade's ARW is a
// datasheet figure of the sensor at rest; on a drone the motors' vibration raises the in-flight
// noise 10-100x (the shared ArduPilot log: 3-25 deg/sqrt(h) against the MEMS grade's 0.2), and a
// filter told the quiet figure trusts the IMU that much too far: on simulated drone flights with
// the log's noise its 95 % intervals covered 4 of 12 biases with the grade's levels, 115 of 120
// with the right ones (results/uncertainty/README.md). `source` says which was used.
NoiseLevels ekf_noise_levels(const Dataset& ds, const EkfRtsParams& params,
                             const EkfRtsGradeSetup* setup, std::string* source = nullptr) {
  const std::optional<NoiseLevels>& dn = ds.meta.noise;
  NoiseLevels defaults = setup ? setup->grade.noise : grade_figures("nav").noise;
  const bool imu_measured = setup && !dn && (params.arw_deg_rth < 0.0 || params.vrw_mps_rth < 0.0);
  if (imu_measured) {
    const NoiseLevels flight = estimate_flight_imu_noise(ds);
    defaults.arw_deg_rth = flight.arw_deg_rth;
    defaults.vrw_mps_rth = flight.vrw_mps_rth;
  }
  if (source)
    *source =
        dn             ? "meta.json (parameters where given)"
        : imu_measured ? "IMU: measured in the flight (MAD of second differences of the increments "
                         "after the static window); GNSS: the " +
                             std::string(setup->grade.name) + " grade's (parameters where given)"
        : setup ? "the " + std::string(setup->grade.name) + " grade's (parameters where given)"
                : "nav defaults (parameters where given)";
  NoiseLevels noise;
  noise.arw_deg_rth = pick(params.arw_deg_rth, dn ? std::optional(dn->arw_deg_rth) : std::nullopt,
                           defaults.arw_deg_rth, kNoiseFloor.arw_deg_rth);
  noise.vrw_mps_rth = pick(params.vrw_mps_rth, dn ? std::optional(dn->vrw_mps_rth) : std::nullopt,
                           defaults.vrw_mps_rth, kNoiseFloor.vrw_mps_rth);
  noise.gnss_vel_sigma_mps =
      pick(params.gnss_vel_sigma_mps, dn ? std::optional(dn->gnss_vel_sigma_mps) : std::nullopt,
           defaults.gnss_vel_sigma_mps, kNoiseFloor.gnss_vel_sigma_mps);
  noise.gnss_pos_sigma_m =
      pick(params.gnss_pos_sigma_m, dn ? std::optional(dn->gnss_pos_sigma_m) : std::nullopt,
           defaults.gnss_pos_sigma_m, kNoiseFloor.gnss_pos_sigma_m);
  return noise;
}

// The initial state covariance: position and velocity from the GNSS noise, attitude and sensor
// errors from params.initial_bias_sigma in catalogue sigmas; with a grade set-up (attitude_model),
// the grade's bias priors (no wider than bias_prior_sd) and the attitude error tied to them,
// phi0 = G db + w (ekf_rts.h).
Eigen::MatrixXd initial_covariance(int N, bool scale, const EkfRtsParams& params,
                                   const NoiseLevels& noise, const EarthModel& earth, double lat0,
                                   const std::optional<AttitudeErrorModel>& attitude_model,
                                   const EkfRtsGradeSetup* setup,
                                   const Eigen::Matrix<double, 6, 1>* bias_prior_sd) {
  using Mat = Eigen::MatrixXd;
  Mat P = Mat::Zero(N, N);
  const double heading_sigma =
      std::clamp(params.initial_bias_sigma * kSigmaGyroRadS /
                     (earth.omega_ie_rad_s * std::max(std::cos(lat0), 0.1)),
                 1e-3, 0.1);
  const double tilt_sigma = std::max(params.initial_bias_sigma * kSigmaAccelMps2 / 9.8 * 3.0, 1e-4);
  P.block<3, 3>(kR, kR) =
      Eigen::Matrix3d::Identity() * std::pow(std::max(noise.gnss_pos_sigma_m, 0.1), 2);
  P.block<3, 3>(kV, kV) =
      Eigen::Matrix3d::Identity() * std::pow(std::max(noise.gnss_vel_sigma_mps, 0.01), 2);
  P.block<3, 3>(kPhi, kPhi) = Eigen::Vector3d(tilt_sigma * tilt_sigma, tilt_sigma * tilt_sigma,
                                              heading_sigma * heading_sigma)
                                  .asDiagonal();
  P.block<3, 3>(kBg, kBg) =
      Eigen::Matrix3d::Identity() * std::pow(params.initial_bias_sigma * kSigmaGyroRadS, 2);
  P.block<3, 3>(kBa, kBa) =
      Eigen::Matrix3d::Identity() * std::pow(params.initial_bias_sigma * kSigmaAccelMps2, 2);
  if (scale) {
    P.block<6, 6>(kSg, kSg) = Mat::Identity(6, 6) * std::pow(params.initial_scale_ppm * 1e-6, 2);
  }
  if (attitude_model) {
    // Grade-aware prior (ekf_rts.h): bias priors from the grade, the attitude error tied to
    // the bias errors through the initial-attitude mode, phi0 = G db + w.
    Eigen::Matrix<double, 6, 6> Pb = Eigen::Matrix<double, 6, 6>::Zero();
    Pb.diagonal().head<3>().setConstant(
        std::pow(params.initial_bias_sigma * setup->grade.gyro_bias_rad_s, 2));
    Pb.diagonal().tail<3>().setConstant(
        std::pow(params.initial_bias_sigma * setup->grade.accel_bias_mps2, 2));
    if (bias_prior_sd) Pb.diagonal() = bias_prior_sd->cwiseAbs2().cwiseMin(Pb.diagonal());
    const Eigen::Matrix<double, 3, 6>& G = attitude_model->G;
    const double t2 = std::pow(attitude_model->tilt_sd_rad, 2);
    P.block<3, 3>(kPhi, kPhi) = G * Pb * G.transpose();
    P.block<3, 3>(kPhi, kPhi) +=
        Eigen::Vector3d(t2, t2, std::pow(attitude_model->heading_sd_rad, 2))
            .asDiagonal()
            .toDenseMatrix();
    P.block<6, 6>(kBg, kBg) = Pb;
    P.block<3, 6>(kPhi, kBg) = G * Pb;
    P.block<6, 3>(kBg, kPhi) = (G * Pb).transpose();
  }
  return P;
}

// The error-state transition over `dt` (the dynamics F at the top of the file, at the state `s`
// with the interval's mean specific force f_b and rate w_b): Phi = I + F dt + (F dt)^2 / 2.
Eigen::MatrixXd error_state_transition(const EarthModel& earth, const NavState& s,
                                       const Eigen::Vector3d& f_b, const Eigen::Vector3d& w_b,
                                       double dt, int N, bool scale) {
  using Mat = Eigen::MatrixXd;
  const Eigen::Matrix3d C = s.q_b_n.toRotationMatrix();
  const Eigen::Vector3d f_n = C * f_b;
  const double lat = s.lat_rad, h = s.h_m;
  const double RM = earth.meridian_radius_m(lat) + h, RN = earth.prime_vertical_radius_m(lat) + h;
  const Eigen::Vector3d w_ie = earth.omega_ie_n(lat);
  const Eigen::Vector3d w_en = earth.omega_en_n(lat, h, s.v_eb_n);
  const double g = earth.normal_gravity_mps2(lat, h);
  Mat F = Mat::Zero(N, N);
  F.block<3, 3>(kR, kV).setIdentity();
  F.block<3, 3>(kV, kPhi) = skew(f_n);
  F.block<3, 3>(kV, kV) = -skew(2.0 * w_ie + w_en);
  F(kV + 2, kR + 2) = 2.0 * g / std::sqrt(RM * RN);
  F.block<3, 3>(kV, kBa) = C;
  F.block<3, 3>(kPhi, kPhi) = -skew(w_ie + w_en);
  Eigen::Matrix3d dwen_dv = Eigen::Matrix3d::Zero();
  dwen_dv(0, 1) = -1.0 / RM;
  dwen_dv(1, 0) = 1.0 / RN;
  dwen_dv(2, 0) = std::tan(lat) / RN;
  F.block<3, 3>(kPhi, kV) = dwen_dv;
  F.block<3, 3>(kPhi, kBg) = -C;
  if (scale) {
    F.block<3, 3>(kPhi, kSg) = -C * w_b.asDiagonal();
    F.block<3, 3>(kV, kSa) = C * f_b.asDiagonal();
  }
  const Mat Fdt = F * dt;
  return Mat::Identity(N, N) + Fdt + 0.5 * Fdt * Fdt;
}

// The RTS backward pass over the filter's updates (closed-loop form, see the top of the file): the
// smoothed error state at the first record and its covariance.
struct Smoothed {
  Eigen::VectorXd e;
  Eigen::MatrixXd P;
};

Smoothed rts_smooth(const std::vector<UpdateRecord>& records, int N) {
  using Mat = Eigen::MatrixXd;
  using Vec = Eigen::VectorXd;
  const std::size_t last = records.size() - 1;
  Smoothed out{Vec::Zero(N), records[last].P_post};
  Vec& e = out.e;
  Mat& P_smooth = out.P;
  for (std::size_t k = last; k-- > 0;) {
    const UpdateRecord& rec = records[k];
    const UpdateRecord& next = records[k + 1];
    // A = P_k Phi^T P_prior^-1  <=>  P_prior A^T = Phi P_k.
    const Mat A = rec.P_prior_next.ldlt().solve(rec.Phi_next * rec.P_post).transpose();
    e = A * (e + next.dx);
    P_smooth = rec.P_post + A * (P_smooth - rec.P_prior_next) * A.transpose();
  }
  return out;
}

EkfRtsResult ekf_pass(const NavigationProblem& navigation, const EkfRtsParams& params,
                      const SensorErrors& base, const EkfRtsGradeSetup* setup,
                      const Eigen::Matrix<double, 6, 1>* bias_prior_sd = nullptr) {
  const auto t_start = std::chrono::steady_clock::now();
  const Dataset& ds = navigation.dataset();
  const EarthModel& earth = ds.meta.earth;
  const bool scale = params.scale_factors == 1;
  const int N = scale ? 21 : 15;
  const int n_sensor = scale ? 12 : 6;
  using Mat = Eigen::MatrixXd;
  using Vec = Eigen::VectorXd;

  std::string noise_source;
  const NoiseLevels noise = ekf_noise_levels(ds, params, setup, &noise_source);
  const double q_arw = std::pow(noise.arw_deg_rth * kPi / 180.0 / 60.0, 2);  // rad^2/s
  const double q_vrw = std::pow(noise.vrw_mps_rth / 60.0, 2);                // (m/s)^2/s

  // Sensor-error estimates (start: the base values), as SensorErrors for compensation.
  SensorErrors est = base;
  auto sensor_vector = [&]() {
    Vec s(n_sensor);
    s.segment<3>(0) = est.gyro.bias;
    s.segment<3>(3) = est.accel.bias;
    if (scale) {
      s.segment<3>(6) = est.gyro.scale;
      s.segment<3>(9) = est.accel.scale;
    }
    return s;
  };

  // Initial state and covariance.
  std::optional<AttitudeErrorModel> attitude_model;
  if (setup) attitude_model = attitude_error_model(navigation, base, setup->grade, noise);
  const Eigen::Matrix3d C0 =
      attitude_model ? attitude_model->C_b_n : navigation.initial_attitude(SensorErrors{});
  NavState state = navigation.initial_state(C0);
  const std::size_t k0 = navigation.nav_begin();
  Mat P = initial_covariance(N, scale, params, noise, earth, state.lat_rad, attitude_model, setup,
                             bias_prior_sd);
  std::vector<UpdateRecord> records;
  records.push_back({P, Mat::Identity(N, N), Mat(), Vec::Zero(N), sensor_vector()});
  Mat Phi_interval = Mat::Identity(N, N);

  // Strapdown from the navigation start; the increment ending there seeds coning/sculling.
  auto compensated = [&](std::size_t k, const ImuCompensator& comp) {
    ImuSample inc = ds.imu[k];
    const double t_before = k >= 1 ? ds.imu[k - 1].t_s : inc.t_s - 1.0 / ds.meta.imu_rate_hz;
    comp.compensate(inc.t_s, inc.t_s - t_before, inc.dtheta_b_rad, inc.dv_b_mps,
                    navigation.motor_on(k));
    return inc;
  };
  auto compensator = std::make_unique<ImuCompensator>(est);
  auto ins = std::make_unique<Strapdown>(earth, state, compensated(k0 - 1, *compensator));

  Eigen::Vector3d sum_dv = Eigen::Vector3d::Zero(), sum_dtheta = Eigen::Vector3d::Zero();
  double sum_dt = 0.0;
  double t_next_update = state.t_s + params.update_interval_s;
  const double t_gnss_end = ds.gnss.back().t_s;
  int updates = 0;
  double nis_sum = 0.0;  // sum of z^T S^-1 z over the updates (EkfRtsResult::nis_per_dof)
  int nis_dof = 0;

  auto propagate = [&](const NavState& s) {
    if (sum_dt <= 0.0) return;
    const Eigen::Vector3d f_b = sum_dv / sum_dt, w_b = sum_dtheta / sum_dt;
    const Mat Phi = error_state_transition(earth, s, f_b, w_b, sum_dt, N, scale);
    P = Phi * P * Phi.transpose();
    for (int i = 0; i < 3; ++i) {
      P(kV + i, kV + i) += q_vrw * sum_dt;
      P(kPhi + i, kPhi + i) += q_arw * sum_dt;
    }
    Phi_interval = Phi * Phi_interval;
    sum_dv.setZero();
    sum_dtheta.setZero();
    sum_dt = 0.0;
  };

  const int n_meas = params.use_position == 1 ? 6 : 3;
  double t_prop = state.t_s;
  for (std::size_t k = k0; k < ds.imu.size(); ++k) {
    const ImuSample inc = compensated(k, *compensator);
    const double dt = inc.t_s - ins->state().t_s;
    ins->step(inc);
    sum_dv += inc.dv_b_mps;
    sum_dtheta += inc.dtheta_b_rad;
    sum_dt += dt;
    const NavState& s = ins->state();
    const bool update_due = s.t_s >= t_next_update - 1e-9 && s.t_s <= t_gnss_end + 1e-9;
    if (s.t_s - t_prop >= params.propagation_interval_s - 1e-9 || update_due) {
      propagate(s);
      t_prop = s.t_s;
    }
    if (!update_due) continue;
    t_next_update += params.update_interval_s;

    // Measurement: INS minus GNSS (interpolated to the IMU epoch).
    const GnssSample g = interpolate_gnss(ds.gnss, s.t_s);
    const double RM = earth.meridian_radius_m(s.lat_rad) + s.h_m;
    const double RN = earth.prime_vertical_radius_m(s.lat_rad) + s.h_m;
    Vec z(n_meas);
    Mat H = Mat::Zero(n_meas, N);
    Vec r_diag(n_meas);
    int row = 0;
    if (n_meas == 6) {
      z[0] = (s.lon_rad - g.lon_rad) * RN * std::cos(s.lat_rad);
      z[1] = (s.lat_rad - g.lat_rad) * RM;
      z[2] = s.h_m - g.h_m;
      H.block<3, 3>(0, kR).setIdentity();
      r_diag.head<3>().setConstant(noise.gnss_pos_sigma_m * noise.gnss_pos_sigma_m);
      row = 3;
    }
    z.segment<3>(row) = s.v_eb_n - g.v_eb_n_mps;
    H.block<3, 3>(row, kV).setIdentity();
    r_diag.segment<3>(row).setConstant(noise.gnss_vel_sigma_mps * noise.gnss_vel_sigma_mps);

    records.back().Phi_next = Phi_interval;
    records.back().P_prior_next = P;
    const Mat R = r_diag.asDiagonal();
    const Mat S = H * P * H.transpose() + R;
    const Eigen::LDLT<Mat> S_ldlt(S);
    // Closed loop: the error state is zero after every feedback, so the predicted measurement is
    // zero and z itself is the innovation; z^T S^-1 z is chi-square(n_meas) for a right model.
    nis_sum += z.dot(S_ldlt.solve(z));
    nis_dof += n_meas;
    const Mat K = P * H.transpose() * S_ldlt.solve(Mat::Identity(n_meas, n_meas));
    const Vec dx = K * z;
    const Mat IKH = Mat::Identity(N, N) - K * H;
    P = IKH * P * IKH.transpose() + K * R * K.transpose();
    P = 0.5 * (P + P.transpose());
    ++updates;

    // Feedback.
    NavState c = s;
    c.lat_rad -= dx[kR + 1] / RM;
    c.lon_rad -= dx[kR + 0] / (RN * std::cos(s.lat_rad));
    c.h_m -= dx[kR + 2];
    c.v_eb_n -= dx.segment<3>(kV);
    c.q_b_n = (quat_from_rotation_vector(dx.segment<3>(kPhi)) * s.q_b_n).normalized();
    est.gyro.bias += dx.segment<3>(kBg);
    est.accel.bias += dx.segment<3>(kBa);
    if (scale) {
      est.gyro.scale += dx.segment<3>(kSg);
      est.accel.scale += dx.segment<3>(kSa);
    }
    compensator = std::make_unique<ImuCompensator>(est);
    ins = std::make_unique<Strapdown>(earth, c, compensated(k, *compensator));
    records.push_back({P, Mat::Identity(N, N), Mat(), dx, sensor_vector()});
    Phi_interval.setIdentity();
  }
  if (updates == 0) throw std::invalid_argument("ekf-rts: no GNSS update after the alignment");
  const auto t_filter = std::chrono::steady_clock::now();

  // RTS backward pass (closed-loop form, see the top of the file).
  const std::size_t last = records.size() - 1;
  const Smoothed smoothed = rts_smooth(records, N);
  const Vec& e = smoothed.e;
  const Mat& P_smooth = smoothed.P;
  const auto t_end = std::chrono::steady_clock::now();

  EkfRtsResult out;
  const std::vector<std::string> names = sensor_names(scale);
  const Vec s0 = records[0].sensor_est + e.segment(kBg, n_sensor);
  const Vec sN = records[last].sensor_est;
  for (int i = 0; i < n_sensor; ++i) {
    const std::string& name = names[static_cast<std::size_t>(i)];
    out.estimate[name] = s0[i];
    out.std[name] = std::sqrt(std::max(P_smooth(kBg + i, kBg + i), 0.0));
    out.filtered_estimate[name] = sN[i];
    out.filtered_std[name] = std::sqrt(std::max(records[last].P_post(kBg + i, kBg + i), 0.0));
  }
  out.noise_used = noise;
  out.noise_source = noise_source;
  out.updates = updates;
  out.nis_per_dof = nis_sum / static_cast<double>(nis_dof);
  out.nis_dof = nis_dof;
  out.states = N;
  if (attitude_model) {
    out.setup = *setup;
    out.initial_tilt_sd_rad = attitude_model->tilt_sd_rad;
    out.initial_heading_sd_rad = attitude_model->heading_sd_rad;
  }
  out.filter_wall_s = std::chrono::duration<double>(t_filter - t_start).count();
  out.smoother_wall_s = std::chrono::duration<double>(t_end - t_filter).count();
  return out;
}

}  // namespace

std::optional<EkfRtsGradeSetup> ekf_grade_setup(const NavigationProblem& navigation,
                                                const SensorGrade& grade) {
  if (grade.name == "nav" &&
      navigation.options().initial_attitude.mode == InitialAttitudeMode::kGyrocompass)
    return std::nullopt;
  return EkfRtsGradeSetup{grade, 2, 30.0};
}

EkfRtsResult run_ekf_rts(const NavigationProblem& navigation, const EkfRtsParams& params,
                         const SensorErrors& base, const std::optional<EkfRtsGradeSetup>& setup) {
  if (std::string error = params.validate(); !error.empty()) throw std::invalid_argument(error);
  if (!setup) return ekf_pass(navigation, params, base, nullptr);
  if (setup->passes < 1)
    throw std::invalid_argument("ekf-rts: passes must be >= 1, got " +
                                std::to_string(setup->passes));
  if (!(setup->relinearisation_prior_factor >= 3.0) ||
      !std::isfinite(setup->relinearisation_prior_factor))
    throw std::invalid_argument(
        "ekf-rts: relinearisation_prior_factor must be finite and >= 3, got " +
        std::to_string(setup->relinearisation_prior_factor));
  SensorErrors b = base;
  EkfRtsResult out;
  double filter_s = 0.0, smoother_s = 0.0;
  for (int pass = 0; pass < setup->passes; ++pass) {
    // Passes after the first: the bias prior centred on the previous pass's estimate, its sd
    // the previous posterior sd times relinearisation_prior_factor (never wider than the
    // grade's prior).
    Eigen::Matrix<double, 6, 1> prior_sd;
    if (pass > 0) {
      const std::vector<std::string> names = sensor_names(false);
      for (int i = 0; i < 6; ++i)
        prior_sd[i] =
            setup->relinearisation_prior_factor * out.std.at(names[static_cast<std::size_t>(i)]);
    }
    out = ekf_pass(navigation, params, b, &*setup, pass > 0 ? &prior_sd : nullptr);
    filter_s += out.filter_wall_s;
    smoother_s += out.smoother_wall_s;
    for (const auto& [name, value] : out.estimate) set_effect(b, name, value);
  }
  out.filter_wall_s = filter_s;
  out.smoother_wall_s = smoother_s;
  return out;
}

// ---------------------------------------------------------------------------------------------
namespace {
opt::RunConfig one_iteration(opt::RunConfig config) {
  config.max_iterations = 1;
  return config;
}
}  // namespace

EkfRtsOptimizer::EkfRtsOptimizer(const opt::Bounds& bounds, const opt::RunConfig& config,
                                 const EkfRtsParams& params)
    : opt::Optimizer("EKF-RTS", bounds, one_iteration(config)), params_(params) {
  if (std::string error = params_.validate(); !error.empty()) throw std::invalid_argument(error);
}

opt::ParameterList EkfRtsOptimizer::parameters() const {
  opt::ParameterList list = params_.list();
  if (done()) {
    list.emplace_back("equivalent_ins_runs", equivalent_ins_runs_);
    if (ekf_)
      list.emplace_back("filter_smoother_wall_s", ekf_->filter_wall_s + ekf_->smoother_wall_s);
    for (std::size_t k = 0; k < names_.size(); ++k)
      list.emplace_back("std_sigma_" + names_[k], std_sigma_[static_cast<Eigen::Index>(k)]);
  }
  return list;
}

void EkfRtsOptimizer::bind(const opt::Problem& problem) {
  if (bound_ == &problem) return;
  if (bound_ != nullptr) throw std::logic_error("EKF-RTS: bound to a second problem");
  start_clock();  // the filter and smoother pass below is this run's main work
  const auto* ins = dynamic_cast<const InsIdentificationProblem*>(&problem);
  // A campaign's search problem (identification/search_fitness.h): the filter reads the exact one.
  if (const auto* search = dynamic_cast<const SearchProblem*>(&problem)) ins = &search->exact();
  if (ins == nullptr)
    throw std::invalid_argument("ekf-rts runs on the INS identification problem only, not on '" +
                                problem.name() + "'");
  const ParameterMapping& mapping = ins->mapping();
  EkfRtsParams p = params_;
  bool needs_scale = false;
  for (const EstimatedParameter& e : mapping.parameters())
    if (e.name.find("_scale_") != std::string::npos) needs_scale = true;
  if (needs_scale) p.scale_factors = 1;
  const SensorGrade& grade = grade_ ? *grade_ : grade_for(ins->navigation().dataset());
  ekf_ =
      run_ekf_rts(ins->navigation(), p, mapping.base(), ekf_grade_setup(ins->navigation(), grade));
  const int n = mapping.dimension();
  estimate_sigma_.resize(n);
  std_sigma_.resize(n);
  names_.clear();
  for (int k = 0; k < n; ++k) {
    const EstimatedParameter& e = mapping.parameters()[static_cast<std::size_t>(k)];
    const auto it = ekf_->estimate.find(e.name);
    if (it == ekf_->estimate.end())
      throw std::invalid_argument("ekf-rts estimates gyro/accel biases (and scale factors), not '" +
                                  e.name + "'");
    estimate_sigma_[k] = it->second / e.sigma;
    std_sigma_[k] = ekf_->std.at(e.name) / e.sigma;
    names_.push_back(e.name);
  }
  x_ = clamp(mapping.from_sigma(estimate_sigma_));
  // The cost yardstick: one full INS run of the estimate with the scalar reference on this
  // thread. Unlike the evaluation the optimizer later asks for (a batch that a campaign may share
  // with other members, on however many threads it has), it does not depend on the thread count
  // or on what runs beside it, so equivalent_ins_runs compares like with like.
  const auto t0 = std::chrono::steady_clock::now();
  (void)ins->navigation().fitness(mapping.to_errors(x_));
  const double ins_run_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double ekf_s = ekf_->filter_wall_s + ekf_->smoother_wall_s;
  equivalent_ins_runs_ = ins_run_s > 0.0 ? ekf_s / ins_run_s : 0.0;
  bound_ = &problem;
}

void EkfRtsOptimizer::propose(std::vector<Eigen::VectorXd>& batch) {
  if (bound_ == nullptr)
    throw std::logic_error(
        "EKF-RTS: not bound to a problem; drive it with opt::step / run / "
        "optimize");
  batch.push_back(x_);
}

void EkfRtsOptimizer::accept(std::span<const Eigen::VectorXd>, std::span<const double>) {}

nlohmann::json EkfRtsOptimizer::report_json(const ParameterMapping& mapping) const {
  nlohmann::json j = ekf_ ? ekf_->to_json() : nlohmann::json::object();
  for (int k = 0; k < mapping.dimension() && k < std_sigma_.size(); ++k)
    j["estimate_std_sigma"][mapping.parameters()[static_cast<std::size_t>(k)].name] = std_sigma_[k];
  j["estimate_unclamped_sigma"] = nlohmann::json::object();
  for (int k = 0; k < mapping.dimension() && k < estimate_sigma_.size(); ++k)
    j["estimate_unclamped_sigma"][mapping.parameters()[static_cast<std::size_t>(k)].name] =
        estimate_sigma_[k];
  j["equivalent_ins_runs"] = equivalent_ins_runs_;
  for (const auto& [name, value] : params_.list()) j["settings"][name] = value;
  j["model"] =
      "loosely coupled error-state EKF (Groves 2013 ch. 14, psi/phi-angle, ENU), "
      "closed-loop, RTS smoother";
  return j;
}

// "ekf-rts" in the optimizer registry, registered when the program starts. A static library
// contributes an object file to a program only when something refers to it, so
// insid_identification's link interface names this symbol (identification/CMakeLists.txt) and
// every program that links the library has the entry without a call of its own.
extern "C" const bool insid_ekf_rts_registered = opt::register_algorithm(
    {.name = "ekf-rts",
     .make = [](std::string_view, const opt::Bounds& bounds, const opt::RunConfig& config,
                const opt::ParameterMap& overrides) -> std::unique_ptr<opt::Optimizer> {
       return std::make_unique<EkfRtsOptimizer>(bounds, config, EkfRtsParams::from_map(overrides));
     },
     .parameters = [] { return EkfRtsParams{}.info(); },
     .traits = {.family = opt::AlgorithmTraits::Family::kProblemSpecific,
                .least_squares = true,
                .needs_problem = true,
                .stochastic = false,
                .description = "loosely coupled INS/GNSS error-state EKF with RTS smoother"}});

}  // namespace insid
