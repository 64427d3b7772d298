// A campaign's runs in IOHprofiler's data format, for IOHanalyzer:
// `insid export --to iohprofiler --campaign DIR --out DIR2`.
//
// Mapping (results/README.md, "IOHprofiler export"):
//   algorithm -> one folder DIR2/<label>/ (IOHanalyzer loads a folder per algorithm);
//   function  -> a scenario: funcId = its position in the config (1-based), funcName = its name;
//   instance  -> the scenario's noise seed (data_seed);
//   DIM       -> the number of estimated parameters;
//   run       -> one optimizer seed (a block of the .dat file, in config seed order);
//   f(x)      -> the Eq. 15 fitness, minimised (maximization = F), as the search saw it: the
//                best-so-far curves of the campaign's search fitness (config "fitness"; the run
//                files' result.fitness is the exact kernel's Eq. 15 of the best point).
// Files, following IOHanalyzer's documented format (inst/shiny-server/markdown/dataformat.md):
//   DIR2/<label>/IOHprofiler_f<fid>_i<instance>.info, three lines:
//     suite = 'insid', funcId = 1, funcName = 'rich-short', DIM = 4, maximization = F,
//       algId = 'PSO', algInfo = 'pso population=10 w=0.8 c1=2 c2=2 v_max_fraction=0.2'
//     % <comment: campaign, fitness, what instance and runs mean>
//     data_f<fid>/IOHprofiler_f<fid>_DIM<n>_i<instance>.dat, <inst>:<evaluations>|<best f>, ...
//   DIR2/<label>/data_f<fid>/IOHprofiler_f<fid>_DIM<n>_i<instance>.dat, the two-column format:
//     "function evaluation" "best-so-far f(x)"      (one such line starts each run)
//     <evaluation> <best-so-far>                    (the first evaluation, each evaluation that
//                                                    improves the best, and the last one)
// Numbers are written with 17 significant digits: they read back to the campaign's own doubles.
// The campaign run files record the best-so-far after every evaluation
// (result.best_per_evaluation), which is what the .dat records are taken from.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace insid::campaign {

struct IohExportOutcome {
  int info_files = 0;
  int runs = 0;          ///< runs written
  int missing_runs = 0;  ///< runs of the config without a run file (incomplete campaign): skipped
};

/// Writes the runs of the campaign in `campaign_dir` (its manifest.json and run files) under
/// `out_dir`. Throws std::runtime_error naming the file when the manifest or a present run file
/// cannot be used; missing run files are skipped and counted.
IohExportOutcome export_iohprofiler(const std::string& campaign_dir, const std::string& out_dir);

/// Reader of the layout above (for tests and checks; strict: throws std::runtime_error naming
/// the file, line and what was expected).
struct IohInfoRun {
  std::string instance;
  std::int64_t evaluations = 0;
  double best = 0.0;
};
struct IohInfoBlock {
  std::vector<std::pair<std::string, std::string>> header;  ///< name = value pairs, in order
  std::string comment;                                      ///< line 2 after its leading '%'
  std::string data_file;                                    ///< relative to the .info file's folder
  std::vector<IohInfoRun> runs;
  /// The value of a header key ("" when absent), quotes removed.
  std::string value(const std::string& key) const;
};
std::vector<IohInfoBlock> read_ioh_info(const std::string& path);

/// One run of a .dat file: its (evaluation, best-so-far) records.
using IohDatRun = std::vector<std::pair<std::int64_t, double>>;
std::vector<IohDatRun> read_ioh_dat(const std::string& path);

/// The best-so-far after each evaluation 1..last, expanded from a run's records (a value holds
/// until the next record; NaN before the first record).
std::vector<double> expand_best_so_far(const IohDatRun& run);

}  // namespace insid::campaign
