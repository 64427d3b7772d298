#include "identification/uncertainty.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include <omp.h>
#include <Eigen/Cholesky>
#include <Eigen/QR>

#include "base/threads.h"
#include "data/noise_model.h"
#include "identification/ekf_rts.h"
#include "model/sensor_errors.h"
#include "model/units.h"
#include "optimizers/parameters.h"
#include "optimizers/random.h"
#include "optimizers/registry.h"

namespace insid {
namespace {

using Mat = Eigen::MatrixXd;
using Vec = Eigen::VectorXd;
using json = nlohmann::json;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kZ95 = 1.959963984540054;  // two-sided 95 % normal quantile

json num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json opt_num(const std::optional<double>& v) { return v ? num(*v) : json(nullptr); }

Vec to_vec(const std::vector<double>& r) {
  return Eigen::Map<const Vec>(r.data(), static_cast<Eigen::Index>(r.size()));
}

using opt::mix_seed;

// Normal draws for the replicas: Marsaglia's polar method on a splitmix64 stream (portable,
// deterministic in the seed; no trigonometry, so several times cheaper than Box-Muller, which
// dominated the cost of a replica).
class FastNormal {
 public:
  explicit FastNormal(std::uint64_t seed) : state_(seed) {}
  double operator()() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u = 0.0, v = 0.0, q = 0.0;
    do {
      u = 2.0 * uniform() - 1.0;
      v = 2.0 * uniform() - 1.0;
      q = u * u + v * v;
    } while (q >= 1.0 || q == 0.0);
    const double f = std::sqrt(-2.0 * std::log(q) / q);
    spare_ = v * f;
    has_spare_ = true;
    return u * f;
  }

