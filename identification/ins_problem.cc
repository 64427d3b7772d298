#include "identification/ins_problem.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <exception>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include "base/number_text.h"
#include "data/dataset.h"
#include "model/earth.h"
#include "model/rotation.h"
#include "optimizers/parameters.h"

namespace insid {
namespace {

double parse_number(const std::string& text, const std::string& what, const std::string& spec) {
  double value = 0.0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || ptr != text.data() + text.size() || !std::isfinite(value))
    throw std::invalid_argument("--estimate '" + spec + "': " + what +
                                " must be a finite number, got '" + text + "'");
  return value;
}

}  // namespace

namespace {

// The largest size of an effect that is still physical (a search box beyond it only runs the
// pipeline into overflow and a misleading message, e.g. a 1e300-sigma accelerometer box failed
// as "coarse alignment ... (at a pole?)"): biases within the ranges insid accepts in data
// (PlausibilityBounds), drifts that stay there for a minute, scale factors up to 100 %,
// small-angle misalignments up to 1 rad, GNSS latencies up to a minute, lever arms up to 100 m.
struct PhysicalLimit {
  double value_si;
  std::string why;
};
PhysicalLimit physical_limit(const std::string& name) {
  using B = PlausibilityBounds;
  const double gyro_rad_s = B::kMaxAngularRate_deg_s * kDegToRad;
  const double accel_mps2 = B::kMaxSpecificForce_g * kStandardGravity_mps2;
  const EffectInfo* info = find_effect_info(name);
  if (info == nullptr) return {std::numeric_limits<double>::infinity(), ""};
  const bool gyro = info->sensor == EffectSensor::kGyro;
  switch (info->kind) {
    case EffectKind::kBiasDrift:
      return gyro ? PhysicalLimit{gyro_rad_s / 60.0,
                                  "a gyro bias drift that leaves the 2000 deg/s range within a "
                                  "minute is not physical"}
                  : PhysicalLimit{accel_mps2 / 60.0,
                                  "an accelerometer bias drift that leaves the 50 g range within "
                                  "a minute is not physical"};
    case EffectKind::kBias:
    case EffectKind::kMotorOffset:
      return gyro ? PhysicalLimit{gyro_rad_s,
                                  "a gyro bias beyond 2000 deg/s (the largest rate insid accepts "
                                  "in data) is not physical"}
                  : PhysicalLimit{accel_mps2,
                                  "an accelerometer bias beyond 50 g (the largest specific force "
                                  "insid accepts in data) is not physical"};
    case EffectKind::kScale:
      return {1.0, "a scale factor error beyond 100 % is not physical"};
    case EffectKind::kMisalign:
      return {1.0, "the small-angle misalignment model ends well before 1 rad"};
    case EffectKind::kLatency:
      return {60.0, "a GNSS latency beyond a minute is not physical"};
    case EffectKind::kLeverArm:
      return {100.0, "an antenna lever arm beyond 100 m is not physical"};
  }
  return {std::numeric_limits<double>::infinity(), ""};
}

}  // namespace

EstimatedParameter EstimatedParameter::parse(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, ':');) parts.push_back(part);
  if (parts.empty() || (parts.size() != 1 && parts.size() != 2 && parts.size() != 4))
    throw std::invalid_argument("--estimate '" + text +
                                "': expected NAME, NAME:SIGMA or NAME:SIGMA:LO:HI");
  EstimatedParameter p;
  p.name = parts[0];
  p.sigma = effect_info(p.name).sigma;  // throws on an unknown name, listing the valid ones
  if (parts.size() >= 2) p.sigma = parse_number(parts[1], "SIGMA", text);
  if (parts.size() == 4) {
    p.lower_sigma = parse_number(parts[2], "LO", text);
    p.upper_sigma = parse_number(parts[3], "HI", text);
  }
  if (!(p.sigma > 0.0)) throw std::invalid_argument("--estimate '" + text + "': SIGMA must be > 0");
  if (!(p.lower_sigma < p.upper_sigma))
    throw std::invalid_argument("--estimate '" + text + "': LO must be < HI");
  const double reach_si = std::max(std::abs(p.lower_sigma), std::abs(p.upper_sigma)) * p.sigma;
  const PhysicalLimit limit = physical_limit(p.name);
  if (!(reach_si <= limit.value_si))
    throw std::invalid_argument("--estimate '" + text + "': the search box reaches " +
                                number_text(reach_si, 3) + " " +
                                std::string(effect_info(p.name).unit) + "; " + limit.why +
                                ": give a smaller SIGMA or " + "LO:HI");
  return p;
}

std::vector<EstimatedParameter> EstimatedParameter::paper_four() {
  return {parse("accel_bias_x"), parse("accel_bias_y"), parse("gyro_bias_x"), parse("gyro_bias_y")};
}

