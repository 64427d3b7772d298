// The cross-IMU check: direct gyro bias differences from the raw samples of several IMUs on one
// airframe, and insid's estimated differences held against them (cross_imu.h has the model).
#include "diagnose/cross_imu.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <Eigen/Dense>

#include "base/json_object.h"
#include "base/json_reader.h"
#include "model/sensor_errors.h"
#include "model/units.h"

namespace insid::cross_imu {
namespace {

constexpr const char* kAxis[3] = {"x", "y", "z"};

// The catalogue name of the gyro bias on body axis i (0, 1, 2: x, y, z).
std::string gyro_bias_name(int axis, EffectKind kind = EffectKind::kBias) {
  return std::string(effect_info(EffectSensor::kGyro, kind, axis).name);
}

/// Fewest blocks a segment's SE is computed from.
constexpr int kMinSegmentBlocks = 5;
/// Most segments of one window (a longer list says nothing a plot of the data would not).
constexpr double kMaxSegments = 100000.0;

std::string num(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

double median_step(const RateSeries& s) {
  std::vector<double> steps = s.dt_s;
  std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2),
                   steps.end());
  return steps[steps.size() / 2];
}

// The matched samples of a pair inside the window: indices into a and b.
struct Matched {
  std::vector<std::size_t> ia, ib;
  std::size_t in_window_a = 0, in_window_b = 0;
};

Matched match_samples(const RateSeries& a, const RateSeries& b, double t0, double t1,
                      double tol_s) {
  Matched m;
  auto inside = [&](double t) { return t >= t0 && t <= t1; };
  for (double t : a.t_s) m.in_window_a += inside(t) ? 1 : 0;
  for (double t : b.t_s) m.in_window_b += inside(t) ? 1 : 0;
  std::size_t i = 0;
  for (std::size_t k = 0; k < b.t_s.size(); ++k) {
    if (!inside(b.t_s[k])) continue;
    while (i < a.t_s.size() && a.t_s[i] < b.t_s[k] - tol_s) ++i;
    if (i == a.t_s.size()) break;
    // The same instant and the same step (the rate is a mean over the step).
    if (std::abs(a.t_s[i] - b.t_s[k]) <= tol_s && std::abs(a.dt_s[i] - b.dt_s[k]) <= tol_s &&
        inside(a.t_s[i])) {
      m.ia.push_back(i);
      m.ib.push_back(k);
    }
  }
  return m;
}

// Block index of each sample: floor((t - t_first) / length).
std::vector<long> block_ids(const std::vector<double>& t, double length_s) {
  std::vector<long> id(t.size());
  for (std::size_t k = 0; k < t.size(); ++k)
    id[k] = static_cast<long>(std::floor((t[k] - t.front()) / length_s));
  return id;
}

// The block sandwich covariance of an OLS fit: (X'X)^-1 [sum_g s_g s_g'] (X'X)^-1 G/(G-1),
// s_g = sum_{k in g} x_k e_k (batch means / cluster-robust; Newey-West with a flat kernel inside
// blocks). nullopt with fewer than min_blocks non-empty blocks.
std::optional<Eigen::MatrixXd> block_covariance(const Eigen::MatrixXd& X, const Eigen::VectorXd& e,
                                                const Eigen::MatrixXd& XtX_inv,
                                                const std::vector<long>& ids, int min_blocks) {
  const Eigen::Index p = X.cols();
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(p, p);
  Eigen::VectorXd s = Eigen::VectorXd::Zero(p);
  long groups = 0;
  for (Eigen::Index k = 0; k < X.rows(); ++k) {
    s += X.row(k).transpose() * e(k);
    const bool last = k + 1 == X.rows() ||
                      ids[static_cast<std::size_t>(k + 1)] != ids[static_cast<std::size_t>(k)];
    if (last) {
      S += s * s.transpose();
      s.setZero();
      ++groups;
    }
  }
  if (groups < std::max(2, min_blocks)) return std::nullopt;
  const double g = static_cast<double>(groups);
  return Eigen::MatrixXd(XtX_inv * S * XtX_inv * (g / (g - 1.0)));
}

std::string deg(double rad_s, int digits = 3) {
  char b[64];
  std::snprintf(b, sizeof b, "%+.*f", digits, rad_s * kRadToDeg);
  return b;
}

std::string deg_opt(const std::optional<double>& rad_s, int digits = 3) {
  if (!rad_s) return "n/a";
  char b[64];
  std::snprintf(b, sizeof b, "%.*f", digits, *rad_s * kRadToDeg);
  return b;
}

nlohmann::json opt_json(const std::optional<double>& v, double scale = 1.0) {
  return v ? nlohmann::json(*v * scale) : nlohmann::json(nullptr);
}

std::string pair_name(const PairDifference& p) { return p.name_a + " - " + p.name_b; }

// A rate coefficient K as the tables print it: "%+.4f", or "-" where the axis was left out.
std::string coefficient_text(const std::optional<double>& k) {
  if (!k) return "-";
  char b[32];
  std::snprintf(b, sizeof b, "%+.4f", *k);
  return b;
}

}  // namespace