 private:
  double uniform() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    z ^= z >> 31;
    return static_cast<double>(z >> 11) * 0x1.0p-53;
  }
  std::uint64_t state_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

// One noise replica into `out`, a buffer of the same shape as `source` reused between replicas
// (no allocation, no page faults: the fresh copy per replica of noise_replica was half
// its cost). The noise model is noise_replica's: per IMU axis and sample
// N(0, arw^2 dt) on dtheta and N(0, vrw^2 dt) on dv (dt = 1 / imu_rate_hz), per GNSS epoch and
// ENU axis N(0, sv^2) on the velocity and N(0, sp^2) on the position.
void fill_replica(const Dataset& source, const NoiseLevels& levels, std::uint64_t seed,
                  Dataset& out) {
  FastNormal normal(seed);
  const double dt = 1.0 / source.meta.imu_rate_hz;
  const double s_theta = levels.arw_deg_rth / kRadToDeg / 60.0 * std::sqrt(dt);
  const double s_v = levels.vrw_mps_rth / 60.0 * std::sqrt(dt);
  for (std::size_t i = 0; i < source.imu.size(); ++i) {
    const ImuSample& in = source.imu[i];
    ImuSample& o = out.imu[i];
    for (int a = 0; a < 3; ++a) {
      o.dtheta_b_rad[a] = in.dtheta_b_rad[a] + s_theta * normal();
      o.dv_b_mps[a] = in.dv_b_mps[a] + s_v * normal();
    }
  }
  const EarthModel& earth = source.meta.earth;
  for (std::size_t i = 0; i < source.gnss.size(); ++i) {
    const GnssSample& in = source.gnss[i];
    GnssSample& g = out.gnss[i];
    for (int a = 0; a < 3; ++a)
      g.v_eb_n_mps[a] = in.v_eb_n_mps[a] + levels.gnss_vel_sigma_mps * normal();
    const double rn = earth.meridian_radius_m(in.lat_rad) + in.h_m;
    const double re = (earth.prime_vertical_radius_m(in.lat_rad) + in.h_m) * std::cos(in.lat_rad);
    g.lat_rad = in.lat_rad + levels.gnss_pos_sigma_m * normal() / rn;
    g.lon_rad = in.lon_rad + levels.gnss_pos_sigma_m * normal() / re;
    g.h_m = in.h_m + levels.gnss_pos_sigma_m * normal();
  }
}

// Columns of J with the given indices.
Mat columns(const Mat& J, const std::vector<int>& idx) {
  Mat out(J.rows(), static_cast<Eigen::Index>(idx.size()));
  for (std::size_t k = 0; k < idx.size(); ++k)
    out.col(static_cast<Eigen::Index>(k)) = J.col(idx[k]);
  return out;
}

// Share of column j of J not explained by the other columns: |P_perp J_j|^2 / |J_j|^2.
double share_not_absorbed(const Mat& J, int j) {
  const double norm2 = J.col(j).squaredNorm();
  if (!(norm2 > 0.0)) return 0.0;
  if (J.cols() == 1) return 1.0;
  std::vector<int> others;
  for (int k = 0; k < J.cols(); ++k)
    if (k != j) others.push_back(k);
  const Mat O = columns(J, others);
  const Eigen::ColPivHouseholderQR<Mat> qr(O);
  const Vec left = J.col(j) - O * qr.solve(Vec(J.col(j)));
  return left.squaredNorm() / norm2;
}

// One (weighted) Gauss-Newton step on the columns `free`: -(J^T W J)^-1 J^T W r.
Vec gauss_newton_step(const Mat& J, const Vec& r, const Vec& w, const std::vector<int>& free) {
  Vec step = Vec::Zero(J.cols());
  if (free.empty()) return step;
  const Mat JF = columns(J, free);
  const Mat JtW = JF.transpose() * w.asDiagonal();
  const Mat A = JtW * JF;
  const Vec b = JtW * r;
  const Vec d = -Eigen::ColPivHouseholderQR<Mat>(A).solve(b);
  for (std::size_t k = 0; k < free.size(); ++k) step[free[k]] = d[static_cast<Eigen::Index>(k)];
  return step;
}

// The noise replicas' responses at one point: replica run minus the data run r0 (scalar
// reference), M = options.replicas draws, seeds mix_seed(options.seed, 7000 + k).
// Residuals of the noise replicas at the point x of `mapping`. With a gyro bias measured at
// rest (ParameterMapping::gyro_at_rest) each replica measures it again on its own window, so the
// window's noise reaches the estimates as it would on another flight.
NoiseReplicaSet run_noise_replicas(const NavigationProblem& nav, const ParameterMapping& mapping,
                                   const Eigen::VectorXd& x, const Vec& r0,
                                   const UncertaintyOptions& options) {
  const SensorErrors errors = mapping.to_errors(x);
  const auto t0 = std::chrono::steady_clock::now();
  NoiseReplicaSet set;
  const Dataset& dataset = nav.dataset();
  NoiseEstimate noise = noise_levels_for(dataset);
  if (options.noise) {
    noise.levels = *options.noise;
    noise.source = "given";
  }
  set.levels = noise.levels;
  set.source = noise.source;
  set.seed = options.seed;
  const Eigen::Index m = r0.size();
  const int M = options.replicas;
  Mat D(m, M);
  {
    std::vector<std::string> failures(static_cast<std::size_t>(M));
    const int threads = thread_count(options.threads);
    // One replica buffer per thread (the data without truth.csv, which navigation never reads;
    // the measured heading as it is, as noise_replica keeps it: --heading-source measured reads
    // it at every replica's start).
    std::vector<Dataset> buffers(static_cast<std::size_t>(threads));
    for (Dataset& b : buffers) {
      b.meta = dataset.meta;
      b.imu = dataset.imu;
      b.gnss = dataset.gnss;
      b.heading = dataset.heading;
    }
#pragma omp parallel for schedule(dynamic) num_threads(threads)
    for (int k = 0; k < M; ++k) {
      try {
        Dataset& buffer = buffers[static_cast<std::size_t>(omp_get_thread_num())];
        fill_replica(dataset, noise.levels, mix_seed(options.seed, 7000 + k), buffer);
        // Non-owning: the buffer outlives the problem, which lives in this iteration only.
        const std::shared_ptr<const Dataset> replica(std::shared_ptr<const Dataset>(), &buffer);
        const NavigationProblem rnav(replica, nav.options());
        std::vector<double> rr;
        if (mapping.gyro_at_rest())
          rnav.residuals(mapping.with_gyro_at_rest(gyro_at_rest(rnav)).to_errors(x), rr);
        else
          rnav.residuals(errors, rr);
        const Vec d = to_vec(rr) - r0;
        if (static_cast<Eigen::Index>(rr.size()) != m || !d.allFinite())
          throw std::runtime_error("its residuals are not finite");
        D.col(k) = d;
      } catch (const std::exception& e) {
        failures[static_cast<std::size_t>(k)] = e.what();
      }
    }
    for (int k = 0; k < M; ++k)
      if (!failures[static_cast<std::size_t>(k)].empty())
        throw std::runtime_error("uncertainty: noise replica " + std::to_string(k) + ": " +
                                 failures[static_cast<std::size_t>(k)]);
  }
  set.responses = std::move(D);
  set.evaluations = M;
  set.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return set;
}

// The factor on the EKF-RTS's smoothed sd: the filter's own Birge ratio, sqrt(max(1, NIS/dof)),
// with NIS/dof = sum_k z_k^T S_k^-1 z_k / sum_k dim(z_k) over its GNSS updates (EkfRtsResult::
// nis_per_dof). A filter whose every noise (process and measurement) is k times too small
// has innovations k times its predicted S^(1/2), so NIS/dof ~ k^2, and its smoothed covariance
// is k^2 too small with an unchanged gain (Bar-Shalom, Li & Kirubarajan 2001, "Estimation with
// Applications to Tracking and Navigation", sec. 5.4 on the NIS as the filter's consistency
// test; the PDG's scale factor S = sqrt(chi^2 / dof), applied only when S > 1, Particle Data
// Group, "Review of Particle Physics", Introduction, "Averages and fits"). The filter's own ratio,
// not the fitness's (UncertaintyReport::sd_scale): that one measures the windowed velocity fit
// against replicas of the static window's noise, a model the filter does not share (on the shared
// ArduPilot log 15-47 where the filter, told the flight's noise, sees 46-103 in NIS, i.e. 7-10 in
// sd). Why not the Gauss-Newton sd instead, or as a floor always: on simulated drone flights
// the filter is 2-3x more precise than the least-squares fit (it uses the GNSS positions and
// re-estimates the attitude), and the floor made its intervals cover 180 of 180 truths with
// |error|/sd RMS 0.42: honest but 2.4x too wide (results/uncertainty/README.md).
double filter_sd_scale(double nis_per_dof) { return std::sqrt(std::max(nis_per_dof, 1.0)); }

// A not_converged estimate (step 6 below): the sd describes the spread of the optimum, and the
// estimate lies one Gauss-Newton step from that optimum, so its error is (estimate - optimum) +
// (optimum - truth), and with the step taken as that first term,
//   sd_reported = sqrt(sd^2 + step^2)
// (the two terms independent: the step comes from the search, the spread from the noise). The
// interval then covers the optimum as well as the noise around it. not_observable and the
// step in sd units (the flag's own measure) stay with the sd before the step.
void widen_by_step(ParameterUncertainty& p) {
  if (!p.sd_si) return;
  p.sd_without_step_si = p.sd_si;
  p.sd_si = std::hypot(*p.sd_si, p.step_to_optimum_sigma * p.sigma_si);
}

}  // namespace

