// insid-mems-study (results/mems/): EKF-RTS, LM and a swarm method (DVPIO by default) on the
// windowed fitness over noise seeds of a simulated MEMS flight (identification/mems_study.h): per
// seed and parameter the error and the reported sd; per method and parameter the count within 3 sd,
// the 95 % coverage and the RMS of |error| / sd. Markdown on stdout, one CSV row per seed, method
// and parameter with --csv.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "core/alignment.h"
#include "core/fitness.h"
#include "core/rotation.h"
#include "identification/ekf_rts.h"
#include "identification/grade.h"
#include "identification/mems_study.h"
#include "tools/tool_main.h"

namespace {

int mems_study_main(int argc, char** argv) {
  using namespace insid;
  CLI::App app("insid-mems-study: identification of simulated MEMS flights within their sd",
               "insid-mems-study");
  mems_study::Spec spec;
  int seeds = 10;
  double sd_scale = 1.0;
  std::string csv;
  bool ekf_only = false;
  bool heading_check = false;
  std::vector<std::string> methods = {"ekf-rts", "lm", "swarm"};
  app.add_option("--seeds", seeds, "noise seeds 1..N")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--flight-s", spec.flight_s)->capture_default_str()->check(CLI::Range(10.0, 1e5));
  app.add_option("--align-s", spec.align_s)->capture_default_str()->check(CLI::Range(1.0, 1e4));
  app.add_option("--window-s", spec.window_s)->capture_default_str()->check(CLI::Range(0.0, 1e5));
  app.add_option("--replicas", spec.replicas)->capture_default_str()->check(CLI::Range(10, 100000));
  app.add_option("--threads", spec.threads)->capture_default_str()->check(CLI::Range(0, 1024));
  app.add_option("--ekf-passes", spec.ekf_passes)->capture_default_str()->check(CLI::Range(1, 20));
  app.add_option("--ekf-update-interval-s", spec.ekf_update_interval_s)->capture_default_str();
  app.add_option("--ekf-attitude", spec.ekf_attitude)->capture_default_str();
  app.add_option("--ekf-propagation-interval-s", spec.ekf_propagation_interval_s)
      ->capture_default_str()
      ->check(CLI::Range(1e-4, 10.0));
  app.add_option("--ekf-use-position", spec.ekf_use_position)
      ->capture_default_str()
      ->check(CLI::Range(0, 1));
  app.add_option("--sd-scale", sd_scale, "multiply the reported sd (a broken sd, for checks)")
      ->capture_default_str();
  app.add_option("--swarm", spec.swarm, "swarm method of the registry (the `swarm` rows)")
      ->capture_default_str();
  app.add_option("--swarm-evaluations", spec.swarm_evaluations, "its budget")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000000));
  app.add_option("--swarm-seed", spec.swarm_seed)->capture_default_str();
  app.add_option("--methods", methods, "any of ekf-rts, lm, swarm")
      ->capture_default_str()
      ->check(CLI::IsMember({"ekf-rts", "lm", "swarm"}));
  app.add_flag("--ekf-only", ekf_only, "EKF-RTS only (seconds instead of a minute)");
  app.add_flag("--heading-check", heading_check,
               "per seed: the level+heading attitude's error at the true biases against the "
               "EKF-RTS's modelled heading sd (issue 14, the z gyro's sd)");
  app.add_option("--csv", csv, "one row per seed, method and parameter");
  tools::parse(app, argc, argv);
  register_ekf_rts();
  // Names checked before any work (a bad one is a usage error).
  cli::parse_option("--ekf-attitude", [&] {
    try {
      return initial_attitude_mode_from_string(spec.ekf_attitude);
    } catch (const std::invalid_argument& e) {  // it names insid's --initial-attitude
      const std::string what = e.what(), theirs = "--initial-attitude";
      throw std::invalid_argument(what.rfind(theirs, 0) == 0
                                      ? "--ekf-attitude" + what.substr(theirs.size())
                                      : "--ekf-attitude: " + what);
    }
  });
  cli::parse_option("--swarm", [&] { tools::check_algorithm(spec.swarm); });
  if (heading_check) {
    // The initial attitude's own error w of phi0 = G db + w (identification/ekf_rts.cc): the
    // level+heading attitude with the TRUE biases compensated, against the simulated truth.
    SensorErrors truth_errors;
    for (std::size_t k = 0; k < 5; ++k)
      set_effect(truth_errors, mems_study::parameter_names()[k],
                 mems_study::truth_si()[static_cast<Eigen::Index>(k)]);
    double sum_ratio2 = 0.0;
    std::printf(
        "| seed | heading error (deg) | tilt error x, y (deg) | modelled heading sd (deg) | "
        "ratio |\n|---|---|---|---|---|\n");
    for (int seed = 1; seed <= seeds; ++seed) {
      const auto data = mems_study::flight(spec, static_cast<std::uint64_t>(seed));
      NavigationOptions lh, truth;
      lh.initial_attitude.mode = InitialAttitudeMode::kLevelHeading;
      truth.initial_attitude.mode = InitialAttitudeMode::kTruth;
      const NavigationProblem p_lh(data, lh), p_truth(data, truth);
      const Eigen::Matrix3d dC =
          p_lh.initial_attitude(truth_errors) * p_truth.initial_attitude(truth_errors).transpose();
      const Eigen::Matrix3d A = 0.5 * (dC - dC.transpose());
      const Eigen::Vector3d phi(A(2, 1), A(0, 2), A(1, 0));  // nav frame (NED), rad
      std::optional<EkfRtsGradeSetup> setup = ekf_grade_setup(p_lh, grade_for(*data));
      setup->passes = spec.ekf_passes;
      const EkfRtsResult r = run_ekf_rts(p_lh, EkfRtsParams{}, SensorErrors{}, setup);
      const double ratio = phi.z() / r.initial_heading_sd_rad;
      sum_ratio2 += ratio * ratio;
      std::printf("| %d | %.4f | %.4f, %.4f | %.4f | %.2f |\n", seed, phi.z() / kDegToRad,
                  phi.x() / kDegToRad, phi.y() / kDegToRad, r.initial_heading_sd_rad / kDegToRad,
                  ratio);
    }
    std::printf("RMS heading error / modelled sd: %.3g over %d seeds\n",
                std::sqrt(sum_ratio2 / seeds), seeds);
    return 0;
  }

  constexpr double kZ95 = 1.959963984540054;
  const auto& names = mems_study::parameter_names();
  const Eigen::VectorXd truth = mems_study::truth_si();
  std::ofstream out;
  if (!csv.empty()) {
    out.open(csv);
    out << "seed,method,parameter,truth_si,estimate_si,sd_si,error_over_sd,flags,wall_s\n";
  }
  if (ekf_only) methods = {"ekf-rts"};
  const int n_methods = static_cast<int>(methods.size());
  std::vector<std::string> labels;
  for (const std::string& m : methods) labels.push_back(m == "swarm" ? spec.swarm : m);
  std::vector<std::vector<int>> within3(n_methods, std::vector<int>(5, 0)), covered = within3,
                                                                            not_converged = within3;
  std::vector<std::vector<double>> z2(n_methods, std::vector<double>(5, 0.0));
  std::vector<double> wall(n_methods, 0.0);
  std::vector<std::int64_t> evaluations(n_methods, 0);
  for (int seed = 1; seed <= seeds; ++seed) {
    const auto data = mems_study::flight(spec, static_cast<std::uint64_t>(seed));
    for (int m = 0; m < n_methods; ++m) {
      const std::string& method = methods[static_cast<std::size_t>(m)];
      const mems_study::Answer a = method == "ekf-rts" ? mems_study::ekf_rts(data, spec)
                                   : method == "lm"    ? mems_study::lm_windowed(data, spec)
                                                       : mems_study::swarm_windowed(data, spec);
      wall[m] += a.wall_s;
      evaluations[m] += a.evaluations;
      for (int k = 0; k < 5; ++k) {
        const double err = a.estimate_si[k] - truth[k];
        const double sd = sd_scale * a.sd_si[k];
        const double z = err / sd;
        within3[m][k] += std::abs(z) <= 3.0;
        covered[m][k] += std::abs(z) <= kZ95;
        z2[m][k] += z * z;
        std::string flags;
        for (const std::string& f : a.flags[k]) {
          flags += (flags.empty() ? "" : " ") + f;
          not_converged[m][k] += f == "not_converged";
        }
        if (out)
          out << seed << "," << labels[m] << "," << names[k] << "," << truth[k] << ","
              << a.estimate_si[k] << "," << sd << "," << z << "," << flags << "," << a.wall_s
              << "\n";
      }
    }
    std::cerr << "seed " << seed << " done\n";
  }
  std::printf(
      "| method | parameter | within 3 sd | 95 %% covered | RMS \\|error\\|/sd | not_converged "
      "|\n");
  std::printf("|---|---|---|---|---|---|\n");
  for (int m = 0; m < n_methods; ++m) {
    int total3 = 0, total95 = 0, total_nc = 0;
    for (int k = 0; k < 5; ++k) {
      std::printf("| %s | %s | %d/%d | %d/%d | %.3g | %d |\n", labels[m].c_str(), names[k].c_str(),
                  within3[m][k], seeds, covered[m][k], seeds, std::sqrt(z2[m][k] / seeds),
                  not_converged[m][k]);
      total3 += within3[m][k];
      total95 += covered[m][k];
      total_nc += not_converged[m][k];
    }
    std::printf(
        "| %s | all | %d/%d | %d/%d | (wall %.1f s, %lld evaluations over %d seeds) | %d |\n",
        labels[m].c_str(), total3, 5 * seeds, total95, 5 * seeds, wall[m],
        static_cast<long long>(evaluations[m]), seeds, total_nc);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return insid::tools::run("insid-mems-study", [&] { return mems_study_main(argc, argv); });
}