RateSeries rates_from_dataset(const Dataset& dataset, std::string name, double t_offset_s,
                              double t_scale) {
  if (dataset.imu.size() < 3)
    throw std::invalid_argument(name + ": " + std::to_string(dataset.imu.size()) +
                                " IMU rows; the cross-IMU check needs at least 3");
  if (!(t_scale > 0.0) || !std::isfinite(t_scale) || !std::isfinite(t_offset_s))
    throw std::invalid_argument(name + ": clock scale " + num(t_scale) + " / offset " +
                                num(t_offset_s) + " is not a usable clock");
  RateSeries s;
  s.name = std::move(name);
  const std::size_t n = dataset.imu.size() - 1;
  s.t_s.reserve(n);
  s.dt_s.reserve(n);
  s.omega_ib_b_rad_s.reserve(n);
  for (std::size_t k = 1; k < dataset.imu.size(); ++k) {
    const double dt = dataset.imu[k].t_s - dataset.imu[k - 1].t_s;  // > 0: load_dataset checks
    s.t_s.push_back((dataset.imu[k].t_s + t_offset_s) * t_scale);
    s.dt_s.push_back(dt * t_scale);
    s.omega_ib_b_rad_s.push_back(dataset.imu[k].dtheta_b_rad / dt);
    if (!dataset.meta.motors.empty())
      s.motor_on.push_back(
          dataset.meta.motors.fraction(dataset.imu[k - 1].t_s, dataset.imu[k].t_s));
  }
  return s;
}

std::string CrossImuOptions::validate() const {
  auto bad = [](const char* what, double v, const char* why) {
    return std::string(what) + " " + num(v) + ": " + why;
  };
  if (t_start_s && !std::isfinite(*t_start_s)) return bad("--t-start", *t_start_s, "not finite");
  if (t_end_s && !std::isfinite(*t_end_s)) return bad("--t-end", *t_end_s, "not finite");
  if (t_start_s && t_end_s && !(*t_start_s < *t_end_s))
    return "--t-start " + num(*t_start_s) + " must be before --t-end " + num(*t_end_s);
  if (!(block_s > 0.0) || !std::isfinite(block_s))
    return bad("--block-s", block_s, "must be a positive number of seconds");
  if (!(segment_s > 0.0) || !std::isfinite(segment_s))
    return bad("--segment-s", segment_s, "must be a positive number of seconds");
  if (!(min_rate_sd_rad_s >= 0.0) || !std::isfinite(min_rate_sd_rad_s))
    return bad("--min-rate-sd-deg-s", min_rate_sd_rad_s * kRadToDeg, "must be >= 0 deg/s");
  if (!(time_match_fraction > 0.0 && time_match_fraction < 0.5))
    return bad("time_match_fraction", time_match_fraction, "must be in (0, 0.5)");
  if (min_blocks < 2) return bad("min_blocks", min_blocks, "must be at least 2");
  for (double l : block_ladder_s)
    if (!(l > 0.0) || !std::isfinite(l))
      return bad("block ladder length", l, "must be a positive number of seconds");
  return "";
}

