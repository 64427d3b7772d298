// One import of a user's recording as one library call: import_recording(spec) -> report, as
// identify(spec) is for an identification. `insid import` only maps its options to an
// ImportSpec and prints what the import tells.
//
// The pipeline: the spec validated, the output directories checked before any work, the source
// files read (regular files, the size limit, a binary log's magic), parsed and assembled into a
// dataset in memory (importer.h), the dataset's plausibility checked (data/plausibility.h), and
// the dataset written atomically with provenance.json: the source files' sizes and SHA-256,
// every option, what was dropped or derived. Sources: an IMU CSV with a mapping spec and a GNSS
// solution, KF-GINS text files, a PX4 ULog, an ArduPilot DataFlash log; the two logs can give
// every IMU they hold, each an ordinary dataset in a directory of its own under out_dir.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "data/dataset.h"
#include "import/ardupilot_import.h"
#include "import/csv_imu.h"
#include "import/importer.h"
#include "import/ulog_import.h"

namespace insid::importers {

/// An IMU CSV file read with a mapping spec, and a GNSS solution (`insid import csv`).
struct CsvImportSource {
  std::string imu_path;   ///< the IMU CSV file
  std::string gnss_path;  ///< an RTKLIB .pos or a KF-GINS GNSS file, told apart by content
  /// Columns, units, time scale, mounting. Its gps_week also dates a KF-GINS GNSS file.
  CsvImuSpec imu;
  /// RTKLIB quality flags kept, recorded in the order given.
  std::vector<int> gnss_quality = {1, 2};
  std::string validate() const;
};

/// KF-GINS text files: IMU increments and a GNSS file (or an RTKLIB .pos) (`insid import kf-gins`).
struct KfGinsImportSource {
  std::string imu_path, gnss_path;
  std::optional<int> gps_week;  ///< of the seconds-of-week times (recorded; absent: 0)
  std::string validate() const;
};

/// A PX4 ULog (`insid import ulog`).
struct UlogImportSource {
  std::string log_path;
  UlogImportOptions options;
  /// Every vehicle_imu instance with data (one per physical IMU), each into
  /// out_dir/vehicle_imu_K; options.imu_instance is not read, options.imu_topic may only be
  /// vehicle_imu.
  bool every_imu_instance = false;
  std::string validate() const;
};

/// An ArduPilot DataFlash log (`insid import ardupilot`).
struct ArduPilotImportSource {
  std::string log_path;
  ArduPilotImportOptions options;
  /// Every IMU message the log has (IMU, IMU2, IMU3), each into out_dir/NAME with the same
  /// options and window; options.imu is not read.
  bool every_imu = false;
  std::string validate() const;
};

using ImportSource =
    std::variant<CsvImportSource, KfGinsImportSource, UlogImportSource, ArduPilotImportSource>;

/// How every source is assembled: AssembleOptions less the GNSS selection, which is the
/// source's (a CSV import's gnss_quality; a log's fix or status selection, made by its reader).
struct ImportAssembly {
  std::optional<double> align_s;  ///< absent: the static window detected
  double static_speed_mps = AssembleOptions{}.static_speed_mps;
  double static_rate_dps = AssembleOptions{}.static_rate_dps;
  double static_accel_sd_mps2 = AssembleOptions{}.static_accel_sd_mps2;
  std::optional<double> declination_deg;
  double min_imu_rate_hz = kDefaultMinImuRateHz;

  /// The assembly's options with the source's GNSS quality flags.
  AssembleOptions assemble_options(std::set<int> gnss_quality) const;
  /// Adds these options to the recorded options of provenance.json.
  void record(nlohmann::json& options) const;
};

/// One import (`insid import`): what to read, how to assemble it, where to write it.
struct ImportSpec {
  ImportSource source;
  ImportAssembly assembly;
  /// Input files larger than this (MiB) are refused before they are read.
  double max_input_mb = 4096;
  /// The dataset directory (new, empty or an insid dataset); with every IMU of a log, the
  /// directory of their directories.
  std::string out_dir;
  /// Write into an out_dir that holds other files (DatasetWriteOptions::into_foreign_directory).
  bool force = false;

  /// "" when the spec can be run, else the first bad field named by its command-line option,
  /// with the value where the reader's message gives it: the source's options (CsvImuSpec,
  /// UlogImportOptions, ArduPilotImportOptions; a topic other than vehicle_imu with every IMU
  /// instance), the input size limit, the assembly's options (AssembleOptions::validate).
  std::string validate() const;
};

/// Where an import tells how it goes; either may be empty (silent).
struct ImportProgress {
  /// About the user's data, for the user even when quiet: an ArduPilot log's flight phases,
  /// the IMU being assembled, the plausibility findings, what was dropped or derived (the last
  /// two also in provenance.json).
  std::function<void(const std::string&)> data_note;
  /// A dataset written: its directory, rows, rates, span and the time taken.
  std::function<void(const std::string&)> note;
};

/// A dataset an import wrote.
struct ImportedDataset {
  std::string dir;
  std::shared_ptr<const Dataset> dataset;  ///< as written (for IdentifySpec::dataset)
  nlohmann::json provenance;               ///< as written in dir/provenance.json
};

struct ImportReport {
  /// In the order written: one, or each IMU of a log imported with every IMU.
  std::vector<ImportedDataset> datasets;
};

/// Runs `spec` (validated first: std::invalid_argument with validate()'s message). The output
/// directories are checked before anything is read (DatasetError); a source that cannot be
/// read or assembled throws std::runtime_error naming the file (FileReadError: unreadable);
/// data that fail the plausibility checks are refused with nothing written. With every IMU of
/// a log, all are assembled before any is written: one that fails is named and nothing is
/// written. Running out of memory is thrown as std::runtime_error naming the input files.
ImportReport import_recording(const ImportSpec& spec, const ImportProgress& progress = {});

}  // namespace insid::importers