NoiseReplicaSet noise_replica_set(const InsIdentificationProblem& problem,
                                  const Eigen::VectorXd& at_sigma,
                                  const UncertaintyOptions& options) {
  if (const std::string error = options.validate(); !error.empty())
    throw std::invalid_argument(error);
  const ParameterMapping& mapping = problem.mapping();
  if (at_sigma.size() != mapping.dimension())
    throw std::invalid_argument("noise_replica_set: point has " + std::to_string(at_sigma.size()) +
                                " values, the problem " + std::to_string(mapping.dimension()) +
                                " parameters");
  const NavigationProblem& nav = problem.navigation();
  const SensorErrors errors = mapping.to_errors(mapping.from_sigma(at_sigma));
  std::vector<double> r_scalar;
  nav.residuals(errors, r_scalar);
  NoiseReplicaSet set =
      run_noise_replicas(nav, mapping, mapping.from_sigma(at_sigma), to_vec(r_scalar), options);
  set.at_sigma = at_sigma;
  ++set.evaluations;
  return set;
}

MisfitRatio misfit_ratio(const Mat& J, const Vec& r, const Mat& D, double min_ratio) {
  MisfitRatio out;
  const Eigen::ColPivHouseholderQR<Mat> qr(J);
  const double data_sq = (r - J * qr.solve(r)).squaredNorm();
  const Mat D_unabsorbed = D - J * qr.solve(D);
  double noise_sq_mean = 0.0, noise_sq_max = 0.0;
  for (Eigen::Index k = 0; k < D.cols(); ++k) {
    const double e = D_unabsorbed.col(k).squaredNorm();
    noise_sq_mean += e / static_cast<double>(D.cols());
    noise_sq_max = std::max(noise_sq_max, e);
  }
  if (!(noise_sq_mean > 0.0)) return out;
  const double ratio = data_sq / noise_sq_mean;
  out.residual_vs_noise_rms = std::sqrt(ratio);
  out.residual_above_every_replica = data_sq > noise_sq_max;
  if (out.residual_above_every_replica && ratio > min_ratio) {
    out.sd_scale = std::sqrt(ratio);
    out.covariance_scale = ratio;
  }
  return out;
}

UncertaintyCriterion criterion_for_algorithm(const std::string& algorithm) {
  return opt::algorithm_traits(algorithm).least_squares ? UncertaintyCriterion::kLeastSquares
                                                        : UncertaintyCriterion::kEq15;
}

std::string UncertaintyOptions::validate() const {
  const auto real = [](const char* field, double value, double lo, double hi) {
    if (std::isfinite(value) && value >= lo && value <= hi) return std::string();
    return std::string("UncertaintyOptions.") + field + " = " + opt::format_number(value) +
           ": must be a finite number in [" + opt::format_number(lo) + ", " +
           opt::format_number(hi) + "]";
  };
  if (replicas < 10 || replicas > 100000)
    return "UncertaintyOptions.replicas = " + std::to_string(replicas) +
           ": must be a whole number in [10, 100000]";
  if (threads < 0 || threads > 4096)
    return "UncertaintyOptions.threads = " + std::to_string(threads) +
           ": must be a whole number in [0, 4096]";
  for (const std::string& error :
       {real("jacobian_step_sigma", jacobian_step_sigma, 1e-6, 1.0),
        real("not_observable_box_fraction", not_observable_box_fraction, 1e-6, 1e6),
        real("absorbed_share", absorbed_share, 0.0, 1.0),
        real("correlated_threshold", correlated_threshold, 0.0, 1.0),
        real("not_converged_sd", not_converged_sd, 1e-9, 1e9),
        real("box_edge_tolerance", box_edge_tolerance, 0.0, 0.5),
        real("misfit_min_ratio", misfit_min_ratio, 1.0, 1e12)})
    if (!error.empty()) return error;
  if (noise) {
    const NoiseLevels& l = *noise;
    for (const std::string& error :
         {real("noise.arw_deg_rth", l.arw_deg_rth, 0.0, 1e6),
          real("noise.vrw_mps_rth", l.vrw_mps_rth, 0.0, 1e6),
          real("noise.gnss_vel_sigma_mps", l.gnss_vel_sigma_mps, 0.0, 1e6),
          real("noise.gnss_pos_sigma_m", l.gnss_pos_sigma_m, 0.0, 1e6)})
      if (!error.empty()) return error;
  }
  return "";
}