CrossImuReport direct_differences(const std::vector<RateSeries>& series,
                                  const CrossImuOptions& options) {
  if (const std::string e = options.validate(); !e.empty()) throw std::invalid_argument(e);
  if (series.size() < 2)
    throw std::invalid_argument("the cross-IMU check needs at least two IMUs, got " +
                                std::to_string(series.size()));
  for (const RateSeries& s : series)
    if (s.t_s.size() < 2 || s.t_s.size() != s.dt_s.size() ||
        s.t_s.size() != s.omega_ib_b_rad_s.size())
      throw std::invalid_argument(s.name + ": no usable rate samples");

  CrossImuReport report;
  report.options = options;
  for (const RateSeries& s : series) report.names.push_back(s.name);
  // The window: what every IMU covers, cut to the options.
  double t0 = -std::numeric_limits<double>::infinity();
  double t1 = std::numeric_limits<double>::infinity();
  for (const RateSeries& s : series) {
    t0 = std::max(t0, s.t_s.front());
    t1 = std::min(t1, s.t_s.back());
  }
  if (!(t0 < t1))
    throw std::invalid_argument("the IMUs share no time span (latest start " + num(t0) +
                                " s, earliest end " + num(t1) + " s)");
  if (options.t_start_s) t0 = std::max(t0, *options.t_start_s);
  if (options.t_end_s) t1 = std::min(t1, *options.t_end_s);
  if (!(t0 < t1))
    throw std::invalid_argument(
        "the window --t-start/--t-end lies outside the span every IMU covers");
  report.t_start_s = t0;
  report.t_end_s = t1;
  if ((t1 - t0) / options.segment_s > kMaxSegments)
    throw std::invalid_argument("--segment-s " + num(options.segment_s) + ": the window of " +
                                num(t1 - t0) + " s would make more than " +
                                std::to_string(static_cast<long>(kMaxSegments)) +
                                " segments; give a longer segment");
  report.median_step_s = median_step(series.front());
  report.block_s_used =
      std::min(options.block_s, (t1 - t0) / static_cast<double>(options.min_blocks));
  const double tol_s = options.time_match_fraction * report.median_step_s;

  for (std::size_t bi = 0; bi < series.size(); ++bi)
    for (std::size_t ai = bi + 1; ai < series.size(); ++ai) {
      const RateSeries& a = series[ai];
      const RateSeries& b = series[bi];
      const Matched m = match_samples(a, b, t0, t1, tol_s);
      const std::size_t n = m.ia.size();
      PairDifference pair;
      pair.a = ai;
      pair.b = bi;
      pair.name_a = a.name;
      pair.name_b = b.name;
      pair.against_first = bi == 0;
      pair.samples = n;
      pair.unmatched = m.in_window_a + m.in_window_b - 2 * n;
      if (n < 30)
        throw std::invalid_argument(
            pair_name(pair) + ": " + std::to_string(n) + " samples at the same instants in [" +
            num(t0) + ", " + num(t1) + "] s (" + std::to_string(m.in_window_a) + " of " + a.name +
            ", " + std::to_string(m.in_window_b) + " of " + b.name +
            "); the cross-IMU check needs IMUs logged at the same instants (at least 30)");
      std::vector<double> t(n);
      Eigen::MatrixXd Y(n, 3), W(n, 3);
      for (std::size_t k = 0; k < n; ++k) {
        t[k] = b.t_s[m.ib[k]];
        const Eigen::Vector3d& wa = a.omega_ib_b_rad_s[m.ia[k]];
        const Eigen::Vector3d& wb = b.omega_ib_b_rad_s[m.ib[k]];
        Y.row(static_cast<Eigen::Index>(k)) = (wa - wb).transpose();
        W.row(static_cast<Eigen::Index>(k)) = (0.5 * (wa + wb)).transpose();
      }
      // Which rate columns are motion rather than noise.
      const Eigen::RowVector3d mean_w = W.colwise().mean();
      for (int j = 0; j < 3; ++j) {
        const double sd =
            std::sqrt((W.col(j).array() - mean_w(j)).square().sum() / static_cast<double>(n - 1));
        pair.wbar_sd_rad_s(j) = sd;
        pair.rate_column_used[static_cast<std::size_t>(j)] = sd >= options.min_rate_sd_rad_s;
      }
      std::vector<int> cols;
      for (int j = 0; j < 3; ++j)
        if (pair.rate_column_used[static_cast<std::size_t>(j)]) cols.push_back(j);
      const Eigen::Index p = 1 + static_cast<Eigen::Index>(cols.size());
      if (static_cast<Eigen::Index>(n) < 10 * p)
        throw std::invalid_argument(pair_name(pair) + ": " + std::to_string(n) + " samples for " +
                                    std::to_string(p) +
                                    " coefficients per axis; give a longer window");
      Eigen::MatrixXd X(n, p);
      X.col(0).setOnes();
      for (std::size_t c = 0; c < cols.size(); ++c)
        X.col(static_cast<Eigen::Index>(c + 1)) = W.col(cols[c]);
      const Eigen::MatrixXd XtX = X.transpose() * X;
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(XtX);
      const Eigen::MatrixXd XtX_inv = ldlt.solve(Eigen::MatrixXd::Identity(p, p));
      if (ldlt.info() != Eigen::Success || !XtX_inv.allFinite())
        throw std::invalid_argument(pair_name(pair) +
                                    ": the rates are too nearly constant for a regression");
      const std::vector<long> ids = block_ids(t, report.block_s_used);
      Eigen::MatrixXd K_used(3, p - 1);  // per axis, the rate coefficients used
      for (int i = 0; i < 3; ++i) {
        const Eigen::VectorXd y = Y.col(i);
        const Eigen::VectorXd beta = XtX_inv * (X.transpose() * y);
        const Eigen::VectorXd e = y - X * beta;
        AxisDifference& ax = pair.axes[static_cast<std::size_t>(i)];
        ax.bias_diff_rad_s = beta(0);
        const double s2 = e.squaredNorm() / static_cast<double>(static_cast<Eigen::Index>(n) - p);
        ax.residual_sd_rad_s = std::sqrt(s2);
        ax.se_iid_rad_s = std::sqrt(s2 * XtX_inv(0, 0));
        const std::optional<Eigen::MatrixXd> V =
            block_covariance(X, e, XtX_inv, ids, options.min_blocks);
        if (V) ax.se_rad_s = std::sqrt((*V)(0, 0));
        for (std::size_t c = 0; c < cols.size(); ++c) {
          const auto q = static_cast<Eigen::Index>(c + 1);
          ax.rate_coeff[static_cast<std::size_t>(cols[c])] = beta(q);
          if (V) ax.rate_coeff_se[static_cast<std::size_t>(cols[c])] = std::sqrt((*V)(q, q));
          K_used(i, q - 1) = beta(q);
        }
        for (double length : options.block_ladder_s) {
          const std::optional<Eigen::MatrixXd> Vl =
              block_covariance(X, e, XtX_inv, block_ids(t, length), options.min_blocks);
          ax.se_by_block.emplace_back(
              length, Vl ? std::optional<double>(std::sqrt((*Vl)(0, 0))) : std::nullopt);
        }
      }
      // The step at motor start: the same regression with the motor state as a column.
      if (!a.motor_on.empty() && !b.motor_on.empty()) {
        Eigen::VectorXd u(static_cast<Eigen::Index>(n));
        std::set<long> off_blocks, on_blocks;
        for (std::size_t q = 0; q < n; ++q) {
          u(static_cast<Eigen::Index>(q)) = b.motor_on[m.ib[q]];
          const bool on = b.motor_on[m.ib[q]] >= 0.5;
          (on ? pair.motor_on_samples : pair.motor_off_samples)++;
          (on ? on_blocks : off_blocks).insert(ids[q]);
        }
        // Each side as a segment's SE needs it; the SE itself, from every block of the window,
        // needs min_blocks of them.
        const auto min_side = static_cast<std::size_t>(kMinSegmentBlocks);
        if (off_blocks.size() >= min_side && on_blocks.size() >= min_side) {
          Eigen::MatrixXd Xm(static_cast<Eigen::Index>(n), p + 1);
          Xm.col(0) = X.col(0);
          Xm.col(1) = u;
          Xm.rightCols(p - 1) = X.rightCols(p - 1);
          const Eigen::LDLT<Eigen::MatrixXd> ldlt_m(Xm.transpose() * Xm);
          const Eigen::MatrixXd XtX_inv_m = ldlt_m.solve(Eigen::MatrixXd::Identity(p + 1, p + 1));
          if (ldlt_m.info() == Eigen::Success && XtX_inv_m.allFinite())
            for (int i = 0; i < 3; ++i) {
              const Eigen::VectorXd y = Y.col(i);
              const Eigen::VectorXd beta = XtX_inv_m * (Xm.transpose() * y);
              const Eigen::VectorXd e = y - Xm * beta;
              AxisDifference& ax = pair.axes[static_cast<std::size_t>(i)];
              ax.motor_jump_rad_s = beta(1);
              ax.motors_off_bias_diff_rad_s = beta(0);
              if (const std::optional<Eigen::MatrixXd> V =
                      block_covariance(Xm, e, XtX_inv_m, ids, options.min_blocks)) {
                ax.motor_jump_se_rad_s = std::sqrt((*V)(1, 1));
                ax.motors_off_se_rad_s = std::sqrt((*V)(0, 0));
              }
            }
        }
      }
      // Per segment: the mean of y - K wbar, its SE from the blocks inside the segment.
      std::size_t k = 0;
      for (long segment = 0; t0 + static_cast<double>(segment) * options.segment_s < t1 && k < n;
           ++segment) {
        const double s0 = t0 + static_cast<double>(segment) * options.segment_s;
        const double s1 = std::min(t1, s0 + options.segment_s);
        Segment seg;
        seg.t_start_s = s0;
        seg.t_end_s = s1;
        std::vector<Eigen::Vector3d> r;
        std::vector<long> seg_ids;
        while (k < n && (t[k] < s1 || (s1 == t1 && t[k] <= t1))) {
          Eigen::Vector3d ri = Y.row(static_cast<Eigen::Index>(k)).transpose();
          for (std::size_t c = 0; c < cols.size(); ++c)
            ri -=
                K_used.col(static_cast<Eigen::Index>(c)) * W(static_cast<Eigen::Index>(k), cols[c]);
          r.push_back(ri);
          seg_ids.push_back(static_cast<long>(std::floor((t[k] - s0) / report.block_s_used)));
          ++k;
        }
        seg.samples = r.size();
        if (r.empty()) continue;
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        for (const Eigen::Vector3d& v : r) mean += v;
        mean /= static_cast<double>(r.size());
        seg.bias_diff_rad_s = mean;
        Eigen::Vector3d S = Eigen::Vector3d::Zero(), sum = Eigen::Vector3d::Zero();
        long groups = 0;
        for (std::size_t q = 0; q < r.size(); ++q) {
          sum += r[q] - mean;
          if (q + 1 == r.size() || seg_ids[q + 1] != seg_ids[q]) {
            S += sum.cwiseProduct(sum);
            sum.setZero();
            ++groups;
          }
        }
        if (groups >= kMinSegmentBlocks) {
          const double g = static_cast<double>(groups), m2 = static_cast<double>(r.size());
          for (int i = 0; i < 3; ++i)
            seg.se_rad_s[static_cast<std::size_t>(i)] = std::sqrt(S(i) / (m2 * m2) * g / (g - 1));
        }
        pair.segments.push_back(seg);
      }
      report.pairs.push_back(std::move(pair));
    }
  // Pairs against the first IMU first (the independent ones), then the others.
  std::stable_sort(report.pairs.begin(), report.pairs.end(),
                   [](const PairDifference& x, const PairDifference& y) {
                     return x.against_first && !y.against_first;
                   });
  return report;
}

