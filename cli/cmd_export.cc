// insid export: a dataset as KF-GINS text files (import/kf_gins.h), or a campaign's runs for
// IOHanalyzer (bench/iohprofiler.h).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "base/json_reader.h"
#include "base/output_dir.h"
#include "bench/campaign.h"
#include "bench/iohprofiler.h"
#include "cli/cli_util.h"
#include "cli/commands.h"
#include "data/dataset.h"
#include "import/kf_gins.h"

namespace insid::cli {
namespace {
namespace fs = std::filesystem;

struct ExportArgs {
  std::string to, data, campaign, out;
  double sow_offset_s = 0.0;
  std::optional<double> pos_std_m, vel_std_mps;
  bool force = false;
};

// insid export --to iohprofiler: a campaign's runs for IOHanalyzer (bench/iohprofiler.h).
void run_export_iohprofiler(const ExportArgs& args) {
  if (args.campaign.empty())
    throw UsageError("--to iohprofiler needs --campaign DIR (a campaign directory)");
  if (!args.data.empty())
    throw UsageError("--data is for --to kf-gins; --to iohprofiler reads --campaign");
  if (contains_working_directory(args.out))
    throw std::invalid_argument("--out " + args.out + ": the current directory or a parent of it");
  if (!fs::exists(fs::path(args.campaign) / "manifest.json"))
    throw std::invalid_argument("--campaign " + args.campaign +
                                ": no manifest.json (not a "
                                "campaign directory written by insid bench or insid sweep)");
  if (!args.force) {
    // The folders an export writes: one per algorithm label of the campaign.
    const nlohmann::json manifest =
        read_json_file(fs::path(args.campaign) / "manifest.json", "--campaign " + args.campaign);
    const campaign::CampaignConfig config =
        campaign::config_from_manifest(manifest, args.campaign + "/manifest.json");
    OutputKind kind{"an IOHprofiler export", {}};
    for (const campaign::AlgorithmSpec& a : config.algorithms) kind.own_entries.push_back(a.label);
    require_own_or_empty(args.out, kind, "give --force to add the algorithm folders there");
  }
  const campaign::IohExportOutcome outcome = campaign::export_iohprofiler(args.campaign, args.out);
  std::fprintf(stderr,
               "insid export: wrote %d runs in %d .info files (IOHprofiler format, one folder per "
               "algorithm) under %s",
               outcome.runs, outcome.info_files, args.out.c_str());
  if (outcome.missing_runs > 0)
    std::fprintf(stderr, "; %d runs of the campaign have no run file yet and were skipped",
                 outcome.missing_runs);
  std::fprintf(stderr, "\n");
}

void run_export(const ExportArgs& args) {
  if (args.to == "iohprofiler") return run_export_iohprofiler(args);
  if (args.to != "kf-gins") throw UsageError("--to: kf-gins or iohprofiler, got '" + args.to + "'");
  if (args.data.empty()) throw UsageError("--to kf-gins needs --data DIR (a dataset)");
  if (!args.campaign.empty())
    throw UsageError("--campaign is for --to iohprofiler; --to kf-gins reads --data");
  const OutputKind kind{"a KF-GINS export", {"imu.txt", "gnss.txt"}};
  if (contains_working_directory(args.out))
    throw std::invalid_argument("--out " + args.out + ": the current directory or a parent of it");
  if (!args.force)
    require_own_or_empty(args.out, kind, "give --force to add imu.txt and gnss.txt there");
  const Dataset ds = load_dataset(args.data);
  // Standard deviations: given, else the dataset's declared GNSS noise, else stated defaults.
  const double pos_std = args.pos_std_m ? *args.pos_std_m
                         : ds.meta.noise && ds.meta.noise->gnss_pos_sigma_m > 0
                             ? ds.meta.noise->gnss_pos_sigma_m
                             : 0.05;
  const double vel_std = args.vel_std_mps ? *args.vel_std_mps
                         : ds.meta.noise && ds.meta.noise->gnss_vel_sigma_mps > 0
                             ? ds.meta.noise->gnss_vel_sigma_mps
                             : 0.05;
  // Never over the dataset's own files; imu.txt / gnss.txt of others only with --force.
  WriteOptions write_options;
  write_options.replace_foreign = args.force;
  for (const char* name : {"imu.txt", "gnss.txt"}) {
    refuse_replacing_inputs(fs::path(args.out) / name, dataset_input_files(args.data), false);
    check_file_writable(fs::path(args.out) / name, write_options);
  }
  std::filesystem::create_directories(args.out);
  write_file_atomic(fs::path(args.out) / "imu.txt",
                    importers::kf_gins_imu_text(ds, args.sow_offset_s), write_options);
  write_file_atomic(fs::path(args.out) / "gnss.txt",
                    importers::kf_gins_gnss_text(ds, args.sow_offset_s, pos_std, vel_std),
                    write_options);
  std::fprintf(
      stderr,
      "insid export: wrote %s/imu.txt (%zu rows, FRD increments) and gnss.txt (%zu rows, 13 "
      "columns: position, velocity NED, std %.3g m and %.3g m/s); times = t_s + %g s of "
      "week\n",
      args.out.c_str(), ds.imu.size(), ds.gnss.size(), pos_std, vel_std, args.sow_offset_s);
}

}  // namespace

void add_export_command(CLI::App& app) {
  auto a = std::make_shared<ExportArgs>();
  CLI::App* cmd = app.add_subcommand(
      "export",
      "Write an insid dataset in another program's layout (KF-GINS: imu.txt, gnss.txt), or a "
      "campaign's runs in IOHprofiler's format for IOHanalyzer (.info + .dat per algorithm)");
  cmd->add_option("--to", a->to, "target layout: kf-gins (--data) | iohprofiler (--campaign)")
      ->required();
  cmd->add_option("--data", a->data, "dataset directory (--to kf-gins)");
  cmd->add_option("--campaign", a->campaign,
                  "campaign directory of insid bench / sweep (--to iohprofiler)");
  cmd->add_option("--out", a->out, "output directory (new, empty, or a previous export)")
      ->required();
  cmd->add_option("--sow-offset-s", a->sow_offset_s,
                  "added to t_s to give KF-GINS's seconds of week")
      ->check(number_in(0, 604800));
  cmd->add_option("--pos-std-m", a->pos_std_m,
                  "GNSS position std written (default: the dataset's noise block, else 0.05)")
      ->check(number_in(1e-9, 1e6));
  cmd->add_option("--vel-std-mps", a->vel_std_mps,
                  "GNSS velocity std written (default: the dataset's noise block, else 0.05)")
      ->check(number_in(1e-9, 1e6));
  cmd->add_flag("--force", a->force, "write into a --out directory that holds other files");
  cmd->callback([a] { run_export(*a); });
}

}  // namespace insid::cli