std::pair<std::string, double> engineering_unit(const std::string& si_unit) {
  if (si_unit == "rad/s") return {"deg/h", kRadToDeg * 3600.0};
  if (si_unit == "m/s^2") return {"ug", 1.0 / kMicroG_mps2};
  if (si_unit == "1") return {"ppm", 1e6};
  if (si_unit == "rad") return {"arcsec", kRadToDeg * 3600.0};
  if (si_unit == "m/s^3") return {"ug/h", 3600.0 / kMicroG_mps2};
  if (si_unit == "rad/s^2") return {"deg/h^2", kRadToDeg * 3600.0 * 3600.0};
  if (si_unit == "s") return {"ms", 1e3};
  return {si_unit, 1.0};
}

UncertaintyReport estimate_uncertainty(const InsIdentificationProblem& problem,
                                       const Eigen::VectorXd& value_sigma,
                                       const UncertaintyOptions& options,
                                       const NoiseReplicaSet* shared) {
  if (const std::string error = options.validate(); !error.empty())
    throw std::invalid_argument(error);
  const auto t0 = std::chrono::steady_clock::now();
  const ParameterMapping& mapping = problem.mapping();
  const int n = mapping.dimension();
  if (value_sigma.size() != n)
    throw std::invalid_argument("estimate_uncertainty: estimate has " +
                                std::to_string(value_sigma.size()) + " values, the problem " +
                                std::to_string(n) + " parameters");
  UncertaintyReport report;
  report.options = options;
  report.criterion = options.criterion;
  report.replicas = options.replicas;
  report.jacobian_step_sigma = options.jacobian_step_sigma;

  // 1. Residuals at the estimate and the central-difference Jacobian, one batch of 2n + 1
  //    candidates through the problem (the batched kernel when it covers the data).
  const double h = options.jacobian_step_sigma;
  std::vector<Eigen::VectorXd> xs(static_cast<std::size_t>(2 * n + 1));
  xs[0] = mapping.from_sigma(value_sigma);
  for (int j = 0; j < n; ++j) {
    Vec plus = value_sigma, minus = value_sigma;
    plus[j] += h;
    minus[j] -= h;
    xs[static_cast<std::size_t>(1 + 2 * j)] = mapping.from_sigma(plus);
    xs[static_cast<std::size_t>(2 + 2 * j)] = mapping.from_sigma(minus);
  }
  std::vector<std::vector<double>> rs(xs.size());
  std::vector<double> fs(xs.size());
  problem.evaluate_residual_batch(xs, rs, fs);
  report.evaluations += static_cast<std::int64_t>(xs.size());
  const Vec r = to_vec(rs[0]);
  const Eigen::Index m = r.size();
  if (m < n) throw std::runtime_error("estimate_uncertainty: fewer residuals than parameters");
  Mat J(m, n);  // d r / d value_sigma (m/s per sigma)
  for (int j = 0; j < n; ++j)
    J.col(j) = (to_vec(rs[static_cast<std::size_t>(1 + 2 * j)]) -
                to_vec(rs[static_cast<std::size_t>(2 + 2 * j)])) /
               (2.0 * h);

  report.jacobian_sigma = J;
  report.residuals = r;

  // 2. Noise replicas through the same pipeline at the estimate (data/noise_model.h), or
  //    the caller's set run once for the data (`shared`, e.g. once per campaign scenario at the
  //    data's optimum): the noise response depends on the data and the noise model, and only
  //    weakly on the point it is run at.
  const NavigationProblem& nav = problem.navigation();
  const SensorErrors errors = mapping.to_errors(xs[0]);
  std::vector<double> r_scalar;
  nav.residuals(errors, r_scalar);  // the replicas run the scalar reference: compare like with like
  ++report.evaluations;
  const Vec r0 = to_vec(r_scalar);
  NoiseReplicaSet own;
  if (!shared) {
    own = run_noise_replicas(nav, mapping, xs[0], r0, options);
    report.evaluations += own.evaluations;
  } else {
    if (shared->responses.rows() != m || shared->responses.cols() < 2)
      throw std::invalid_argument("estimate_uncertainty: shared noise replicas have " +
                                  std::to_string(shared->responses.rows()) + " residuals x " +
                                  std::to_string(shared->responses.cols()) +
                                  " replicas, the problem " + std::to_string(m) +
                                  " residuals (and >= 2 replicas are needed)");
    report.replicas_shared = true;
    report.replicas_at_sigma = shared->at_sigma;
  }
  const NoiseReplicaSet& set = shared ? *shared : own;
  report.noise_levels = set.levels;
  report.noise_source = set.source;
  report.replicas = static_cast<int>(set.responses.cols());
  const int M = report.replicas;
  const Mat& D = set.responses;

  // 3. Which columns carry information of their own.
  report.parameters.resize(static_cast<std::size_t>(n));
  std::vector<int> computable;
  for (int j = 0; j < n; ++j) {
    ParameterUncertainty& p = report.parameters[static_cast<std::size_t>(j)];
    const EstimatedParameter& e = mapping.parameters()[static_cast<std::size_t>(j)];
    p.name = e.name;
    p.sigma_si = e.sigma;
    p.estimate_si = value_sigma[j] * e.sigma;
    p.unit = std::string(effect_info(e.name).unit);
    std::tie(p.unit_eng, p.eng_per_si) = engineering_unit(p.unit);
    p.share_not_absorbed = share_not_absorbed(J, j);
    if (!(J.col(j).squaredNorm() > 0.0))
      p.sd_reason = "the residuals do not depend on it on this flight (zero Jacobian column)";
    else if (!(p.share_not_absorbed > 1e-10))
      p.sd_reason = "its Jacobian column is a combination of the others (share not absorbed " +
                    opt::format_number(p.share_not_absorbed) + ")";
    else
      computable.push_back(j);
  }

  // 4. Covariance: least-squares response to every replica, dtheta = -(J^T J)^-1 J^T d.
  report.covariance_sigma = Mat::Constant(n, n, kNaN);
  report.correlation = Mat::Constant(n, n, kNaN);
  Vec sd_sigma = Vec::Constant(n, kNaN);
  if (!computable.empty()) {
    const Mat JF = columns(J, computable);
    const Eigen::ColPivHouseholderQR<Mat> qr(JF);
    const Mat theta = -qr.solve(D);  // |F| x M
    const Mat cov = theta * theta.transpose() / static_cast<double>(M);
    for (std::size_t a = 0; a < computable.size(); ++a)
      for (std::size_t b = 0; b < computable.size(); ++b)
        report.covariance_sigma(computable[a], computable[b]) =
            cov(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b));
    // 4b. Model misfit (misfit_ratio, a Birge ratio): when the data's unabsorbed residual
    //     exceeds every replica's (p < 1/(M+1)) and the ratio exceeds misfit_min_ratio, the
    //     covariance is scaled by the ratio (sd by its square root) and the result says so.
    const MisfitRatio misfit = misfit_ratio(JF, r0, D, options.misfit_min_ratio);
    report.residual_vs_noise_rms = misfit.residual_vs_noise_rms;
    report.residual_above_every_replica = misfit.residual_above_every_replica;
    report.sd_scale = misfit.sd_scale;
    if (misfit.sd_scale > 1.0) report.covariance_sigma *= misfit.covariance_scale;
    for (int j : computable) sd_sigma[j] = std::sqrt(report.covariance_sigma(j, j));
    for (int a : computable)
      for (int b : computable)
        report.correlation(a, b) = report.covariance_sigma(a, b) / (sd_sigma[a] * sd_sigma[b]);
  }

  // 5. Distance to the optimum of the algorithm's criterion: one Gauss-Newton step (an IRLS /
  //    Weiszfeld step for Eq. 15, weights 1/|r_t|), parameters at a box edge that the step
  //    pushes outward held there (the box-constrained optimum is what the algorithm sought).
  Vec w = Vec::Ones(m);
  if (options.criterion == UncertaintyCriterion::kEq15) {
    double mean = 0.0;
    for (Eigen::Index e = 0; e + 1 < m; e += 2) mean += std::hypot(r[e], r[e + 1]);
    mean /= static_cast<double>(std::max<Eigen::Index>(m / 2, 1));
    const double floor = std::max(1e-6 * mean, 1e-12);
    for (Eigen::Index e = 0; e + 1 < m; e += 2)
      w[e] = w[e + 1] = 1.0 / std::max(std::hypot(r[e], r[e + 1]), floor);
  }
  std::vector<bool> at_edge_low(static_cast<std::size_t>(n)),
      at_edge_high(static_cast<std::size_t>(n));
  for (int j = 0; j < n; ++j) {
    const EstimatedParameter& e = mapping.parameters()[static_cast<std::size_t>(j)];
    const double tol = options.box_edge_tolerance * (e.upper_sigma - e.lower_sigma);
    at_edge_low[static_cast<std::size_t>(j)] = value_sigma[j] <= e.lower_sigma + tol;
    at_edge_high[static_cast<std::size_t>(j)] = value_sigma[j] >= e.upper_sigma - tol;
  }
  Vec step = gauss_newton_step(J, r, w, computable);
  for (int pass = 0; pass < n; ++pass) {
    std::vector<int> free;
    bool changed = false;
    for (int j : computable) {
      const bool pushed_out = (at_edge_low[static_cast<std::size_t>(j)] && step[j] < 0.0) ||
                              (at_edge_high[static_cast<std::size_t>(j)] && step[j] > 0.0);
      if (pushed_out) {
        changed = changed || step[j] != 0.0;
        continue;
      }
      free.push_back(j);
    }
    if (!changed) break;
    step = gauss_newton_step(J, r, w, free);
  }

  // 6. Flags.
  for (int j = 0; j < n; ++j) {
    ParameterUncertainty& p = report.parameters[static_cast<std::size_t>(j)];
    const EstimatedParameter& e = mapping.parameters()[static_cast<std::size_t>(j)];
    p.step_to_optimum_sigma = step[j];
    p.box_width_sigma = e.upper_sigma - e.lower_sigma;
    if (std::isfinite(sd_sigma[j]) && sd_sigma[j] > 0.0) {
      p.sd_si = sd_sigma[j] * e.sigma;
      p.step_to_optimum_sd = std::abs(step[j]) / sd_sigma[j];
    } else if (p.sd_reason.empty() && std::isfinite(sd_sigma[j])) {
      p.sd_reason = "the noise replicas do not move it (zero sd: noise-free data?)";
    }
    if (at_edge_low[static_cast<std::size_t>(j)] || at_edge_high[static_cast<std::size_t>(j)])
      p.flags.push_back("at_box_edge");
    const bool too_wide =
        p.sd_si && 2.0 * kZ95 * sd_sigma[j] >
                       options.not_observable_box_fraction * (e.upper_sigma - e.lower_sigma);
    if (!p.sd_si.has_value() && p.sd_reason.rfind("the noise replicas", 0) != 0)
      p.flags.push_back("not_observable");
    else if (too_wide || p.share_not_absorbed < options.absorbed_share)
      p.flags.push_back("not_observable");
    for (int k = 0; k < n; ++k)
      if (k != j && std::isfinite(report.correlation(j, k)) &&
          std::abs(report.correlation(j, k)) > options.correlated_threshold)
        p.flags.push_back("correlated:" + mapping.parameters()[static_cast<std::size_t>(k)].name);
    if (p.step_to_optimum_sd && *p.step_to_optimum_sd > options.not_converged_sd) {
      p.flags.push_back("not_converged");
      widen_by_step(p);
    }
    if (p.step_to_optimum_sd)
      report.distance_to_optimum_sd =
          std::max(report.distance_to_optimum_sd.value_or(0.0), *p.step_to_optimum_sd);
  }
  report.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