ResultEstimates read_identify_result(const std::filesystem::path& path) {
  const std::string src = path.string();
  const nlohmann::json j = read_json_file(path);
  try {
    const JsonObject doc = JsonObject::with_other_keys(
        j, src, "", {"format", "parameters", "algorithm", "gyro_bias_at_rest"});
    const std::string format = doc.string("format");
    if (format != "insid-identify/2")
      doc.field("format").fail(
          "expected \"insid-identify/2\" (an insid identify result), found \"" + format + "\"");
    ResultEstimates r;
    r.source = src;
    r.gyro_bias_at_rest = doc.has("gyro_bias_at_rest");
    if (const auto algo = doc.optional_given("algorithm")) {  // {"name": ..., "parameters": ...}
      const nlohmann::json& v = algo->value();
      if (v.is_object() && v.contains("name") && v["name"].is_string())
        r.algorithm = v["name"].get<std::string>();
      else if (v.is_string())
        r.algorithm = v.get<std::string>();
    }
    const JsonArray params = doc.array("parameters");
    for (std::size_t k = 0; k < params.size(); ++k) {
      const JsonField f = params[k];
      const JsonObject o =
          JsonObject::with_other_keys(f.value(), src, json_index_path("parameters", k),
                                      {"name", "estimate", "sd", "flags", "unit"});
      const std::string name = o.string("name");
      const EffectInfo* effect = find_effect_info(name);
      if (effect == nullptr || effect->sensor != EffectSensor::kGyro ||
          (effect->kind != EffectKind::kBias && effect->kind != EffectKind::kMotorOffset))
        continue;
      const int axis = effect->axis;
      EstimatedBias e;
      e.estimate_rad_s = o.number("estimate");
      if (o.has("unit") && o.string("unit") != "rad/s")
        o.field("unit").fail("expected \"rad/s\" for " + name + ", found \"" + o.string("unit") +
                             "\"");
      if (const auto sd = o.optional_given("sd")) {
        const double v = sd->finite_number();
        if (v < 0.0) sd->fail("must be >= 0, found " + num(v));
        e.sd_rad_s = v;
      }
      if (const auto flags = o.optional_given("flags")) e.flags = flags->array().strings();
      (effect->kind == EffectKind::kBias ? r.gyro_bias
                                         : r.gyro_motor_offset)[static_cast<std::size_t>(axis)] = e;
    }
    return r;
  } catch (const JsonFieldError& e) {
    throw std::runtime_error(e.what());
  }
}

