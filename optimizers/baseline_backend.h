// The pagmo2 and Ceres code of the reference baselines, in a shared library of its own
// (insid_baseline_backend) with an interface free of Eigen types.
//
// Why: insid is built with -march=native, where Eigen aligns heap arrays to 64 bytes and frees
// them with its own aligned free; the Debian builds of pagmo and Ceres use the default 16 bytes
// and plain malloc. Objects with Eigen members created inside those libraries (pagmo::cmaes's
// state) and destroyed in insid code crash, and inline Eigen functions compiled both ways would
// be merged by the linker. This library is compiled for generic x86-64 like the Debian packages,
// with hidden symbols (only this interface is exported), so neither can happen.
// Internal to optimizers/ (pagmo_algorithms.cc, ceres_lm.cc).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#define INSID_BACKEND_API __attribute__((visibility("default")))

namespace insid::opt::backend {

using Vec = std::vector<double>;

/// A pagmo population-based algorithm advanced one generation at a time (see pagmo_algorithms.cc
/// for the record / replay design).
class INSID_BACKEND_API GenerationalAlgorithm {
 public:
  virtual ~GenerationalAlgorithm();
  /// The initial population and its fitness.
  virtual void initialize(const std::vector<Vec>& x, const Vec& f) = 0;
  /// The points of the next generation (does not change the state).
  virtual std::vector<Vec> propose() = 0;
  /// Their fitness, in order: evolves the state by that generation. Throws std::logic_error if
  /// pagmo asks for other points than those proposed.
  virtual void tell(const Vec& f) = 0;
};

struct CmaesSettings {
  double cc = -1, cs = -1, c1 = -1, cmu = -1, sigma0 = 0.5;
  bool force_bounds = true;
};
struct DeSettings {
  double F = 0.8, CR = 0.9;
  unsigned variant = 2;
};

INSID_BACKEND_API std::unique_ptr<GenerationalAlgorithm> make_cmaes(const CmaesSettings& s,
                                                                    const Vec& lower,
                                                                    const Vec& upper,
                                                                    unsigned seed);
INSID_BACKEND_API std::unique_ptr<GenerationalAlgorithm> make_de(const DeSettings& s,
                                                                 const Vec& lower, const Vec& upper,
                                                                 unsigned seed);

/// One pagmo compass search from (x0, f0) until its step falls below stop_range. `fitness`
/// returns false when the run has ended (the search is then abandoned and this returns false);
/// returns true when the search ended on its own.
INSID_BACKEND_API bool compass_search(const Vec& x0, double f0, const Vec& lower, const Vec& upper,
                                      double start_range, double stop_range, double reduction_coeff,
                                      unsigned seed,
                                      const std::function<bool(const Vec& x, double& f)>& fitness);

struct LmSettings {
  double fd_step = 2.5e-4;
  int max_iterations = 50;
  double parameter_tolerance = 1e-10;
  double function_tolerance = 1e-12;
  double gradient_tolerance = 1e-16;
};

/// Evaluates the residual vectors of `points` (false: the run has ended). `label` is
/// "jacobian" or "step".
using ResidualEvaluator = std::function<bool(
    const std::vector<Vec>& points, std::vector<Vec>& residuals, const std::string& label)>;

/// One Ceres Levenberg-Marquardt start from x0 whose residual vector r0 is known (see
/// ceres_lm.cc). Returns false when the run ended (an evaluation returned false), true when
/// Ceres stopped on its own.
INSID_BACKEND_API bool ceres_lm(const Vec& x0, const Vec& r0, const Vec& lower, const Vec& upper,
                                const LmSettings& settings, const ResidualEvaluator& evaluate);

}  // namespace insid::opt::backend
