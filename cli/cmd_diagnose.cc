// insid diagnose: which catalogue effect explains what the base model leaves in the residuals
// (docs/design.md sec. 9; method in diagnose/README.md).
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "cli/initial_attitude_cli.h"
#include "cli/progress.h"
#include "data/dataset.h"
#include "diagnose/diagnose.h"
#include "identification/grade.h"

namespace insid::cli {
namespace {

struct DiagnoseArgs {
  std::string data_dir;
  std::vector<std::string> base;
  std::vector<std::string> candidates;
  std::string grade = "auto";
  int max_effects = 3;
  std::uint64_t seed = 1;
  std::string out;
  std::string report;
  std::string algorithm = "dvpio";
  int iterations = 20;
  int replicas_basis = 40;
  int replicas_calibration = 80;
  double alpha = 0.05;
  double observable_max_sigma = 30.0;
  std::string alignment = "per-candidate";
  std::optional<double> window_s;  ///< absent: the grade's default (settle_grade_and_window)
  InitialAttitudeArgs initial_attitude;
  int threads = 0;
  Verbosity verbosity = Verbosity::kNormal;
  bool no_plots = false;
  bool fixed_box = false;
  bool gyro_bias_at_rest = false;
  bool force = false;
};

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

void run(const DiagnoseArgs& a) {
  namespace fs = std::filesystem;
  // The outputs are checked before the work: never an input, a file of others only with --force.
  const OutputGuard guard{dataset_input_files(a.data_dir), a.force};
  if (!a.report.empty()) {
    const fs::path md = fs::absolute(a.report);
    const std::string stem = (md.parent_path() / md.stem()).string();
    check_distinct_outputs({{"--out", a.out},
                            {"--report", md.string()},
                            {"--report's residuals", stem + "_residuals.csv"},
                            {"--report's JSON (no --out)",
                             a.out.empty() || a.out == "-" ? stem + ".json" : std::string()}});
  }
  check_output_file(a.out, guard);
  if (!a.report.empty()) {
    const fs::path md = fs::absolute(a.report);
    check_output_file(md.string(), guard);
    check_output_file((md.parent_path() / (md.stem().string() + "_residuals.csv")).string(), guard);
    if (a.out.empty() || a.out == "-")
      check_output_file((md.parent_path() / (md.stem().string() + ".json")).string(), guard);
  }
  auto dataset = std::make_shared<const Dataset>(load_dataset(a.data_dir));
  const nlohmann::json plausibility = check_dataset_plausibility(*dataset, "insid diagnose");
  diagnose::DiagnoseOptions o;
  // --grade as identify's: every --base NAME without SIGMA gets the grade's sigma.
  const GradeAndWindow settled = settle_grade_and_window(*dataset, a.grade, a.window_s);
  const SensorGrade& grade = sensor_grade(settled.grade.grade);
  o.grade = &grade;
  for (const std::string& b : a.base)
    o.base.push_back(parse_option("--base", [&] { return grade.parameter(b); }));
  for (const std::string& c : a.candidates)  // conflicting options: a usage error
    for (const EstimatedParameter& b : o.base)
      if (b.name == c)
        throw UsageError("--candidates " + c +
                         " is also in --base: a candidate is an effect the "
                         "base model lacks");
  if (a.verbosity != Verbosity::kQuiet) std::cerr << "insid diagnose: " << settled.line() << "\n";
  o.candidates = a.candidates;
  for (const std::string& c : a.candidates)
    if (c != "all") parse_option("--candidates", [&] { return effect_info(c); });
  o.max_effects = a.max_effects;
  o.seed = a.seed;
  o.algorithm = a.algorithm;
  o.optimizer_iterations = a.iterations;
  o.replicas_basis = a.replicas_basis;
  o.replicas_calibration = a.replicas_calibration;
  o.alpha = a.alpha;
  o.observable_max_sigma = a.observable_max_sigma;
  o.alignment =
      parse_option("--alignment", [&] { return alignment_mode_from_string(a.alignment); });
  o.window_s = settled.window_s;
  o.initial_attitude = initial_attitude_options(a.initial_attitude);
  o.threads = a.threads;
  o.base_widening.enabled = !a.fixed_box;
  o.gyro_bias_at_rest = a.gyro_bias_at_rest;
  // The diagnosis prints plain timed lines, one per step (never '\r'); --verbose adds nothing.
  o.progress = a.verbosity != Verbosity::kQuiet;
  diagnose::DiagnoseResult res = diagnose::run_diagnose(dataset, o);
  res.report["data"] = a.data_dir;
  res.report["plausibility"] = plausibility;
  res.report.update(settled.to_json());
  write_json_output(a.out, res.report, guard);
  if (a.report.empty()) return;

  const fs::path md_path = fs::absolute(a.report);
  const fs::path dir = md_path.parent_path();
  if (!dir.empty()) fs::create_directories(dir);
  const std::string stem = md_path.stem().string();
  const fs::path csv = dir / (stem + "_residuals.csv");
  write_output_file(csv.string(), diagnose::series_csv_text(res.series), guard);
  // The JSON next to the report (the plots read it), unless --out already is there.
  fs::path json_path = a.out.empty() || a.out == "-" ? dir / (stem + ".json") : fs::path(a.out);
  if (a.out.empty() || a.out == "-") write_json_output(json_path.string(), res.report, guard);

  std::string prefix;
  if (!a.no_plots) {
    // INSID_SCRIPTS_DIR, else the copy the build puts next to the binary (cli/CMakeLists.txt):
    // the binary embeds no source-tree path.
    const char* env = std::getenv("INSID_SCRIPTS_DIR");
    std::error_code exe_error;
    const fs::path exe = fs::read_symlink("/proc/self/exe", exe_error);
    const fs::path script = (env         ? fs::path(env)
                             : exe_error ? fs::path(".")
                                         : exe.parent_path()) /
                            "diagnose_plots.py";
    // Debian's python3 (with matplotlib) first; INSID_PYTHON overrides.
    const char* py_env = std::getenv("INSID_PYTHON");
    const std::string python =
        py_env ? py_env : (fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3");
    const std::string cmd = shell_quote(python) + " " + shell_quote(script.string()) +
                            " --report " + shell_quote(json_path.string()) + " --series " +
                            shell_quote(csv.string()) + " --prefix " +
                            shell_quote((dir / stem).string());
    if (fs::exists(script) && std::system(cmd.c_str()) == 0)
      prefix = stem;
    else
      std::cerr << "insid diagnose: figures not made (" << script.string()
                << " missing or failed); report.md has the tables only\n";
  }
  write_output_file(md_path.string(), diagnose::report_markdown(res.report, prefix), guard);
}

}  // namespace

void add_diagnose_command(CLI::App& app) {
  auto a = std::make_shared<DiagnoseArgs>();
  CLI::App* cmd = app.add_subcommand(
      "diagnose",
      "Find the missing effect: fit the base model, score every catalogue effect on what the "
      "base model cannot absorb (GLS against a noise model calibrated on noise replicas of the "
      "same flight), add the most significant one, re-fit, repeat; report the gap to the noise "
      "floor before and after. Method: diagnose/README.md.");
  cmd->add_option("--data", a->data_dir, "dataset directory (insid-dataset/1)")->required();
  cmd->add_option("--base", a->base,
                  "base model NAME[:SIGMA[:LO:HI]] ...; default: the grade's (nav: the paper's "
                  "four)");
  cmd->add_option("--candidates", a->candidates,
                  "candidate effects NAME ... or 'all' (default: every catalogue effect not in "
                  "the base)");
  cmd->add_option("--grade", a->grade,
                  "sensor grade auto | nav | tactical | mems, as identify's: the sigma of every "
                  "--base NAME without SIGMA and of every candidate, and the default base (nav: "
                  "the paper's four; tactical, mems: also gyro_bias_z); auto: from meta.json's "
                  "noise block, else from the static window's measured noise and gyro bias "
                  "(identification/grade.h, choose_grade), recorded as grade_choice")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "nav", "tactical", "mems"}));
  cmd->add_option("--max-effects", a->max_effects, "most effects added")
      ->capture_default_str()
      ->check(whole_in(1, 100));
  cmd->add_option("--seed", a->seed, "seed (optimizer, noise replicas)")
      ->capture_default_str()
      ->check(seed_value());
  cmd->add_option("--out", a->out, "report JSON (default: stdout)");
  cmd->add_option("--report", a->report,
                  "report.md with figures (PNG next to it, via scripts/diagnose_plots.py)");
  cmd->add_option("--algo", a->algorithm, "base-fit optimizer: ga | pso | pio | dvpio | none")
      ->capture_default_str();
  cmd->add_option("--iterations", a->iterations, "optimizer iterations for the base fit")
      ->capture_default_str()
      ->check(whole_in(1, 10000000));
  cmd->add_option("--replicas-basis", a->replicas_basis,
                  "noise replicas building the working covariance")
      ->capture_default_str()
      ->check(whole_in(2, 100000));
  cmd->add_option("--replicas-calibration", a->replicas_calibration,
                  "noise replicas calibrating the statistics and threshold")
      ->capture_default_str()
      ->check(whole_in(2, 100000));
  cmd->add_option("--alpha", a->alpha, "family-wise false-alarm rate per iteration")
      ->capture_default_str()
      ->check(number_in(1e-9, 0.5));
  cmd->add_option("--observable-max-sigma", a->observable_max_sigma,
                  "a candidate whose minimum detectable size exceeds this many catalogue sigmas "
                  "is reported not observable")
      ->capture_default_str()
      ->check(number_in(1e-9, 1e9));
  cmd->add_option("--alignment", a->alignment, "per-candidate | fixed")->capture_default_str();
  cmd->add_option("--window-s", a->window_s, kWindowWithDefaultHelp)
      ->check(number_in(0.0, kMaxWindowS));
  add_initial_attitude_options(cmd, a->initial_attitude);
  cmd->add_option("--threads", a->threads, "OpenMP threads (0 = all)")
      ->capture_default_str()
      ->check(whole_in(0, kMaxThreads));
  add_verbosity_flags(cmd, a->verbosity);
  cmd->add_flag("--no-plots", a->no_plots, "report.md without figures");
  cmd->add_flag("--gyro-bias-at-rest", a->gyro_bias_at_rest,
                "measure the gyro biases as the static window's mean rate less the Earth rate "
                "(nav/gyro_at_rest.h) in every model instead of fitting them; the window must "
                "end before the motors start. Needs --initial-attitude level+heading or given");
  cmd->add_flag("--fixed-box", a->fixed_box,
                "keep the base's box as given. Default: a base parameter pressing its box is "
                "widened (as identify's, up to the grade's physical limits) and the wider fit "
                "kept when it explains more (recorded in base_fit_procedure.box_widening)");
  add_output_force_flag(cmd, &a->force);
  cmd->callback([a] { run(*a); });
}

}  // namespace insid::cli