void use_filter_sd(UncertaintyReport& report, const FilterSd& filter) {
  if (filter.sd_si.size() != report.parameters.size())
    throw std::invalid_argument("use_filter_sd: " + std::to_string(filter.sd_si.size()) +
                                " sd for " + std::to_string(report.parameters.size()) +
                                " parameters");
  if (!(filter.nis_per_dof >= 0.0) || !std::isfinite(filter.nis_per_dof) || filter.nis_dof < 1)
    throw std::invalid_argument(
        "use_filter_sd: nis_per_dof = " + opt::format_number(filter.nis_per_dof) + " over " +
        std::to_string(filter.nis_dof) +
        " degrees of freedom: must be a finite number >= 0 over >= 1");
  for (std::size_t j = 0; j < report.parameters.size(); ++j) {
    const double sd_si = filter.sd_si[j];
    if (!(sd_si > 0.0) || !std::isfinite(sd_si))
      throw std::invalid_argument("use_filter_sd: sd of " + report.parameters[j].name +
                                  " must be finite and > 0, got " + std::to_string(sd_si));
  }
  const UncertaintyOptions& options = report.options;
  report.filter_nis_per_dof = filter.nis_per_dof;
  report.filter_nis_dof = filter.nis_dof;
  report.filter_sd_scale = filter_sd_scale(filter.nis_per_dof);
  report.filter_model_rejected = filter.nis_per_dof > options.misfit_min_ratio;
  for (std::size_t j = 0; j < report.parameters.size(); ++j) {
    ParameterUncertainty& p = report.parameters[j];
    // The Gauss-Newton sd of the noise alone (estimate_uncertainty may have added the step).
    p.sd_gauss_newton_si = p.sd_without_step_si ? p.sd_without_step_si : p.sd_si;
    p.sd_without_step_si.reset();
    p.sd_filter_si = filter.sd_si[j];
    p.sd_si = filter.sd_si[j] * report.filter_sd_scale;
    p.sd_reason.clear();
    p.sd_source = report.filter_sd_scale > 1.0
                      ? "ekf-rts smoothed covariance, scaled for the filter's misfit"
                      : "ekf-rts smoothed covariance";
    // A filter whose innovations exceed misfit_min_ratio (4) times their expected chi-square has
    // a noise model a single scale cannot mend: the ratio of process to measurement noise is off
    // too, so its gain, not only its covariance, is wrong (told the MEMS grade's 0.2 deg/sqrt(h)
    // on a flight with 8, its NIS-scaled intervals covered 36 of 180 simulated truths). Its sd is
    // then never below the least-squares spread at its point (the Gauss-Newton replica sd, with
    // the fitness's own misfit scale), an estimator-free yardstick of what the data pin down:
    // 180 of 180 covered. The same threshold as the fitness's misfit scale (step 4b).
    if (report.filter_model_rejected && p.sd_gauss_newton_si && *p.sd_gauss_newton_si > *p.sd_si) {
      p.sd_si = p.sd_gauss_newton_si;
      p.sd_source = "gauss-newton replicas at the filter's point (the filter's model rejected)";
    }
    const double sd_sigma = *p.sd_si / p.sigma_si;
    std::vector<std::string> kept;
    bool not_converged = false;
    for (const std::string& f : p.flags) {
      if (f != "not_observable") kept.push_back(f);
      not_converged = not_converged || f == "not_converged";
    }
    p.flags = kept;
    const bool too_wide =
        2.0 * kZ95 * sd_sigma > options.not_observable_box_fraction * p.box_width_sigma;
    if (too_wide || p.share_not_absorbed < options.absorbed_share)
      p.flags.push_back("not_observable");
    // not_converged: the filter's point is more than the optimum's own spread away from the
    // fitness's least-squares optimum; one of the two is off by the step, so the interval
    // covers both (widen_by_step).
    if (not_converged) widen_by_step(p);
  }
}

