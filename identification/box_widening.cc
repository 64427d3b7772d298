#include "identification/box_widening.h"

#include <algorithm>
#include <cmath>

#include "base/number_text.h"

namespace insid {
namespace {

// The bounds of parameter j that value presses: (lower, upper).
std::pair<bool, bool> pressed(const EstimatedParameter& p, double value_sigma,
                              const BoxWideningOptions& options) {
  const double tol = options.edge_fraction * (p.upper_sigma - p.lower_sigma);
  return {value_sigma <= p.lower_sigma + tol, value_sigma >= p.upper_sigma - tol};
}

double limit_sigma(const EstimatedParameter& p, const SensorGrade& grade) {
  return grade.physical_limit(p.name).limit_si / p.sigma;
}

}  // namespace

std::string BoxWideningOptions::validate() const {
  if (!(edge_fraction > 0.0 && edge_fraction <= 0.25))
    return "box_widening.edge_fraction " + number_text(edge_fraction) + ": must be in (0, 0.25]";
  if (!(growth_of_width > 0.0 && growth_of_width <= 10.0))
    return "box_widening.growth_of_width " + number_text(growth_of_width) + ": must be in (0, 10]";
  if (max_rounds < 1 || max_rounds > 32)
    return "box_widening.max_rounds " + std::to_string(max_rounds) + ": must be in [1, 32]";
  return "";
}

std::vector<BoxWidening> widen_pressed_bounds(std::vector<EstimatedParameter>& estimated,
                                              const Eigen::VectorXd& value_sigma,
                                              const SensorGrade& grade,
                                              const BoxWideningOptions& options, int round) {
  std::vector<BoxWidening> moved;
  for (std::size_t j = 0; j < estimated.size(); ++j) {
    EstimatedParameter& p = estimated[j];
    const auto [low, high] = pressed(p, value_sigma[static_cast<Eigen::Index>(j)], options);
    const double limit = limit_sigma(p, grade);
    const double step = options.growth_of_width * (p.upper_sigma - p.lower_sigma);
    if (high && p.upper_sigma < limit) {
      const double to = std::min(p.upper_sigma + step, limit);
      moved.push_back({round, p.name, "upper", p.upper_sigma, to, to >= limit});
      p.upper_sigma = to;
    }
    if (low && p.lower_sigma > -limit) {
      const double to = std::max(p.lower_sigma - step, -limit);
      moved.push_back({round, p.name, "lower", p.lower_sigma, to, to <= -limit});
      p.lower_sigma = to;
    }
  }
  return moved;
}

std::vector<std::string> pressed_at_physical_limit(const std::vector<EstimatedParameter>& estimated,
                                                   const Eigen::VectorXd& value_sigma,
                                                   const SensorGrade& grade,
                                                   const BoxWideningOptions& options) {
  std::vector<std::string> names;
  for (std::size_t j = 0; j < estimated.size(); ++j) {
    const EstimatedParameter& p = estimated[j];
    const auto [low, high] = pressed(p, value_sigma[static_cast<Eigen::Index>(j)], options);
    const double limit = limit_sigma(p, grade);
    if ((high && p.upper_sigma >= limit) || (low && p.lower_sigma <= -limit))
      names.push_back(p.name);
  }
  return names;
}

std::vector<std::string> beyond_physical_limit(const std::vector<EstimatedParameter>& estimated,
                                               const Eigen::VectorXd& value_sigma,
                                               const SensorGrade& grade) {
  std::vector<std::string> names;
  for (std::size_t j = 0; j < estimated.size(); ++j) {
    const EstimatedParameter& p = estimated[j];
    const double value_si = value_sigma[static_cast<Eigen::Index>(j)] * p.sigma;
    if (std::abs(value_si) > grade.physical_limit(p.name).limit_si) names.push_back(p.name);
  }
  return names;
}

}  // namespace insid