Verdict verdict_from_z(double z) {
  if (!std::isfinite(z)) return Verdict::kNotCompared;
  const double a = std::abs(z);
  if (a <= 2.0) return Verdict::kAgree;
  if (a <= 3.0) return Verdict::kCheck;
  return Verdict::kDisagree;
}

std::vector<ComparisonRow> compare_with_results(const CrossImuReport& report,
                                                const std::vector<ResultEstimates>& results) {
  if (results.size() != report.names.size())
    throw std::invalid_argument(std::to_string(results.size()) + " --result files for " +
                                std::to_string(report.names.size()) +
                                " --data directories: give one result per dataset, same order");
  std::vector<ComparisonRow> rows;
  const auto compare = [&](std::size_t pi, int i, EffectKind kind) {
    const PairDifference& p = report.pairs[pi];
    const bool motor = kind == EffectKind::kMotorOffset;
    ComparisonRow row;
    row.pair = pi;
    row.axis = i;
    row.kind = kind;
    const AxisDifference& ax = p.axes[static_cast<std::size_t>(i)];
    row.direct_rad_s = motor ? *ax.motor_jump_rad_s : ax.bias_diff_rad_s;
    row.direct_se_rad_s = motor ? ax.motor_jump_se_rad_s : ax.se_rad_s;
    // Results that estimate this axis's motor offsets call the motors-off bias their bias.
    if (!motor && ax.motors_off_bias_diff_rad_s &&
        results[p.a].gyro_motor_offset[static_cast<std::size_t>(i)] &&
        results[p.b].gyro_motor_offset[static_cast<std::size_t>(i)]) {
      row.direct_rad_s = *ax.motors_off_bias_diff_rad_s;
      row.direct_se_rad_s = ax.motors_off_se_rad_s;
      row.flags.push_back("direct: motors off");
    }
    const std::string param = gyro_bias_name(i, kind);
    const auto& ea = (motor ? results[p.a].gyro_motor_offset
                            : results[p.a].gyro_bias)[static_cast<std::size_t>(i)];
    const auto& eb = (motor ? results[p.b].gyro_motor_offset
                            : results[p.b].gyro_bias)[static_cast<std::size_t>(i)];
    for (const auto& [who, e] : {std::pair{&p.name_a, &ea}, std::pair{&p.name_b, &eb}})
      if (*e)
        for (const std::string& flag : (*e)->flags)
          if (flag == "at_box_edge" || flag == "not_converged")
            row.flags.push_back(*who + " " + flag);
    if (!ea || !eb) {
      const std::string& who = !ea ? p.name_a : p.name_b;
      row.reason = results[!ea ? p.a : p.b].gyro_bias_at_rest && !motor
                       ? param + " measured at rest in the result of " + who +
                             " (the direct difference's own samples)"
                       : param + " not estimated in the result of " + who;
    } else {
      row.insid_diff_rad_s = ea->estimate_rad_s - eb->estimate_rad_s;
      if (!ea->sd_rad_s || !eb->sd_rad_s) {
        row.reason =
            "the result of " + (!ea->sd_rad_s ? p.name_a : p.name_b) + " gives no sd for " + param;
      } else {
        row.insid_sd_rad_s = std::hypot(*ea->sd_rad_s, *eb->sd_rad_s);
        if (!row.direct_se_rad_s) {
          row.reason = "the direct difference has no SE (fewer than " +
                       std::to_string(report.options.min_blocks) + " blocks)";
        } else {
          const double denom = std::hypot(*row.insid_sd_rad_s, *row.direct_se_rad_s);
          if (denom > 0.0) {
            row.z = (*row.insid_diff_rad_s - row.direct_rad_s) / denom;
            row.verdict = verdict_from_z(*row.z);
          } else {
            row.reason = "every sd is zero";
          }
        }
      }
    }
    rows.push_back(std::move(row));
  };
  for (std::size_t pi = 0; pi < report.pairs.size(); ++pi)
    for (int i = 0; i < 3; ++i) compare(pi, i, EffectKind::kBias);
  // The motor offsets against the jumps at motor start, where both are there to compare.
  for (std::size_t pi = 0; pi < report.pairs.size(); ++pi) {
    const PairDifference& p = report.pairs[pi];
    for (int i = 0; i < 3; ++i)
      if (p.axes[static_cast<std::size_t>(i)].motor_jump_rad_s &&
          (results[p.a].gyro_motor_offset[static_cast<std::size_t>(i)] ||
           results[p.b].gyro_motor_offset[static_cast<std::size_t>(i)]))
        compare(pi, i, EffectKind::kMotorOffset);
  }
  // An estimated difference whose sd exceeds the largest difference the airframe shows (of the
  // same quantity) cannot tell these IMUs apart: its |z| would be small whatever it says.
  for (const EffectKind kind : {EffectKind::kBias, EffectKind::kMotorOffset}) {
    double largest = 0.0;
    for (const ComparisonRow& r : rows)
      if (r.kind == kind) largest = std::max(largest, std::abs(r.direct_rad_s));
    for (ComparisonRow& r : rows)
      if (r.kind == kind && r.z && r.insid_sd_rad_s && *r.insid_sd_rad_s > largest) {
        char text[160];
        std::snprintf(text, sizeof text,
                      "insid's sd, %.3f deg/s, exceeds the largest difference the airframe shows "
                      "(%.3f deg/s): the estimate cannot tell these IMUs apart",
                      *r.insid_sd_rad_s * kRadToDeg, largest * kRadToDeg);
        r.reason = text;
        r.z.reset();
        r.verdict = Verdict::kNotCompared;
      }
  }
  return rows;
}