UncertaintyReport add_run_uncertainty_json(json& out, const InsIdentificationProblem& problem,
                                           const opt::Optimizer& optimizer,
                                           const UncertaintyOptions& options,
                                           const NoiseReplicaSet* shared) {
  UncertaintyReport report = estimate_uncertainty(
      problem, problem.mapping().to_sigma(optimizer.result().best_x), options, shared);
  // The EKF-RTS reports its own smoothed sd: the Gauss-Newton sd describes the
  // least-squares optimum's spread, not the filter's estimate.
  if (const auto* ekf = dynamic_cast<const EkfRtsOptimizer*>(&optimizer)) {
    const ParameterMapping& mapping = problem.mapping();
    FilterSd filter;
    for (int k = 0; k < mapping.dimension(); ++k)
      filter.sd_si.push_back(ekf->std_sigma()[k] *
                             mapping.parameters()[static_cast<std::size_t>(k)].sigma);
    filter.nis_per_dof = ekf->ekf()->nis_per_dof;
    filter.nis_dof = ekf->ekf()->nis_dof;
    use_filter_sd(report, filter);
  }
  add_uncertainty_json(out, report);
  return report;
}

json UncertaintyReport::parameters_json() const {
  json arr = json::array();
  for (const ParameterUncertainty& p : parameters) {
    json j;
    j["name"] = p.name;
    j["estimate"] = num(p.estimate_si);
    j["sd"] = opt_num(p.sd_si);
    if (!p.sd_si) j["sd_reason"] = p.sd_reason;
    j["sd_source"] = p.sd_source;
    if (p.sd_source != "gauss-newton replicas")
      j["sd_gauss_newton"] = opt_num(p.sd_gauss_newton_si);
    if (p.sd_filter_si) j["sd_filter"] = num(*p.sd_filter_si);
    // not_converged: sd = sqrt(sd_without_step^2 + step^2) (widen_by_step).
    if (p.sd_without_step_si) j["sd_without_step"] = num(*p.sd_without_step_si);
    j["unit"] = p.unit;
    j["estimate_eng"] = num(p.estimate_si * p.eng_per_si);
    j["sd_eng"] = p.sd_si ? num(*p.sd_si * p.eng_per_si) : json(nullptr);
    j["unit_eng"] = p.unit_eng;
    j["sigma_unit"] = p.sigma_si;
    j["estimate_in_sigma_units"] = num(p.estimate_sigma_units());
    j["sd_in_sigma_units"] = p.sd_si ? num(*p.sd_si / p.sigma_si) : json(nullptr);
    j["share_not_absorbed"] = num(p.share_not_absorbed);
    j["step_to_optimum_in_sigma_units"] = num(p.step_to_optimum_sigma);
    j["step_to_optimum_sd"] = opt_num(p.step_to_optimum_sd);
    j["flags"] = p.flags;
    arr.push_back(j);
  }
  return arr;
}

