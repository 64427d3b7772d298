// insid-window-study: the windowed fitness's trade-off table (results/window/).
//   insid-window-study [--grades mems,nav] [--windows 5,10,20,40,80,0] [--seeds 3]
//                      [--flight-s 300] [--threads 2] [--csv FILE]
//                      [--set-up fixed-given|grade]
// For each grade, seed and window length W (0 = one run): the Eq. 15 optimum of the paper's four
// biases found by a local fit started at the truth, the one started at the box centre, a PSO run
// at the paper's budget, and the Gauss-Newton sd at the optimum (identification/window_study.h).
// --set-up: fixed-given (the default, the first tables: attitude aligned once, biases after the
// 600 s window) or grade (the alignment each grade uses: nav gyrocompass, mems level+heading with
// a 30 s static window and gyro_bias_z estimated too; window_study::SetUp).
// Prints a markdown table of the medians over seeds (stdout) and writes every row to the CSV.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "identification/window_study.h"
#include "tools/tool_main.h"

namespace {

// dAx, dAy, dDx, dDy, dDz: the paper's names of the biases.
std::string short_name(const std::string& name) {
  if (name == "accel_bias_x") return "dAx";
  if (name == "accel_bias_y") return "dAy";
  if (name == "gyro_bias_x") return "dDx";
  if (name == "gyro_bias_y") return "dDy";
  if (name == "gyro_bias_z") return "dDz";
  return name;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

int window_study_main(int argc, char** argv) {
  using namespace insid;
  CLI::App app{"insid-window-study: the windowed fitness's trade-off table (results/window/)",
               "insid-window-study"};
  std::vector<std::string> grades = {"mems", "nav"};
  std::vector<double> windows = {5, 10, 20, 40, 80, 0};
  int seeds = 3, threads = 2;
  double flight_s = 300.0;
  std::string csv_path;
  std::string set_up_text = "fixed-given";
  app.add_option("--grades", grades, "noise grades, comma-separated: mems, nav")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--windows", windows, "window lengths W (s), comma-separated (0 = one run)")
      ->delimiter(',')
      ->check(tools::finite_number())
      ->capture_default_str();
  app.add_option("--seeds", seeds, "noise seeds 1..N")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--flight-s", flight_s, "flight after the alignment (s)")
      ->check(tools::finite_number())
      ->capture_default_str();
  app.add_option("--threads", threads)->check(CLI::Range(0, 4096))->capture_default_str();
  app.add_option("--set-up", set_up_text,
                 "fixed-given (attitude aligned once, biases after the 600 s window) | grade "
                 "(the alignment each grade uses)")
      ->capture_default_str();
  app.add_option("--csv", csv_path, "every row of the table, per seed");
  tools::parse(app, argc, argv);
  // The names the study knows, checked before any work (window_study.h).
  const window_study::SetUp set_up =
      cli::parse_option("--set-up", [&] { return window_study::set_up_from_string(set_up_text); });
  for (const std::string& name : grades)
    cli::parse_option("--grades", [&] { return window_study::grade(name); });
  std::ofstream csv;
  if (!csv_path.empty()) {
    csv.open(csv_path);
    if (!csv) throw std::runtime_error("cannot write " + csv_path);
  }
  bool header_done = false;
  std::string printed_names;
  for (const std::string& name : grades) {
    const window_study::Grade g = window_study::grade(name);
    const ParameterMapping m = window_study::mapping(g, set_up);
    const Eigen::VectorXd truth = window_study::truth_sigma(g, set_up);
    const int n = m.dimension();
    std::vector<std::string> shorts;
    std::string names;
    for (const EstimatedParameter& p : m.parameters()) {
      shorts.push_back(short_name(p.name));
      if (!names.empty()) names += ", ";
      names += shorts.back();
    }
    if (csv && !header_done) {
      // One header for every grade: with --set-up grade, mems adds dDz (nav rows leave it empty).
      std::vector<std::string> all = {"dAx", "dAy", "dDx", "dDy"};
      if (set_up == window_study::SetUp::kGradeAlignment) all.push_back("dDz");
      csv << "grade,seed,window_s,windows,fitness_optimum,fitness_from_centre";
      for (const std::string& p : all)
        csv << ",err_" << p << "_sigma,err_centre_" << p << "_sigma,gn_sd_" << p << "_sigma";
      csv << ",pso_max_err_sigma\n";
      header_done = true;
    }
    if (names != printed_names) {
      std::printf(
          "| grade | W (s) | windows | GN sd %s (sigma) | "
          "|optimum - truth| %s (sigma) | "
          "|fit from centre - truth| max (sigma) | |PSO 10x40 - truth| max (sigma) |\n"
          "|---|---|---|---|---|---|---|\n",
          names.c_str(), names.c_str());
      printed_names = names;
    }
    std::vector<std::shared_ptr<const Dataset>> flights;
    for (int s = 1; s <= seeds; ++s)
      flights.push_back(window_study::flight(g, flight_s, static_cast<std::uint64_t>(s), set_up));
    for (double w : windows) {
      std::vector<std::vector<double>> sd(static_cast<std::size_t>(n)),
          err(static_cast<std::size_t>(n));
      std::vector<double> centre_err, pso_err;
      std::size_t n_windows = 0;
      for (int s = 1; s <= seeds; ++s) {
        const window_study::WindowFit f =
            window_study::fit_window(flights[static_cast<std::size_t>(s - 1)], g, w, threads,
                                     static_cast<std::uint64_t>(s), set_up);
        n_windows = f.windows;
        const Eigen::VectorXd e = f.optimum_sigma - truth;
        const Eigen::VectorXd ec = f.from_centre_sigma - truth;
        for (int k = 0; k < n; ++k) {
          sd[static_cast<std::size_t>(k)].push_back(f.gn_sd_sigma[k]);
          err[static_cast<std::size_t>(k)].push_back(std::abs(e[k]));
        }
        centre_err.push_back(ec.cwiseAbs().maxCoeff());
        pso_err.push_back((f.pso_sigma - truth).cwiseAbs().maxCoeff());
        if (csv) {
          csv << name << "," << s << "," << w << "," << f.windows << "," << f.fitness_optimum << ","
              << f.fitness_from_centre;
          for (int k = 0; k < n; ++k) csv << "," << e[k] << "," << ec[k] << "," << f.gn_sd_sigma[k];
          if (set_up == window_study::SetUp::kGradeAlignment && n == 4) csv << ",,,";
          csv << "," << (f.pso_sigma - truth).cwiseAbs().maxCoeff() << "\n";
        }
        std::cerr << "insid-window-study: " << name << " seed " << s << " W " << w << " done\n";
      }
      std::string sds, errs;
      char buf[32];
      for (int k = 0; k < n; ++k) {
        std::snprintf(buf, sizeof buf, "%.3g", median(sd[static_cast<std::size_t>(k)]));
        if (k) sds += ", ";
        sds += buf;
        std::snprintf(buf, sizeof buf, "%.3g", median(err[static_cast<std::size_t>(k)]));
        if (k) errs += ", ";
        errs += buf;
      }
      std::printf("| %s | %g | %zu | %s | %s | %.3g | %.3g |\n", name.c_str(), w, n_windows,
                  sds.c_str(), errs.c_str(), median(centre_err), median(pso_err));
      std::fflush(stdout);
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return insid::tools::run("insid-window-study", [&] { return window_study_main(argc, argv); });
}