ParameterMapping::ParameterMapping(std::vector<EstimatedParameter> parameters, SensorErrors base,
                                   std::optional<GyroAtRest> gyro_at_rest)
    : parameters_(std::move(parameters)),
      base_(std::move(base)),
      gyro_at_rest_(std::move(gyro_at_rest)) {
  if (parameters_.empty()) throw std::invalid_argument("no parameter to estimate");
  for (std::size_t i = 0; i < parameters_.size(); ++i)
    for (std::size_t j = i + 1; j < parameters_.size(); ++j)
      if (parameters_[i].name == parameters_[j].name)
        throw std::invalid_argument("parameter '" + parameters_[i].name + "' is estimated twice");
  if (!gyro_at_rest_) return;
  for (const EstimatedParameter& p : parameters_) {
    if (measured_at_rest(p.name))
      throw std::invalid_argument("'" + p.name +
                                  "' is measured at rest (the gyro bias at rest), so it cannot be "
                                  "estimated as well: leave it out of the estimated parameters");
  }
}

ParameterMapping ParameterMapping::with_gyro_at_rest(const GyroAtRest& rest) const {
  ParameterMapping copy = *this;
  copy.gyro_at_rest_ = rest;
  return copy;
}

Eigen::VectorXd ParameterMapping::to_sigma(const Eigen::VectorXd& x) const {
  Eigen::VectorXd s(dimension());
  for (int j = 0; j < dimension(); ++j) {
    const EstimatedParameter& p = parameters_[static_cast<std::size_t>(j)];
    s[j] = p.lower_sigma + 0.5 * (x[j] + 1.0) * (p.upper_sigma - p.lower_sigma);
  }
  return s;
}

Eigen::VectorXd ParameterMapping::from_sigma(const Eigen::VectorXd& value_sigma) const {
  Eigen::VectorXd x(dimension());
  for (int j = 0; j < dimension(); ++j) {
    const EstimatedParameter& p = parameters_[static_cast<std::size_t>(j)];
    x[j] = 2.0 * (value_sigma[j] - p.lower_sigma) / (p.upper_sigma - p.lower_sigma) - 1.0;
  }
  return x;
}

SensorErrors ParameterMapping::to_errors(const Eigen::VectorXd& x) const {
  SensorErrors errors = base_;
  const Eigen::VectorXd s = to_sigma(x);
  for (int j = 0; j < dimension(); ++j) {
    const EstimatedParameter& p = parameters_[static_cast<std::size_t>(j)];
    set_effect(errors, p.name, s[j] * p.sigma);
  }
  if (gyro_at_rest_) errors.gyro.bias = gyro_at_rest_->bias_for(errors.gyro);
  return errors;
}

double ParameterMapping::sigma_per_unit(int j) const {
  const EstimatedParameter& p = parameters_[static_cast<std::size_t>(j)];
  return 0.5 * (p.upper_sigma - p.lower_sigma);
}

std::pair<std::string, double> ParameterMapping::algorithm_parameter_in_box(
    std::string key, double value, const opt::ParameterInfoList& own) const {
  for (const opt::ParameterInfo& p : own) {
    if (p.unit != opt::ParameterUnit::kBoxDistance || key != p.name + "_sigma") continue;
    const double unit = sigma_per_unit(0);
    for (int k = 1; k < dimension(); ++k)
      if (sigma_per_unit(k) != unit)
        throw std::invalid_argument(key +
                                    ": the estimated parameters have boxes of different widths; "
                                    "give " +
                                    p.name + " in normalised units");
    return {p.name, value / unit};
  }
  return {std::move(key), value};
}

InsIdentificationProblem::InsIdentificationProblem(
    std::shared_ptr<const NavigationProblem> navigation, ParameterMapping mapping, FitnessKind kind,
    opt::EvaluatorOptions evaluator, FitnessEvaluator implementation)
    : opt::Problem(opt::Bounds::unit_box(mapping.dimension())),
      navigation_(std::move(navigation)),
      kernel_(BatchFitness::shared(navigation_)),
      mapping_(std::move(mapping)),
      kind_(kind),
      options_(evaluator.validated()),
      implementation_(implementation) {
  if (!navigation_->dataset().meta.motors.empty()) return;
  for (const EstimatedParameter& p : mapping_.parameters()) {
    const EffectInfo* info = find_effect_info(p.name);
    if (info != nullptr && info->kind == EffectKind::kMotorOffset)
      throw std::invalid_argument(
          "'" + p.name +
          "' needs the motor state, and the dataset has none (meta.json \"motors\": an "
          "ArduPilot import whose log has RCOU, or a scenario's motors_on_s)");
  }
}

double InsIdentificationProblem::fitness(const Eigen::VectorXd& x) const {
  return navigation_->fitness(mapping_.to_errors(x), kind_);
}

bool InsIdentificationProblem::uses_batched_kernel() const {
  return implementation_ == FitnessEvaluator::kBatched && kernel_->supported();
}