json UncertaintyReport::correlation_json() const {
  json names = json::array(), matrix = json::array();
  for (const ParameterUncertainty& p : parameters) names.push_back(p.name);
  for (Eigen::Index a = 0; a < correlation.rows(); ++a) {
    json row = json::array();
    for (Eigen::Index b = 0; b < correlation.cols(); ++b) row.push_back(num(correlation(a, b)));
    matrix.push_back(row);
  }
  return {{"names", names}, {"matrix", matrix}};
}

json UncertaintyReport::method_json() const {
  json j;
  j["method"] =
      "Gauss-Newton covariance at the estimate: central-difference residual Jacobian through "
      "the batched kernel, least-squares response -(J^T J)^-1 J^T d to noise replicas d of the "
      "flight (the data's own IMU/GNSS noise levels added again, run through alignment and "
      "navigation: correlated residual noise included)";
  j["criterion"] = to_string(criterion);
  j["replicas"] = replicas;
  j["replica_seed"] = options.seed;
  j["jacobian_step_in_sigma_units"] = jacobian_step_sigma;
  j["noise_model"] = {{"arw_deg_rth", noise_levels.arw_deg_rth},
                      {"vrw_mps_rth", noise_levels.vrw_mps_rth},
                      {"gnss_vel_sigma_mps", noise_levels.gnss_vel_sigma_mps},
                      {"gnss_pos_sigma_m", noise_levels.gnss_pos_sigma_m},
                      {"source", noise_source}};
  j["residual_vs_noise_rms"] = opt_num(residual_vs_noise_rms);
  j["residual_above_every_replica"] = residual_above_every_replica;
  j["sd_scale_for_misfit"] = sd_scale;
  if (filter_nis_per_dof) {
    j["filter_nis_per_dof"] = num(*filter_nis_per_dof);
    j["filter_nis_dof"] = filter_nis_dof;
    j["filter_sd_scale"] = filter_sd_scale;
    j["filter_model_rejected"] = filter_model_rejected;
  }
  j["misfit_min_ratio"] = options.misfit_min_ratio;
  j["distance_to_optimum_sd"] = opt_num(distance_to_optimum_sd);
  j["thresholds"] = {
      {"not_observable",
       "95 % interval (2 x 1.96 sd) wider than " +
           opt::format_number(options.not_observable_box_fraction) +
           " x the search box, or share of the Jacobian column not absorbed by the others < " +
           opt::format_number(options.absorbed_share)},
      {"correlated", "|correlation| > " + opt::format_number(options.correlated_threshold)},
      {"not_converged", "one Gauss-Newton step to the optimum of the criterion > " +
                            opt::format_number(options.not_converged_sd) +
                            " sd; its sd is then sqrt(sd^2 + step^2)"},
      {"at_box_edge", "within " + opt::format_number(options.box_edge_tolerance) +
                          " of the box width from a bound"}};
  if (replicas_shared) {
    json at = json::array();
    for (Eigen::Index k = 0; k < replicas_at_sigma.size(); ++k) at.push_back(replicas_at_sigma[k]);
    j["replicas_shared"] = {
        {"at_in_sigma_units", at},
        {"note", "noise replicas run once for the data (not counted in evaluations / wall_s)"}};
  }
  j["evaluations"] = evaluations;
  j["wall_s"] = wall_s;
  return j;
}

