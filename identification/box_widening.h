// No answer clipped by its box: when an identification's estimate sits at an edge of
// its search box, the box is widened on that side and the search run again, until no estimate
// is at an edge or the edge is the grade's physical limit (SensorGrade::physical_limit: the
// MEMS datasheet's tolerances, ten sigma for nav and tactical). An estimate at an edge is where
// the box stopped the optimizer, not where the data put it; the optimizer then pays for the
// clipped parameter in another (on the real quadcopter, a 0.55 deg/s gyro x bias clipped at
// 0.40 pushed a wrong-signed 0.8 deg/s into gyro z). Every widening is recorded in the result.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "identification/grade.h"
#include "identification/ins_problem.h"

namespace insid {

struct BoxWideningOptions {
  /// Widen and re-run (`insid identify` without --fixed-box). Off: the box stays as given and an
  /// estimate at its edge keeps the at_box_edge flag.
  bool enabled = true;
  /// An estimate within this fraction of its box's width from a bound presses that bound. Wider
  /// than the uncertainty's at_box_edge (1e-3): a swarm that stopped just inside an edge it
  /// presses against is not trusted either.
  double edge_fraction = 1e-2;
  /// A pressed bound moves out by this fraction of the box's width (0.5: [-4, 4] -> [-4, 8]).
  double growth_of_width = 0.5;
  /// Re-runs at most (each costs one whole search).
  int max_rounds = 8;

  /// "" when valid, else the bad field and value: edge_fraction in (0, 0.25], growth_of_width
  /// in (0, 10], max_rounds in [1, 32].
  std::string validate() const;
};

/// One bound moved.
struct BoxWidening {
  int round = 0;  ///< 1: after the first search
  std::string parameter;
  std::string side;  ///< "lower" | "upper"
  double from_sigma = 0.0;
  double to_sigma = 0.0;
  bool to_physical_limit = false;  ///< the new bound is the grade's limit: no further widening
};

/// Widens, in `estimated`, each bound that `value_sigma` (the estimate, sigma units) presses
/// (BoxWideningOptions::edge_fraction), by growth_of_width of the box's width, but never past
/// the grade's physical limit (limit_si / sigma). A bound already at or beyond the limit stays.
/// Returns what moved (empty: nothing pressed, or only bounds at their limits).
std::vector<BoxWidening> widen_pressed_bounds(std::vector<EstimatedParameter>& estimated,
                                              const Eigen::VectorXd& value_sigma,
                                              const SensorGrade& grade,
                                              const BoxWideningOptions& options, int round);

/// The names of the parameters whose estimate presses a bound at (or beyond) the grade's
/// physical limit: their box cannot widen further.
std::vector<std::string> pressed_at_physical_limit(const std::vector<EstimatedParameter>& estimated,
                                                   const Eigen::VectorXd& value_sigma,
                                                   const SensorGrade& grade,
                                                   const BoxWideningOptions& options);

/// The names of the parameters whose |estimate| (SI) exceeds the grade's physical limit (a box
/// the user set beyond it): a size no unit of the grade has.
std::vector<std::string> beyond_physical_limit(const std::vector<EstimatedParameter>& estimated,
                                               const Eigen::VectorXd& value_sigma,
                                               const SensorGrade& grade);

}  // namespace insid
