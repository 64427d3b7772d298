// insid-mems-study (results/mems/): EKF-RTS, LM and a swarm method (DVPIO by default) on the
// windowed fitness over noise seeds of a simulated MEMS flight (identification/mems_study.h): per
// seed and parameter the error and the reported sd; per method and parameter the count within 3 sd,
// the 95 % coverage and the RMS of |error| / sd. Markdown on stdout, one CSV row per seed, method
// and parameter with --csv.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "identification/ekf_rts.h"
#include "identification/grade.h"
#include "identification/mems_study.h"
#include "identification/uncertainty.h"
#include "model/rotation.h"
#include "nav/alignment.h"
#include "nav/fitness.h"
#include "tools/tool_main.h"

namespace {

int mems_study_main(int argc, char** argv) {
  using namespace insid;
  CLI::App app("insid-mems-study: identification of simulated MEMS flights within their sd",
               "insid-mems-study");
  mems_study::Spec spec;
  int seeds = 10;
  double sd_scale = 1.0;
  std::string csv, json_out;
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
  app.add_option("--methods", methods,
                 "any of ekf-rts (the filter's own sd), ekf-rts-reported (as insid identify "
                 "reports it), lm, swarm")
      ->capture_default_str()
      ->check(CLI::IsMember({"ekf-rts", "ekf-rts-reported", "lm", "swarm"}));
  app.add_option("--flight", spec.kind,
                 "rich (five fixed biases) or drone (like the shared ArduPilot quadcopter log: "
                 "50 Hz IMU, 5 Hz GNSS, six biases drawn per seed; identification/mems_study.h)")
      ->capture_default_str()
      ->check(CLI::IsMember({"rich", "drone"}));
  app.add_option("--drone-arw-deg-rth", spec.drone_arw_deg_rth, "drone: IMU white noise")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--drone-vrw-mps-rth", spec.drone_vrw_mps_rth)
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--drone-gnss-vel-sigma-mps", spec.drone_gnss_vel_sigma_mps)
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--drone-gnss-pos-sigma-m", spec.drone_gnss_pos_sigma_m)
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--truth-max-sigma", spec.truth_max_sigma,
                 "drone: biases uniform in +- this many grade sigma")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--box-sigma", spec.box_sigma, "drone: search box +- this many grade sigma")
      ->capture_default_str()
      ->check(CLI::Range(1e-6, 1e6));
  app.add_flag("--noise-in-meta", spec.noise_in_meta,
               "drone: meta.json declares the true noise levels (default: none, as an "
               "imported log)");
  app.add_option("--ekf-param", spec.ekf_params,
                 "KEY=VALUE for ekf-rts-reported's filter (e.g. arw_deg_rth=0.2)");
  app.add_option("--json", json_out, "per seed, method and parameter: every sd's parts (JSON)");
  app.add_flag("--ekf-only", ekf_only, "EKF-RTS only (seconds instead of a minute)");
  app.add_flag("--heading-check", heading_check,
               "per seed: the level+heading attitude's error at the true biases against the "
               "EKF-RTS's modelled heading sd (the z gyro's sd)");
  app.add_option("--csv", csv, "one row per seed, method and parameter");
  tools::parse(app, argc, argv);
  // Names checked before any work (a bad one is a usage error).
  cli::parse_option("--ekf-param", [&] {
    for (const std::string& item : spec.ekf_params) {
      const std::size_t eq = item.find('=');
      bool known = false;
      for (const auto& field : EkfRtsParams::fields())
        known = known || (eq != std::string::npos && field.name == item.substr(0, eq));
      std::size_t used = 0;
      double value = std::nan("");
      try {
        if (eq != std::string::npos) value = std::stod(item.substr(eq + 1), &used);
      } catch (const std::exception&) {
      }
      if (!known || !std::isfinite(value) || used == 0 || eq + 1 + used != item.size())
        throw std::invalid_argument("'" + item +
                                    "': must be KEY=VALUE with a key of EKF-RTS's parameters "
                                    "(identification/ekf_rts.h, EkfRtsParams) and a number");
    }
  });
  cli::parse_option("--flight", [&] {
    if (const std::string error = spec.validate(); !error.empty())
      throw std::invalid_argument(error);
  });
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
  const std::vector<std::string>& names = mems_study::parameter_names(spec);
  const int n_par = static_cast<int>(names.size());
  std::ofstream out;
  if (!csv.empty()) {
    out.open(csv);
    out << "seed,method,parameter,truth_si,estimate_si,sd_si,error_over_sd,flags,wall_s\n";
  }
  if (ekf_only) methods = {"ekf-rts"};
  const int n_methods = static_cast<int>(methods.size());
  std::vector<std::string> labels;
  for (const std::string& m : methods) labels.push_back(m == "swarm" ? spec.swarm : m);
  // Per method, the sd as reported and, where the answer carries its uncertainty report, the
  // sd under the rules it is made of (identification/uncertainty.h): the filter's sd times
  // the fitness misfit (labelled "before": the rule the NIS scaling replaced) and the
  // candidate rules measured against it.
  using Rule = std::function<double(const ParameterUncertainty&, const UncertaintyReport&)>;
  const auto step_si = [](const ParameterUncertainty& p) {
    return p.step_to_optimum_sigma * p.sigma_si;
  };
  const auto not_converged = [](const ParameterUncertainty& p) {
    return std::find(p.flags.begin(), p.flags.end(), "not_converged") != p.flags.end();
  };
  const auto nis_scale = [](const UncertaintyReport& r) {
    return std::sqrt(std::max(r.filter_nis_per_dof.value_or(1.0), 1.0));
  };
  std::vector<std::pair<std::string, Rule>> ekf_rules = {
      {"filter's own sd",
       [](const ParameterUncertainty& p, const UncertaintyReport&) { return *p.sd_filter_si; }},
      {"before: filter x fitness misfit",
       [](const ParameterUncertainty& p, const UncertaintyReport& r) {
         return *p.sd_filter_si * r.sd_scale;
       }},
      {"filter x NIS", [&](const ParameterUncertainty& p,
                           const UncertaintyReport& r) { return *p.sd_filter_si * nis_scale(r); }},
      {"filter x NIS, +step if not_converged",
       [&](const ParameterUncertainty& p, const UncertaintyReport& r) {
         const double sd = *p.sd_filter_si * nis_scale(r);
         return not_converged(p) ? std::hypot(sd, step_si(p)) : sd;
       }},
      {"filter x max(NIS, misfit), +step if not_converged",
       [&](const ParameterUncertainty& p, const UncertaintyReport& r) {
         const double sd = *p.sd_filter_si * std::max(nis_scale(r), r.sd_scale);
         return not_converged(p) ? std::hypot(sd, step_si(p)) : sd;
       }},
      {"filter x NIS, gauss-newton floor if NIS > 4, +step if not_converged",
       [&](const ParameterUncertainty& p, const UncertaintyReport& r) {
         double sd = *p.sd_filter_si * nis_scale(r);
         if (r.filter_nis_per_dof.value_or(1.0) > 4.0)
           sd = std::max(sd, p.sd_gauss_newton_si.value_or(0.0));
         return not_converged(p) ? std::hypot(sd, step_si(p)) : sd;
       }},
      {"max(filter x NIS, gauss-newton)",
       [&](const ParameterUncertainty& p, const UncertaintyReport& r) {
         return std::max(*p.sd_filter_si * nis_scale(r), p.sd_gauss_newton_si.value_or(0.0));
       }},
      {"max(filter x NIS, gauss-newton), +step if not_converged",
       [&](const ParameterUncertainty& p, const UncertaintyReport& r) {
         const double sd =
             std::max(*p.sd_filter_si * nis_scale(r), p.sd_gauss_newton_si.value_or(0.0));
         return not_converged(p) ? std::hypot(sd, step_si(p)) : sd;
       }},
      {"gauss-newton",
       [](const ParameterUncertainty& p, const UncertaintyReport&) {
         return p.sd_gauss_newton_si.value_or(std::nan(""));
       }},
  };
  std::vector<std::pair<std::string, Rule>> fit_rules = {
      {"before: without the step",
       [](const ParameterUncertainty& p, const UncertaintyReport&) {
         return p.sd_without_step_si ? *p.sd_without_step_si : p.sd_si.value_or(std::nan(""));
       }},
  };
  struct Tally {
    int n = 0, within3 = 0, covered = 0, not_converged = 0;
    double z2 = 0.0;
    void add(double err, double sd, bool nc) {
      const double z = err / sd;
      ++n;
      within3 += std::abs(z) <= 3.0;
      covered += std::abs(z) <= kZ95;
      z2 += z * z;
      not_converged += nc;
    }
  };
  // tally[method][rule][parameter]; rule 0 = as reported.
  std::vector<std::vector<std::string>> rule_labels(n_methods);
  std::vector<std::vector<std::vector<Tally>>> tally(n_methods);
  std::vector<double> wall(n_methods, 0.0);
  std::vector<std::int64_t> evaluations(n_methods, 0);
  nlohmann::json records = nlohmann::json::array();
  for (int seed = 1; seed <= seeds; ++seed) {
    const auto data = mems_study::flight(spec, static_cast<std::uint64_t>(seed));
    const Eigen::VectorXd truth = mems_study::truth_si(spec, static_cast<std::uint64_t>(seed));
    for (int m = 0; m < n_methods; ++m) {
      const std::string& method = methods[static_cast<std::size_t>(m)];
      const mems_study::Answer a = method == "ekf-rts" ? mems_study::ekf_rts(data, spec)
                                   : method == "ekf-rts-reported"
                                       ? mems_study::ekf_rts_reported(data, spec)
                                   : method == "lm" ? mems_study::lm_windowed(data, spec)
                                                    : mems_study::swarm_windowed(data, spec);
      wall[m] += a.wall_s;
      evaluations[m] += a.evaluations;
      const std::vector<std::pair<std::string, Rule>>* rules = nullptr;
      if (a.uncertainty) rules = method == "ekf-rts-reported" ? &ekf_rules : &fit_rules;
      if (rule_labels[m].empty()) {
        rule_labels[m].push_back("as reported");
        if (rules)
          for (const auto& r : *rules) rule_labels[m].push_back(r.first);
        tally[m].assign(rule_labels[m].size(), std::vector<Tally>(names.size()));
      }
      for (int k = 0; k < n_par; ++k) {
        const double err = a.estimate_si[k] - truth[k];
        const double sd = sd_scale * a.sd_si[k];
        bool nc = false;
        std::string flags;
        for (const std::string& f : a.flags[static_cast<std::size_t>(k)]) {
          flags += (flags.empty() ? "" : " ") + f;
          nc = nc || f == "not_converged";
        }
        tally[m][0][static_cast<std::size_t>(k)].add(err, sd, nc);
        nlohmann::json rec = {{"seed", seed},
                              {"method", labels[m]},
                              {"parameter", names[static_cast<std::size_t>(k)]},
                              {"truth_si", truth[k]},
                              {"estimate_si", a.estimate_si[k]},
                              {"sd_si", sd},
                              {"flags", flags}};
        if (rules) {
          const ParameterUncertainty& p = a.uncertainty->parameters[static_cast<std::size_t>(k)];
          for (std::size_t r = 0; r < rules->size(); ++r) {
            const double sd_r = (*rules)[r].second(p, *a.uncertainty);
            tally[m][r + 1][static_cast<std::size_t>(k)].add(err, sd_r, nc);
            rec["sd_rules"][(*rules)[r].first] = sd_r;
          }
          rec["step_to_optimum_si"] = step_si(p);
          rec["fitness_misfit_scale"] = a.uncertainty->sd_scale;
          if (a.uncertainty->filter_nis_per_dof)
            rec["filter_nis_per_dof"] = *a.uncertainty->filter_nis_per_dof;
        }
        records.push_back(rec);
        if (out)
          out << seed << "," << labels[m] << "," << names[static_cast<std::size_t>(k)] << ","
              << truth[k] << "," << a.estimate_si[k] << "," << sd << "," << err / sd << "," << flags
              << "," << a.wall_s << "\n";
      }
    }
    std::cerr << "seed " << seed << " done\n";
  }
  if (!json_out.empty()) std::ofstream(json_out) << records.dump(1) << "\n";
  std::printf(
      "| method | sd | parameter | within 3 sd | 95 %% covered | RMS \\|error\\|/sd | "
      "not_converged |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  for (int m = 0; m < n_methods; ++m) {
    for (std::size_t r = 0; r < rule_labels[m].size(); ++r) {
      Tally all;
      for (int k = 0; k < n_par; ++k) {
        const Tally& t = tally[m][r][static_cast<std::size_t>(k)];
        if (r == 0)
          std::printf("| %s | %s | %s | %d/%d | %d/%d | %.3g | %d |\n", labels[m].c_str(),
                      rule_labels[m][r].c_str(), names[static_cast<std::size_t>(k)].c_str(),
                      t.within3, t.n, t.covered, t.n, std::sqrt(t.z2 / t.n), t.not_converged);
        all.n += t.n;
        all.within3 += t.within3;
        all.covered += t.covered;
        all.z2 += t.z2;
        all.not_converged += t.not_converged;
      }
      std::printf("| %s | %s | all | %d/%d | %d/%d (%.1f %%) | %.3g | %d |\n", labels[m].c_str(),
                  rule_labels[m][r].c_str(), all.within3, all.n, all.covered, all.n,
                  100.0 * all.covered / all.n, std::sqrt(all.z2 / all.n), all.not_converged);
    }
    std::printf("| %s | (wall %.1f s, %lld evaluations over %d seeds) | | | | | |\n",
                labels[m].c_str(), wall[m], static_cast<long long>(evaluations[m]), seeds);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return insid::tools::run("insid-mems-study", [&] { return mems_study_main(argc, argv); });
}