std::string UncertaintyReport::table() const {
  std::ostringstream out;
  char line[512];
  std::snprintf(line, sizeof(line), "%-16s %12s %11s %-8s %9s %8s  %s\n", "parameter", "estimate",
                "sd", "unit", "est/sigma", "sd/sigma", "flags");
  out << line;
  for (const ParameterUncertainty& p : parameters) {
    std::string flags;
    for (const std::string& f : p.flags) {
      if (!flags.empty()) flags += ' ';
      flags += f;
    }
    if (!p.sd_si) {
      if (!flags.empty()) flags += ' ';
      flags.append("(sd: ").append(p.sd_reason).append(")");
    }
    const double est = p.estimate_si * p.eng_per_si;
    if (p.sd_si)
      std::snprintf(line, sizeof(line), "%-16s %12.5g %11.3g %-8s %9.3f %8.3f  %s\n",
                    p.name.c_str(), est, *p.sd_si * p.eng_per_si, p.unit_eng.c_str(),
                    p.estimate_sigma_units(), *p.sd_si / p.sigma_si, flags.c_str());
    else
      std::snprintf(line, sizeof(line), "%-16s %12.5g %11s %-8s %9.3f %8s  %s\n", p.name.c_str(),
                    est, "-", p.unit_eng.c_str(), p.estimate_sigma_units(), "-", flags.c_str());
    out << line;
  }
  if (distance_to_optimum_sd)
    out << "distance to the " << to_string(criterion)
        << " optimum: " << opt::format_number(std::round(*distance_to_optimum_sd * 1000.0) / 1000.0)
        << " sd (one Gauss-Newton step); sd from " << replicas << " noise replicas ("
        << noise_source << ")\n";
  if (!parameters.empty() && parameters.front().sd_source != "gauss-newton replicas")
    out << "the sd column is the " << parameters.front().sd_source
        << " (the Gauss-Newton sd: \"sd_gauss_newton\" in the JSON)\n";
  if (filter_nis_per_dof)
    out << "the filter's innovations: chi-square / dof "
        << opt::format_number(std::round(*filter_nis_per_dof * 100.0) / 100.0) << " over "
        << filter_nis_dof << " measurements: its sd scaled by "
        << opt::format_number(std::round(filter_sd_scale * 100.0) / 100.0)
        << (filter_model_rejected ? ", and never below the Gauss-Newton sd (its model rejected)"
                                  : "")
        << "\n";
  bool widened = false;
  for (const ParameterUncertainty& p : parameters) widened = widened || p.sd_without_step_si;
  if (widened)
    out << "not_converged: sd = sqrt(sd^2 + step^2), the step to the optimum added "
           "(\"sd_without_step\" in the JSON)\n";
  if (residual_vs_noise_rms && sd_scale > 1.0)
    out << "model misfit: the residual the parameters cannot absorb is "
        << opt::format_number(std::round(*residual_vs_noise_rms * 100.0) / 100.0)
        << "x the noise replicas' (above all " << replicas
        << "): every sd is scaled by that factor; the model lacks something (insid diagnose)\n";
  else if (residual_vs_noise_rms)
    out << "residual not absorbed / noise replicas': "
        << opt::format_number(std::round(*residual_vs_noise_rms * 100.0) / 100.0)
        << " (sd not scaled)\n";
  return out.str();
}

void add_uncertainty_json(nlohmann::json& out, const UncertaintyReport& report) {
  out["parameters"] = report.parameters_json();
  out["correlation"] = report.correlation_json();
  out["uncertainty"] = report.method_json();
}

}  // namespace insid
