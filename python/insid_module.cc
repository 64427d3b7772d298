// The `insid` Python module (issue 48): insid's identification problem as a batch-evaluated black
// box for the optimisers researchers already use.
//
//   import numpy as np, insid
//   p = insid.Problem(preset="paper", flight_s=300)     # or insid.Problem(data="my_flight_dir")
//   f = p.evaluate(np.zeros((32, p.dimension)))          # (n, d) -> (n,), the batched kernel
//
// A Problem is `insid identify`'s problem on the same data and options (identify_setup: the grade,
// the window, the default parameter set and the gyro bias allowance), in the normalised box
// [-1, 1]^d that insid's own optimizers search; `sigma`, `box_sigma` and `to_si` map it to the
// catalogue's units. Batches are scored by the batched kernel on `threads` OpenMP threads with the
// GIL released; every candidate's value depends on its bits alone (any batch, order or thread
// count). Errors are Python exceptions carrying insid's messages: ValueError for bad arguments
// and arrays, RuntimeError for data insid refuses.
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "data/dataset.h"
#include "identification/identify.h"
#include "identification/ins_problem.h"
#include "identification/search_fitness.h"
#include "identification/uncertainty.h"
#include "scenarios/scenario.h"

namespace py = pybind11;

namespace insid {
namespace {

class PythonProblem {
 public:
  PythonProblem(std::optional<std::string> data, std::optional<std::string> preset,
                std::optional<double> flight_s, std::uint64_t seed,
                std::vector<std::string> estimate, std::string grade,
                std::optional<double> window_s, std::string fitness, int threads) {
    if (data.has_value() == preset.has_value())
      throw std::invalid_argument("insid.Problem: give exactly one of data= and preset=");
    if (threads < 0)
      throw std::invalid_argument("insid.Problem: threads must be >= 0 (0 = all), got " +
                                  std::to_string(threads));
    const SearchFitnessKind kind = kSearchFitnessNames.value(fitness);
    if (data) {
      dataset_ = std::make_shared<const Dataset>(load_dataset(*data));
    } else {
      scenarios::ScenarioOverrides overrides;
      overrides.seed = seed;
      overrides.flight_s = flight_s;
      dataset_ = std::make_shared<const Dataset>(scenarios::simulate_preset(
          *preset, overrides, /*record_truth_in_meta=*/true, std::max(threads, 1)));
    }
    IdentifySpec spec;
    spec.dataset = dataset_;
    spec.data_dir = data.value_or("");
    spec.estimate = std::move(estimate);
    spec.grade = std::move(grade);
    spec.window_s = window_s;
    spec.threads = threads;
    if (std::optional<IdentifySpecError> problem = spec_problem(spec))
      throw std::invalid_argument(std::string("insid.Problem: ") + problem->what());
    setup_ = identify_setup(spec, *dataset_);
    // As identify's search: the gyrocompass feasibility check meets the box's gyro biases.
    setup_.navigation.initial_attitude.gyro_bias_allowance_rad_s =
        gyro_bias_allowance_rad_s(setup_.estimated);
    const auto navigation = std::make_shared<const NavigationProblem>(dataset_, setup_.navigation);
    opt::EvaluatorOptions evaluator;
    evaluator.parallelism = threads == 1 ? opt::Parallelism::kSerial : opt::Parallelism::kOpenMP;
    evaluator.num_threads = threads;
    threads_ = threads;
    exact_ = std::make_unique<InsIdentificationProblem>(
        navigation, ParameterMapping(setup_.estimated), FitnessKind::kEq15, evaluator);
    search_ = std::make_unique<SearchProblem>(*exact_, kind);
  }

  int dimension() const { return exact_->dimension(); }
  std::vector<std::string> names() const {
    std::vector<std::string> out;
    for (const EstimatedParameter& p : setup_.estimated) out.push_back(p.name);
    return out;
  }
  std::vector<double> sigma() const {
    std::vector<double> out;
    for (const EstimatedParameter& p : setup_.estimated) out.push_back(p.sigma);
    return out;
  }
  std::vector<std::pair<double, double>> box_sigma() const {
    std::vector<std::pair<double, double>> out;
    for (const EstimatedParameter& p : setup_.estimated)
      out.emplace_back(p.lower_sigma, p.upper_sigma);
    return out;
  }
  std::vector<double> lower() const {
    const Eigen::VectorXd& v = exact_->bounds().lower;
    return {v.data(), v.data() + v.size()};
  }
  std::vector<double> upper() const {
    const Eigen::VectorXd& v = exact_->bounds().upper;
    return {v.data(), v.data() + v.size()};
  }
  std::string grade() const { return std::string(setup_.grade->name); }
  double window_s() const { return setup_.navigation.window_s; }
  std::string fitness_used() const { return std::string(search_->used()); }