std::vector<std::string> comparison_warnings(const CrossImuReport& report,
                                             const std::vector<ComparisonRow>& rows) {
  std::vector<std::string> out;
  std::map<std::string, std::string> edges;  // "gyro_bias_x of IMU2" -> the pairs it enters
  for (const ComparisonRow& r : rows) {
    const PairDifference& p = report.pairs[r.pair];
    const std::string param = gyro_bias_name(r.axis, r.kind);
    if (r.verdict == Verdict::kDisagree) {
      char z[32];
      std::snprintf(z, sizeof z, "%.1f", *r.z);
      out.push_back("insid's " + param + " for " + p.name_a +
                    " disagrees with its own airframe: " + pair_name(p) + " estimated " +
                    deg(*r.insid_diff_rad_s) + " +- " + deg_opt(r.insid_sd_rad_s) +
                    " deg/s, measured directly from the samples " + deg(r.direct_rad_s) + " +- " +
                    deg_opt(r.direct_se_rad_s) + " deg/s (z = " + z + ")");
    }
    for (const std::string& flag : r.flags)
      if (flag.find("at_box_edge") != std::string::npos) {
        std::string& pairs = edges[param + " of " + flag.substr(0, flag.find(' '))];
        pairs.append(pairs.empty() ? "" : ", ").append(pair_name(p));
      }
  }
  for (const auto& [what, pairs] : edges)
    out.push_back(what + " is at its box edge: the estimated " + pairs +
                  " rest on a clipped estimate");
  return out;
}

nlohmann::json report_json(const CrossImuReport& report, const std::vector<ComparisonRow>* rows) {
  const CrossImuOptions& o = report.options;
  nlohmann::json j;
  j["format"] = "insid-cross-imu/1";
  j["imus"] = report.names;
  j["window_s"] = {report.t_start_s, report.t_end_s};
  j["median_step_s"] = report.median_step_s;
  j["block_s_used"] = report.block_s_used;
  j["options"] = {{"block_s", o.block_s},
                  {"block_ladder_s", o.block_ladder_s},
                  {"segment_s", o.segment_s},
                  {"min_rate_sd_deg_s", o.min_rate_sd_rad_s * kRadToDeg},
                  {"time_match_fraction", o.time_match_fraction},
                  {"min_blocks", o.min_blocks}};
  j["model"] =
      "per pair and gyro axis: omega_a - omega_b = db + K wbar + e, wbar = (omega_a + omega_b) / "
      "2 (a rate column only where its sd reaches min_rate_sd), OLS; SE from the block sandwich "
      "(batch means) with blocks of block_s; gyros only (accelerometer differences carry "
      "lever-arm terms and, on a multicopter, a z scale factor collinear with the z bias)";
  nlohmann::json pairs = nlohmann::json::array();
  for (const PairDifference& p : report.pairs) {
    nlohmann::json pj;
    pj["a"] = p.name_a;
    pj["b"] = p.name_b;
    pj["difference"] = p.name_a + " - " + p.name_b;
    pj["against_first"] = p.against_first;
    pj["samples"] = p.samples;
    pj["unmatched_samples"] = p.unmatched;
    pj["wbar_sd_deg_s"] = {p.wbar_sd_rad_s.x() * kRadToDeg, p.wbar_sd_rad_s.y() * kRadToDeg,
                           p.wbar_sd_rad_s.z() * kRadToDeg};
    pj["rate_columns_used"] = {p.rate_column_used[0], p.rate_column_used[1], p.rate_column_used[2]};
    if (p.motor_off_samples + p.motor_on_samples > 0)
      pj["motor_samples"] = {{"off", p.motor_off_samples}, {"on", p.motor_on_samples}};
    nlohmann::json axes = nlohmann::json::object();
    for (int i = 0; i < 3; ++i) {
      const AxisDifference& ax = p.axes[static_cast<std::size_t>(i)];
      nlohmann::json a;
      a["gyro_bias_diff_rad_s"] = ax.bias_diff_rad_s;
      a["se_rad_s"] = opt_json(ax.se_rad_s);
      a["gyro_bias_diff_deg_s"] = ax.bias_diff_rad_s * kRadToDeg;
      a["se_deg_s"] = opt_json(ax.se_rad_s, kRadToDeg);
      a["se_iid_deg_s"] = ax.se_iid_rad_s * kRadToDeg;
      a["residual_sd_deg_s"] = ax.residual_sd_rad_s * kRadToDeg;
      nlohmann::json K = nlohmann::json::array(), Kse = nlohmann::json::array();
      for (int c = 0; c < 3; ++c) {
        K.push_back(opt_json(ax.rate_coeff[static_cast<std::size_t>(c)]));
        Kse.push_back(opt_json(ax.rate_coeff_se[static_cast<std::size_t>(c)]));
      }
      a["rate_coeff"] = K;
      a["rate_coeff_se"] = Kse;
      nlohmann::json ladder = nlohmann::json::array();
      for (const auto& [len, se] : ax.se_by_block)
        ladder.push_back({{"block_s", len}, {"se_deg_s", opt_json(se, kRadToDeg)}});
      a["se_by_block"] = ladder;
      if (ax.motor_jump_rad_s) {
        a["motor_jump_deg_s"] = *ax.motor_jump_rad_s * kRadToDeg;
        a["motor_jump_se_deg_s"] = opt_json(ax.motor_jump_se_rad_s, kRadToDeg);
      }
      axes[kAxis[i]] = a;
    }
    pj["gyro"] = axes;
    nlohmann::json segs = nlohmann::json::array();
    for (const Segment& s : p.segments) {
      nlohmann::json sj;
      sj["t_s"] = {s.t_start_s, s.t_end_s};
      sj["samples"] = s.samples;
      sj["gyro_bias_diff_deg_s"] = {s.bias_diff_rad_s.x() * kRadToDeg,
                                    s.bias_diff_rad_s.y() * kRadToDeg,
                                    s.bias_diff_rad_s.z() * kRadToDeg};
      sj["se_deg_s"] = {opt_json(s.se_rad_s[0], kRadToDeg), opt_json(s.se_rad_s[1], kRadToDeg),
                        opt_json(s.se_rad_s[2], kRadToDeg)};
      segs.push_back(sj);
    }
    pj["segments"] = segs;
    pairs.push_back(pj);
  }
  j["pairs"] = pairs;
  if (rows) {
    nlohmann::json cmp = nlohmann::json::array();
    std::map<std::string, int> counts, motor_counts;
    for (const ComparisonRow& r : *rows) {
      const PairDifference& p = report.pairs[r.pair];
      nlohmann::json c;
      c["difference"] = p.name_a + " - " + p.name_b;
      c["against_first"] = p.against_first;
      c["parameter"] = gyro_bias_name(r.axis, r.kind);
      c["insid_diff_deg_s"] = opt_json(r.insid_diff_rad_s, kRadToDeg);
      c["insid_sd_deg_s"] = opt_json(r.insid_sd_rad_s, kRadToDeg);
      c["direct_deg_s"] = r.direct_rad_s * kRadToDeg;
      c["direct_se_deg_s"] = opt_json(r.direct_se_rad_s, kRadToDeg);
      c["z"] = opt_json(r.z);
      c["verdict"] = to_string(r.verdict);
      if (!r.reason.empty()) c["reason"] = r.reason;
      c["flags"] = r.flags;
      cmp.push_back(c);
      if (p.against_first && r.kind == EffectKind::kBias) ++counts[to_string(r.verdict)];
      if (p.against_first && r.kind == EffectKind::kMotorOffset)
        ++motor_counts[to_string(r.verdict)];
    }
    j["comparison"] = cmp;
    j["comparison_independent_counts"] = counts;
    if (!motor_counts.empty()) j["comparison_motor_offset_independent_counts"] = motor_counts;
    j["comparison_rule"] =
        "z = (insid difference - direct) / sqrt(sd_a^2 + sd_b^2 + se_direct^2); agree |z| <= 2, "
        "check 2-3, disagree > 3; counts over the pairs against the first IMU (independent)";
  }
  return j;
}