int InsIdentificationProblem::residual_count() const {
  return static_cast<int>(2 * navigation_->num_epochs());
}

void InsIdentificationProblem::evaluate_batch(std::span<const Eigen::VectorXd> xs,
                                              std::span<double> f_out) const {
  evaluate(xs, f_out, {});
}

void InsIdentificationProblem::evaluate_residual_batch(std::span<const Eigen::VectorXd> xs,
                                                       std::span<std::vector<double>> r_out,
                                                       std::span<double> f_out) const {
  if (r_out.size() != xs.size())
    throw std::invalid_argument("evaluate_residual_batch: " + std::to_string(xs.size()) +
                                " candidates but " + std::to_string(r_out.size()) + " outputs");
  evaluate(xs, f_out, r_out);
}

void InsIdentificationProblem::require_finite(std::span<const Eigen::VectorXd> xs,
                                              std::span<const double> f) const {
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (std::isfinite(f[i])) continue;
    // Name the candidate in the user's terms (SI and sigma) and where its navigation broke.
    const Eigen::VectorXd sigma = mapping_.to_sigma(xs[i]);
    std::string values;
    for (int k = 0; k < mapping_.dimension(); ++k) {
      const EstimatedParameter& p = mapping_.parameters()[static_cast<std::size_t>(k)];
      values += (k == 0 ? "" : ", ") + p.name + " = " + opt::format_number(sigma[k] * p.sigma) +
                " (" + opt::format_number(sigma[k]) + " sigma)";
    }
    std::string why;
    try {
      why = navigation_->non_finite_report(mapping_.to_errors(xs[i]));
    } catch (const std::exception& e) {
      why = e.what();
    }
    throw opt::NonFiniteFitnessError("fitness " + opt::format_number(f[i]) + " of candidate " +
                                     std::to_string(i) + " (" + values + "): " +
                                     (why.empty() ? "its navigation stays finite; the sum of the "
                                                    "residuals overflowed"
                                                  : why));
  }
}

void InsIdentificationProblem::evaluate(std::span<const Eigen::VectorXd> xs,
                                        std::span<double> f_out,
                                        std::span<std::vector<double>> r_out) const {
  score(xs, f_out, r_out);
  require_finite(xs, f_out);
}

void InsIdentificationProblem::score(std::span<const Eigen::VectorXd> xs, std::span<double> f_out,
                                     std::span<std::vector<double>> r_out) const {
  if (f_out.size() != xs.size())
    throw std::invalid_argument("evaluate_batch: " + std::to_string(xs.size()) +
                                " candidates but " + std::to_string(f_out.size()) +
                                " output slots");
  if (!uses_batched_kernel()) {
    // The scalar reference, candidate by candidate (serially or OpenMP across candidates).
    const Eigen::VectorXd* first = xs.data();
    opt::evaluate_each(xs, f_out, options_, [&](const Eigen::VectorXd& x) {
      if (r_out.empty()) return navigation_->fitness(mapping_.to_errors(x), kind_);
      // Candidate i writes only r_out[i]: safe under evaluate_each's OpenMP loop.
      std::vector<double>& r = r_out[static_cast<std::size_t>(&x - first)];
      navigation_->residuals(mapping_.to_errors(x), r);
      return fitness_from_residuals(r, kind_);  // as NavigationProblem::fitness
    });
    return;
  }

  std::vector<SensorErrors> candidates;
  candidates.reserve(xs.size());
  std::vector<std::exception_ptr> errors(xs.size());
  for (std::size_t i = 0; i < xs.size(); ++i) {
    try {
      candidates.push_back(mapping_.to_errors(xs[i]));
    } catch (...) {
      errors[i] = std::current_exception();
      candidates.push_back(mapping_.base());  // scored, then reported as failed
    }
  }
  BatchFitness::Request request;
  request.candidates = candidates;
  request.fitness = f_out;
  request.kind = kind_;
  request.residuals = r_out;
  request.threads = options_.threads();
  std::vector<std::exception_ptr> kernel_errors(xs.size());
  request.errors = kernel_errors;
  kernel_->evaluate(request);
  for (std::size_t i = 0; i < xs.size(); ++i) {
    const std::exception_ptr error = errors[i] ? errors[i] : kernel_errors[i];
    if (!error) continue;
    // As opt::evaluate_each: the lowest failing index, named, the original nested.
    const std::string where = "fitness evaluation failed for candidate " + std::to_string(i) +
                              " at x = " + opt::format_vector(xs[i]) + ": ";
    try {
      std::rethrow_exception(error);
    } catch (const std::exception& e) {
      std::throw_with_nested(opt::EvaluationError(where + e.what()));
    } catch (...) {
      std::throw_with_nested(opt::EvaluationError(where + "unknown exception"));
    }
  }
}

}  // namespace insid