  // X: (n, d) float64, finite. Returns (n,) Eq. 15 values.
  py::array_t<double> evaluate(
      py::array_t<double, py::array::c_style | py::array::forcecast> x) const {
    return evaluate_timed(std::move(x)).first;
  }

  // evaluate() and the seconds the C++ batch call took inside it (python/bench_boundary.py: the
  // cost of the Python boundary, paired in one run).
  std::pair<py::array_t<double>, double> evaluate_timed(
      py::array_t<double, py::array::c_style | py::array::forcecast> x) const {
    const std::vector<Eigen::VectorXd> xs = candidates(x);
    std::vector<double> f(xs.size());
    double seconds = 0.0;
    {
      py::gil_scoped_release release;
      const auto t0 = std::chrono::steady_clock::now();
      search_->evaluate_batch(xs, f);
      seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    return {py::array_t<double>(static_cast<py::ssize_t>(f.size()), f.data()), seconds};
  }

  double call(py::array_t<double, py::array::c_style | py::array::forcecast> x) const {
    if (x.ndim() != 1)
      throw std::invalid_argument("insid.Problem(x): x must be one candidate, shape (" +
                                  std::to_string(dimension()) + ",), got " +
                                  std::to_string(x.ndim()) + " dimensions");
    return evaluate(as_row(x)).at(0);
  }

  // The candidate's estimated effects in SI units, by name.
  std::map<std::string, double> to_si(
      py::array_t<double, py::array::c_style | py::array::forcecast> x) const {
    const Eigen::VectorXd s = exact_->mapping().to_sigma(one_candidate(x, "to_si"));
    std::map<std::string, double> out;
    for (int i = 0; i < dimension(); ++i)
      out[setup_.estimated[static_cast<std::size_t>(i)].name] =
          s[i] * setup_.estimated[static_cast<std::size_t>(i)].sigma;
    return out;
  }

  // How sure the candidate is as an estimate, as `insid identify` reports it (identification/
  // uncertainty.h: Gauss-Newton with `replicas` noise replicas of the flight, on the exact Eq. 15):
  // {"fitness": its exact Eq. 15, "parameters": [{name, estimate, sd, units, flags, ...}]}.
  py::object report(py::array_t<double, py::array::c_style | py::array::forcecast> x,
                    int replicas) const {
    if (replicas < 10)
      throw std::invalid_argument("insid.Problem.report: replicas must be >= 10, got " +
                                  std::to_string(replicas));
    const std::vector<Eigen::VectorXd> xs{one_candidate(x, "report")};
    nlohmann::json j;
    {
      py::gil_scoped_release release;
      UncertaintyOptions options;
      options.replicas = replicas;
      options.criterion = UncertaintyCriterion::kEq15;
      options.threads = threads_;
      const UncertaintyReport u =
          estimate_uncertainty(*exact_, exact_->mapping().to_sigma(xs.front()), options);
      j["parameters"] = u.parameters_json();
      j["fitness"] = search_->exact_fitness(xs).front();
    }
    return py::module_::import("json").attr("loads")(j.dump());
  }

 private:
  // A 1-D candidate as a one-row batch; other arrays as they are.
  static py::array_t<double> as_row(py::array_t<double> x) {
    if (x.ndim() != 1) return x;
    return x.reshape({static_cast<py::ssize_t>(1), x.shape(0)});
  }
  // The one candidate of x (shape (d,) or (1, d)) for `method`.
  Eigen::VectorXd one_candidate(py::array_t<double> x, const char* method) const {
    std::vector<Eigen::VectorXd> xs = candidates(as_row(std::move(x)));
    if (xs.size() != 1)
      throw std::invalid_argument(std::string("insid.Problem.") + method +
                                  ": one candidate at a time");
    return std::move(xs.front());
  }

  std::vector<Eigen::VectorXd> candidates(const py::array_t<double>& x) const {
    const int d = dimension();
    if (x.ndim() != 2 || x.shape(1) != d)
      throw std::invalid_argument(
          "insid.Problem.evaluate: X must have shape (n, " + std::to_string(d) + "), got " +
          (x.ndim() == 2
               ? "(" + std::to_string(x.shape(0)) + ", " + std::to_string(x.shape(1)) + ")"
               : std::to_string(x.ndim()) + " dimensions"));
    std::vector<Eigen::VectorXd> xs(static_cast<std::size_t>(x.shape(0)), Eigen::VectorXd(d));
    const auto a = x.unchecked<2>();
    for (py::ssize_t n = 0; n < x.shape(0); ++n)
      for (int i = 0; i < d; ++i) {
        const double v = a(n, i);
        if (!std::isfinite(v))
          throw std::invalid_argument("insid.Problem.evaluate: X[" + std::to_string(n) + ", " +
                                      std::to_string(i) + "] is not finite");
        xs[static_cast<std::size_t>(n)][i] = v;
      }
    return xs;
  }

  std::shared_ptr<const Dataset> dataset_;
  IdentifySetup setup_;
  std::unique_ptr<InsIdentificationProblem> exact_;
  std::unique_ptr<SearchProblem> search_;
  int threads_ = 0;
};

}  // namespace
}  // namespace insid

PYBIND11_MODULE(insid, m) {
  m.doc() =
      "insid: the INS error identification problem (Eq. 15 of Li, Deng & Liu 2022) as a "
      "batch-evaluated black box";
  py::class_<insid::PythonProblem>(m, "Problem",
                                   "insid identify's problem on a dataset directory or a "
                                   "simulated preset, in the normalised box [-1, 1]^d")
      .def(py::init<std::optional<std::string>, std::optional<std::string>, std::optional<double>,
                    std::uint64_t, std::vector<std::string>, std::string, std::optional<double>,
                    std::string, int>(),
           py::kw_only(), py::arg("data") = py::none(), py::arg("preset") = py::none(),
           py::arg("flight_s") = py::none(), py::arg("seed") = 1,
           py::arg("estimate") = std::vector<std::string>{}, py::arg("grade") = "auto",
           py::arg("window_s") = py::none(), py::arg("fitness") = "exact", py::arg("threads") = 0)
      .def_property_readonly("dimension", &insid::PythonProblem::dimension)
      .def_property_readonly("names", &insid::PythonProblem::names)
      .def_property_readonly("sigma", &insid::PythonProblem::sigma,
                             "SI value of one sigma of each parameter")
      .def_property_readonly("box_sigma", &insid::PythonProblem::box_sigma,
                             "each parameter's box in sigma units")
      .def_property_readonly("lower", &insid::PythonProblem::lower)
      .def_property_readonly("upper", &insid::PythonProblem::upper)
      .def_property_readonly("grade", &insid::PythonProblem::grade)
      .def_property_readonly("window_s", &insid::PythonProblem::window_s)
      .def_property_readonly("fitness", &insid::PythonProblem::fitness_used,
                             "what scores the candidates: exact (the kernel) or fast")
      .def("evaluate", &insid::PythonProblem::evaluate, py::arg("X"),
           "Eq. 15 of each row of X, shape (n, d) -> (n,)")
      .def("_evaluate_timed", &insid::PythonProblem::evaluate_timed, py::arg("X"),
           "evaluate(X) and the seconds of the C++ batch call inside it (for benchmarks)")
      .def("__call__", &insid::PythonProblem::call, py::arg("x"), "Eq. 15 of one candidate")
      .def("report", &insid::PythonProblem::report, py::arg("x"), py::arg("replicas") = 100,
           "how sure x is as an estimate, as insid identify reports it: a dict with its exact "
           "Eq. 15 and per parameter the estimate, sd (Gauss-Newton, noise replicas), units and "
           "flags")
      .def("to_si", &insid::PythonProblem::to_si, py::arg("x"),
           "the candidate's effects in SI units, by name");
}