namespace {

// The jumps at motor start, one line per pair ("" when no pair has one).
std::string motor_jump_text(const CrossImuReport& report, const std::string& indent) {
  std::ostringstream s;
  for (const PairDifference& p : report.pairs) {
    if (!p.axes[0].motor_jump_rad_s) continue;
    if (s.tellp() == 0)
      s << indent.substr(2) << "jump of the difference at motor start (deg/s, +- SE; "
        << "the pair's motor offset difference):\n";
    s << indent << pair_name(p) << " (" << p.motor_off_samples << " samples motors off, "
      << p.motor_on_samples << " on):";
    for (int i = 0; i < 3; ++i) {
      const AxisDifference& ax = p.axes[static_cast<std::size_t>(i)];
      s << "  " << kAxis[i] << " " << deg(*ax.motor_jump_rad_s) << " +- "
        << deg_opt(ax.motor_jump_se_rad_s);
    }
    s << "\n";
  }
  return s.str();
}

}  // namespace

std::string report_text(const CrossImuReport& report, const std::vector<ComparisonRow>* rows) {
  std::ostringstream s;
  char line[512];
  std::snprintf(line, sizeof line,
                "direct gyro bias differences (deg/s) over %.2f-%.2f s, SE from %g s blocks "
                "(batch means):\n",
                report.t_start_s, report.t_end_s, report.block_s_used);
  s << line;
  std::snprintf(line, sizeof line, "  %-16s %-4s %10s %8s %8s  %-26s %s\n", "difference", "axis",
                "db", "SE", "SE iid", "K (x, y, z rate)", "SE over blocks 0.5-5 s");
  s << line;
  for (const PairDifference& p : report.pairs)
    for (int i = 0; i < 3; ++i) {
      const AxisDifference& ax = p.axes[static_cast<std::size_t>(i)];
      std::string K;
      for (int c = 0; c < 3; ++c) {
        if (c) K.append(" ");
        K.append(coefficient_text(ax.rate_coeff[static_cast<std::size_t>(c)]));
      }
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      for (const auto& [len, se] : ax.se_by_block)
        if (se && len >= 0.5 - 1e-9 && len <= 5.0 + 1e-9) {
          lo = std::min(lo, *se);
          hi = std::max(hi, *se);
        }
      char range[64] = "n/a";
      if (std::isfinite(lo))
        std::snprintf(range, sizeof range, "%.4f-%.4f", lo * kRadToDeg, hi * kRadToDeg);
      std::snprintf(line, sizeof line, "  %-16s %-4s %10s %8s %8s  %-26s %s\n",
                    pair_name(p).c_str(), kAxis[i], deg(ax.bias_diff_rad_s, 4).c_str(),
                    deg_opt(ax.se_rad_s, 4).c_str(), deg_opt(ax.se_iid_rad_s, 4).c_str(), K.c_str(),
                    range);
      s << line;
    }
  s << "per segment of " << report.options.segment_s
    << " s (db = mean of the difference less K x rate; +- SE):\n";
  for (const PairDifference& p : report.pairs) {
    s << "  " << pair_name(p) << ":\n";
    for (const Segment& g : p.segments) {
      std::snprintf(line, sizeof line, "    %8.2f-%8.2f s  x %s +- %s  y %s +- %s  z %s +- %s\n",
                    g.t_start_s, g.t_end_s, deg(g.bias_diff_rad_s.x()).c_str(),
                    deg_opt(g.se_rad_s[0]).c_str(), deg(g.bias_diff_rad_s.y()).c_str(),
                    deg_opt(g.se_rad_s[1]).c_str(), deg(g.bias_diff_rad_s.z()).c_str(),
                    deg_opt(g.se_rad_s[2]).c_str());
      s << line;
    }
  }
  s << motor_jump_text(report, "  ");
  if (rows) {
    s << "insid's estimated differences against the direct ones (deg/s):\n";
    std::snprintf(line, sizeof line, "  %-16s %-12s %10s %8s %10s %8s %7s  %-12s %s\n",
                  "difference", "parameter", "insid", "sd", "direct", "SE", "z", "verdict",
                  "flags");
    s << line;
    for (const ComparisonRow& r : *rows) {
      const PairDifference& p = report.pairs[r.pair];
      std::string flags;
      for (const std::string& f : r.flags) flags.append(flags.empty() ? "" : ", ").append(f);
      if (!r.reason.empty()) flags.append(flags.empty() ? "" : "; ").append(r.reason);
      char z[32] = "n/a";
      if (r.z) std::snprintf(z, sizeof z, "%+.2f", *r.z);
      std::snprintf(line, sizeof line, "  %-16s %-12s %10s %8s %10s %8s %7s  %-12s %s\n",
                    pair_name(p).c_str(), gyro_bias_name(r.axis, r.kind).c_str(),
                    r.insid_diff_rad_s ? deg(*r.insid_diff_rad_s).c_str() : "n/a",
                    deg_opt(r.insid_sd_rad_s).c_str(), deg(r.direct_rad_s).c_str(),
                    deg_opt(r.direct_se_rad_s).c_str(), z, to_string(r.verdict), flags.c_str());
      s << line;
    }
  }
  return s.str();
}

std::string report_markdown(const CrossImuReport& report, const std::vector<ComparisonRow>* rows) {
  std::ostringstream s;
  char line[512];
  std::snprintf(line, sizeof line,
                "Direct gyro bias differences over %.2f-%.2f s (deg/s; SE from %g s blocks):\n\n",
                report.t_start_s, report.t_end_s, report.block_s_used);
  s << line;
  s << "| difference | axis | direct | SE | SE (i.i.d.) | K x | K y | K z |\n"
       "|---|---|---:|---:|---:|---:|---:|---:|\n";
  for (const PairDifference& p : report.pairs)
    for (int i = 0; i < 3; ++i) {
      const AxisDifference& ax = p.axes[static_cast<std::size_t>(i)];
      std::string K;
      for (int c = 0; c < 3; ++c) {
        K.append(" ")
            .append(coefficient_text(ax.rate_coeff[static_cast<std::size_t>(c)]))
            .append(" |");
      }
      std::snprintf(line, sizeof line, "| %s | %s | %s | %s | %s |%s\n", pair_name(p).c_str(),
                    kAxis[i], deg(ax.bias_diff_rad_s).c_str(), deg_opt(ax.se_rad_s).c_str(),
                    deg_opt(ax.se_iid_rad_s).c_str(), K.c_str());
      s << line;
    }
  if (const std::string jumps = motor_jump_text(report, "    "); !jumps.empty()) s << "\n" << jumps;
  if (rows) {
    s << "\ninsid's estimated differences against the direct ones (deg/s):\n\n"
         "| difference | parameter | insid | sd | direct | SE | z | verdict | flags |\n"
         "|---|---|---:|---:|---:|---:|---:|---|---|\n";
    for (const ComparisonRow& r : *rows) {
      const PairDifference& p = report.pairs[r.pair];
      std::string flags;
      for (const std::string& f : r.flags) flags.append(flags.empty() ? "" : ", ").append(f);
      if (!r.reason.empty()) flags.append(flags.empty() ? "" : "; ").append(r.reason);
      char z[32] = "n/a";
      if (r.z) std::snprintf(z, sizeof z, "%+.2f", *r.z);
      std::snprintf(line, sizeof line, "| %s | %s | %s | %s | %s | %s | %s | %s | %s |\n",
                    pair_name(p).c_str(), gyro_bias_name(r.axis, r.kind).c_str(),
                    r.insid_diff_rad_s ? deg(*r.insid_diff_rad_s).c_str() : "n/a",
                    deg_opt(r.insid_sd_rad_s).c_str(), deg(r.direct_rad_s).c_str(),
                    deg_opt(r.direct_se_rad_s).c_str(), z, to_string(r.verdict), flags.c_str());
      s << line;
    }
  }
  return s.str();
}

}  // namespace insid::cross_imu
