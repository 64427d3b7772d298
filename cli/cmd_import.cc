// insid import: a user's recording -> insid-dataset/2 directory with a provenance record
// (import/). Formats: csv (an IMU CSV with a mapping spec + an RTKLIB .pos GNSS solution), kf-gins,
// ulog (PX4) and ardupilot (DataFlash .bin). The other way, `insid export`: cmd_export.cc.
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <new>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/digest.h"
#include "base/file_read.h"
#include "base/json_reader.h"
#include "base/output_dir.h"
#include "cli/cli_util.h"
#include "cli/commands.h"
#include "cli/progress.h"
#include "data/dataset.h"
#include "data/plausibility.h"
#include "identification/identify.h"
#include "import/ardupilot_import.h"
#include "import/csv_imu.h"
#include "import/dataflash.h"
#include "import/gnss_solution.h"
#include "import/importer.h"
#include "import/kf_gins.h"
#include "import/ulog.h"
#include "import/ulog_import.h"

namespace insid::cli {
namespace {
namespace fs = std::filesystem;

// What every import subcommand takes (declared once by add_shared_import_options): the static
// window (importers::AssembleOptions), the output directory and the verbosity.
struct SharedImportArgs {
  std::optional<double> align_s;
  double static_speed_mps = importers::AssembleOptions{}.static_speed_mps;
  double static_rate_dps = importers::AssembleOptions{}.static_rate_dps;
  double static_accel_sd_mps2 = importers::AssembleOptions{}.static_accel_sd_mps2;
  std::optional<double> declination_deg;
  double min_imu_rate_hz = importers::kDefaultMinImuRateHz;
  double max_input_mb = 4096;  ///< input files larger than this are refused before reading
  std::string out;
  bool force = false;
  Verbosity verbosity = Verbosity::kNormal;

  /// The static-window part of the assembly options (the caller sets the GNSS quality).
  importers::AssembleOptions assemble_options() const {
    importers::AssembleOptions options;
    options.align_s = align_s;
    options.static_speed_mps = static_speed_mps;
    options.static_rate_dps = static_rate_dps;
    options.static_accel_sd_mps2 = static_accel_sd_mps2;
    options.declination_deg = declination_deg;
    options.min_imu_rate_hz = min_imu_rate_hz;
    return options;
  }
  /// Added to the recorded options of provenance.json.
  void record(nlohmann::json& options) const {
    options["align_s"] = align_s ? nlohmann::json(*align_s) : nlohmann::json(nullptr);
    options["static_speed_mps"] = static_speed_mps;
    options["static_rate_dps"] = static_rate_dps;
    options["static_accel_sd_mps2"] = static_accel_sd_mps2;
    if (declination_deg) options["declination_deg"] = *declination_deg;  // only when given
    options["min_imu_rate_hz"] = min_imu_rate_hz;
  }
  /// How an input file is read: the size limit, and what lifts it.
  FileReadOptions read_options() const {
    FileReadOptions o;
    o.max_bytes = static_cast<std::uint64_t>(max_input_mb * 1048576.0);
    o.limit_option = "--max-input-mb";
    return o;
  }
};  // namespace

void add_shared_import_options(CLI::App* sub, SharedImportArgs& a) {
  sub->add_option("--align-s", a.align_s,
                  "static alignment window (s); default: detected, until 1 s before the GNSS "
                  "shows motion or the IMU block before the first turn or shake")
      ->check(number_in(0, 86400));
  sub->add_option("--static-speed", a.static_speed_mps,
                  "GNSS horizontal speed (m/s) above which the unit is moving")
      ->capture_default_str()
      ->check(number_in(1e-6, 10));
  sub->add_option("--static-rate", a.static_rate_dps,
                  "angular rate (deg/s) by which a 0.5 s block's mean departing from the still "
                  "blocks' ends the static window (a turn on the spot)")
      ->capture_default_str()
      ->check(number_in(1e-6, 1000));
  sub->add_option("--static-accel-sd", a.static_accel_sd_mps2,
                  "sd of |specific force| (m/s^2) within a 0.5 s block that ends the static "
                  "window (steps, handling; raise it for a platform vibrating while still)")
      ->capture_default_str()
      ->check(number_in(1e-6, 100));
  sub->add_option("--declination-deg", a.declination_deg,
                  "magnetic declination (deg, east +) at the flight: required with a "
                  "magnetometer heading (csv mx,my,mz columns; ulog --heading mag), which it "
                  "turns into a true heading; insid has no world magnetic model")
      ->check(number_in(-180, 180));
  sub->add_option("--min-imu-rate-hz", a.min_imu_rate_hz,
                  "lowest IMU rate (Hz) integrated; a slower log is refused (default 20: a "
                  "multicopter's motion reaches ~5 Hz, and the Nyquist frequency should be twice "
                  "that; lower it only for a platform whose motion stays below a quarter of it)")
      ->capture_default_str()
      ->check(number_in(1e-3, 10000));
  sub->add_option("--max-input-mb", a.max_input_mb,
                  "largest input file read (MiB; each is read whole, checked before reading: an "
                  "honest bigger log needs about twice its size in memory)")
      ->capture_default_str()
      ->check(number_in(1, 1048576));
  sub->add_option("--out", a.out, "output dataset directory (new, empty or an insid dataset)")
      ->required();
  sub->add_flag("--force", a.force, "write into a --out directory that holds other files");
  add_verbosity_flags(sub, a.verbosity);
}

// Runs an import: running out of memory anywhere in it (reading, parsing, assembling) is
// reported with its input files named, never as a bare std::bad_alloc.
template <class Run>
void naming_inputs_on_oom(const std::string& inputs, Run&& run) {
  try {
    run();
  } catch (const std::bad_alloc&) {
    throw std::runtime_error("out of memory while importing " + inputs +
                             " (split the log, or give the import more memory)");
  }
}

struct ImportCsvArgs {
  std::string imu, gnss, columns, units, imu_time = "gpst-unix", rate_samples = "point", mounting;
  std::optional<int> gps_week;
  std::optional<double> time_offset_s;  // required with --imu-time relative
  std::vector<int> gnss_quality = {1, 2};
  SharedImportArgs shared;
};

// A whole input file (base/file_read.h: regular files only, the size limit, out of memory named).
std::string read_text(const std::string& path, const char* option, const FileReadOptions& read) {
  return read_file_whole(path, std::string(option) + " " + path, read);
}

// A text log: read_text, less a UTF-8 byte-order mark at its start (editors and Windows loggers
// write one; left in, it made the first data row look like a header and dropped it silently).
std::string read_text_log(const std::string& path, const char* option,
                          const FileReadOptions& read) {
  FileReadOptions as_text = read;
  as_text.text = true;  // a binary file or one of zeros refused on its first bytes
  std::string text = read_text(path, option, as_text);
  if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) text.erase(0, 3);
  return text;
}

// "180,0,-90" -> {180, 0, -90}; throws naming the option and the bad item.
std::vector<double> parse_number_list(const std::string& text, const char* option) {
  std::vector<double> values;
  std::size_t b = 0;
  for (;;) {
    const std::size_t e = text.find(',', b);
    const std::string item = text.substr(b, e == std::string::npos ? std::string::npos : e - b);
    double v = 0.0;
    const auto [end, ec] = std::from_chars(item.data(), item.data() + item.size(), v);
    if (ec != std::errc() || end != item.data() + item.size() || !std::isfinite(v))
      throw std::invalid_argument(std::string(option) + ": '" + item + "' is not a finite number");
    values.push_back(v);
    if (e == std::string::npos) return values;
    b = e + 1;
  }
}

// An RTKLIB .pos or a KF-GINS GNSS text file, told apart by content.
importers::GnssSolution read_gnss_by_content(const std::string& text, const std::string& path,
                                             std::optional<int> gps_week) {
  if (importers::looks_like_rtklib_pos(text)) return importers::parse_rtklib_pos(text, path);
  if (importers::looks_like_kf_gins_gnss(text))
    return importers::parse_kf_gins_gnss(text, path, gps_week);
  throw std::invalid_argument("--gnss " + path +
                              ": neither an RTKLIB solution (a '%' header naming latitude(deg)) "
                              "nor a KF-GINS GNSS file (7 or 13 numbers per line)");
}

nlohmann::json source_json(const std::string& role, const std::string& path,
                           const std::string& text) {
  return {{"role", role},
          {"path", path},
          {"file_name", fs::path(path).filename().string()},
          {"bytes", text.size()},
          {"sha256", sha256_hex(text)}};
}

// Provenance, the atomic write, and the user's summary: common to every import format.
void finish_import(const std::string& command, importers::Assembled result, nlohmann::json options,
                   nlohmann::json sources, const std::string& out, bool force,
                   std::chrono::steady_clock::time_point t0, Verbosity verbosity) {
  nlohmann::json& prov = result.provenance;
  prov["format"] = "insid-provenance/1";
  prov["command"] = command;
  prov["insid"] = build_info_json();
  prov["sources"] = std::move(sources);
  prov["options"] = std::move(options);
  DatasetWriteOptions write_options;
  write_options.into_foreign_directory = force;
  write_options.extra_files["provenance.json"] = prov.dump(2) + "\n";
  for (const nlohmann::json& source : prov["sources"])
    write_options.inputs.emplace_back(source.at("path").get<std::string>());
  // Does the result obey the physics it must (data/plausibility.h)? Said before anything is
  // written; a refusal writes nothing.
  const PlausibilityReport plausibility = check_plausibility(result.dataset);
  for (const PlausibilityFinding& f : plausibility.findings)
    std::cerr << "insid import: " << f.text() << "\n";
  if (plausibility.refused())
    throw std::runtime_error("the imported data cannot be right (above); nothing written to " +
                             out);
  prov["plausibility"] = plausibility.to_json();
  write_options.extra_files["provenance.json"] = prov.dump(2) + "\n";
  write_dataset(out, result.dataset, write_options);
  // Notes say what was dropped or derived: printed even with --quiet (also in provenance.json).
  for (const std::string& note : result.notes) std::cerr << "insid import: " << note << "\n";
  ProgressPrinter progress("insid import", verbosity);
  const Dataset& ds = result.dataset;
  char line[256];
  std::snprintf(line, sizeof line,
                " (insid-dataset/2): %zu IMU rows (median %.4g Hz), %zu GNSS epochs (%.3g Hz), "
                "%.1f s, in %.2f s",
                ds.imu.size(), ds.meta.imu_rate_hz, ds.gnss.size(), ds.meta.gnss_rate_hz,
                ds.imu.back().t_s - ds.imu.front().t_s,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  progress.note("wrote " + out + line);
}

void run_import_csv(const ImportCsvArgs& args) {
  // Refuse a directory before the work (its own input files included).
  dataset_destination(args.shared.out, args.shared.force, {args.imu, args.gnss});
  importers::CsvImuSpec spec;
  spec.columns =
      parse_option("--columns", [&] { return importers::CsvImuSpec::parse_columns(args.columns); });
  parse_option("--units", [&] {
    spec.parse_units(args.units);
    return 0;
  });
  spec.time_scale = args.imu_time;
  spec.rate_samples = args.rate_samples;
  spec.gps_week = args.gps_week;
  if (args.imu_time == "relative" && !args.time_offset_s)
    throw UsageError(
        "--imu-time relative needs --imu-time-offset-s: the GPS time of week (s) at the logger's "
        "zero, so that the IMU can be paired with the GNSS solution");
  spec.time_offset_s = args.time_offset_s.value_or(0.0);
  if (!args.mounting.empty()) {
    const std::vector<double> rpy = parse_option("--mounting-rpy-deg", [&] {
      return parse_number_list(args.mounting, "--mounting-rpy-deg");
    });
    if (rpy.size() != 3)
      throw UsageError("--mounting-rpy-deg: expected R,P,Y (three angles in degrees)");
    spec.mounting_rpy_deg = {rpy[0], rpy[1], rpy[2]};
  }
  if (const std::string e = spec.validate(); !e.empty()) throw UsageError(e);
  importers::AssembleOptions options = args.shared.assemble_options();
  options.gnss_quality = {args.gnss_quality.begin(), args.gnss_quality.end()};
  if (const std::string e = options.validate(); !e.empty()) throw UsageError(e);

  const auto t0 = std::chrono::steady_clock::now();
  const std::string gnss_text = read_text_log(args.gnss, "--gnss", args.shared.read_options());
  const importers::GnssSolution gnss = read_gnss_by_content(gnss_text, args.gnss, args.gps_week);
  const std::optional<int> gnss_week = static_cast<int>(
      static_cast<double>(gnss.epochs.front().t_gpst_unix_s - importers::kGpsEpochGpstUnix_s) /
      importers::kSecondsPerWeek);
  const std::string imu_text = read_text_log(args.imu, "--imu", args.shared.read_options());
  const importers::CsvImu imu = importers::read_csv_imu(imu_text, args.imu, spec, gnss_week);
  importers::Assembled result = importers::assemble_dataset(imu, gnss, options);

  nlohmann::json recorded_options = {
      {"columns", spec.columns},
      {"units", {{"time", spec.time_unit}, {"accel", spec.accel_unit}, {"gyro", spec.gyro_unit}}},
      {"imu_time", spec.time_scale},
      {"rate_samples", spec.rate_samples},
      {"gps_week", args.gps_week ? nlohmann::json(*args.gps_week) : nlohmann::json(nullptr)},
      {"imu_time_offset_s", spec.time_offset_s},
      {"mounting_rpy_deg",
       {spec.mounting_rpy_deg.x(), spec.mounting_rpy_deg.y(), spec.mounting_rpy_deg.z()}},
      {"mounting", "v_b = Rx(R) Ry(P) Rz(Y) v_s, applied at import"},
      {"gnss_quality", args.gnss_quality}};
  args.shared.record(recorded_options);
  finish_import("insid import csv", std::move(result), std::move(recorded_options),
                {source_json("imu", args.imu, imu_text), source_json("gnss", args.gnss, gnss_text)},
                args.shared.out, args.shared.force, t0, args.shared.verbosity);
}

struct ImportKfGinsArgs {
  std::string imu, gnss;
  std::optional<int> gps_week;
  SharedImportArgs shared;
};

void run_import_kf_gins(const ImportKfGinsArgs& args) {
  dataset_destination(args.shared.out, args.shared.force, {args.imu, args.gnss});
  const importers::AssembleOptions options = args.shared.assemble_options();
  if (const std::string e = options.validate(); !e.empty()) throw UsageError(e);
  const auto t0 = std::chrono::steady_clock::now();
  const std::string gnss_text = read_text_log(args.gnss, "--gnss", args.shared.read_options());
  const importers::GnssSolution gnss = read_gnss_by_content(gnss_text, args.gnss, args.gps_week);
  const std::string imu_text = read_text_log(args.imu, "--imu", args.shared.read_options());
  const importers::CsvImu imu = importers::parse_kf_gins_imu(imu_text, args.imu, args.gps_week);
  importers::Assembled result = importers::assemble_dataset(imu, gnss, options);
  if (gnss.format.find("derived") != std::string::npos)
    result.notes.push_back(
        "GNSS velocity derived from positions by central differences (the "
        "file has no velocity columns); see README, insid import kf-gins");
  nlohmann::json opts = {
      {"gps_week", args.gps_week ? nlohmann::json(*args.gps_week) : nlohmann::json(nullptr)},
      {"axes", "body forward-right-down as KF-GINS defines its IMU file (no mounting applied)"}};
  args.shared.record(opts);
  finish_import("insid import kf-gins", std::move(result), std::move(opts),
                {source_json("imu", args.imu, imu_text), source_json("gnss", args.gnss, gnss_text)},
                args.shared.out, args.shared.force, t0, args.shared.verbosity);
}

struct ImportUlogArgs {
  std::string log;
  importers::UlogImportOptions ulog;
  std::string imu_instance = "0";  ///< a whole number 0-255, or all
  SharedImportArgs shared;
};

// One IMU instance of a parsed ULog, extracted and assembled in memory (nothing written).
importers::Assembled assemble_ulog(const ImportUlogArgs& args, const importers::UlogFile& log,
                                   const importers::UlogImportOptions& ulog,
                                   const importers::AssembleOptions& options,
                                   nlohmann::json& opts) {
  importers::UlogSeries series = importers::extract_ulog(log, args.log, ulog);
  importers::Assembled result = importers::assemble_dataset(
      series.imu, series.gnss, options, series.heading ? &*series.heading : nullptr);
  // The ULog clock is PX4's boot clock, not GPST: name the origin accordingly.
  nlohmann::json& prov = result.provenance;
  prov["time_origin_boot_s"] = prov["time_origin_gpst_unix_s"];
  prov.erase("time_origin_gpst_unix_s");
  prov.update(series.provenance, true);
  result.notes.insert(result.notes.begin(), series.notes.begin(), series.notes.end());
  if (!series.autopilot_estimates.is_null())
    result.dataset.meta.autopilot_estimates_json = series.autopilot_estimates.dump();
  opts = {{"imu_topic", ulog.imu_topic.empty() ? "auto" : ulog.imu_topic},
          {"imu_instance", ulog.imu_instance},
          {"gnss_instance", ulog.gnss_instance},
          {"min_fix_type", ulog.min_fix_type}};
  if (args.imu_instance == "all") opts["imu_instance_option"] = "all";
  if (!ulog.heading.empty()) {  // only when given: earlier records stay as they were
    opts["heading"] = ulog.heading;
    if (ulog.heading == "mag") opts["mag_instance"] = ulog.mag_instance;
  }
  args.shared.record(opts);
  return result;
}

// The multi-instance IMU topic `--imu-instance all` imports: one vehicle_imu instance per
// physical IMU (sensor_combined is PX4's one selected IMU).
constexpr const char* kUlogMultiImuTopic = "vehicle_imu";

void run_import_ulog(const ImportUlogArgs& args) {
  const bool every = args.imu_instance == "all";
  importers::UlogImportOptions ulog = args.ulog;
  if (!every) {
    ulog.imu_instance = parse_option("--imu-instance", [&] {
      int v = -1;
      const std::string& t = args.imu_instance;
      const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
      if (ec != std::errc() || end != t.data() + t.size() || v < 0 || v > 255)
        throw std::invalid_argument("--imu-instance '" + t +
                                    "': must be a whole number in 0-255, or all");
      return v;
    });
  } else {
    if (!ulog.imu_topic.empty() && ulog.imu_topic != kUlogMultiImuTopic)
      throw UsageError(
          "--imu-instance all imports every instance of vehicle_imu (one per "
          "physical IMU); --imu-topic '" +
          ulog.imu_topic + "' has one");
    ulog.imu_topic = kUlogMultiImuTopic;
  }
  if (const std::string e = ulog.validate(); !e.empty()) throw UsageError(e);
  if (!every) dataset_destination(args.shared.out, args.shared.force, {args.log});
  importers::AssembleOptions options = args.shared.assemble_options();
  options.gnss_quality = {1};  // the fix-type selection is made by extract_ulog
  if (const std::string e = options.validate(); !e.empty()) throw UsageError(e);
  const auto t0 = std::chrono::steady_clock::now();
  FileReadOptions read = args.shared.read_options();
  read.magic = importers::kUlogMagic;
  read.magic_name = "a PX4 ULog (magic 'ULog' 01 12 35)";
  std::string bytes = read_text(args.log, "LOG", read);
  const nlohmann::json source = source_json("ulog", args.log, bytes);
  const importers::UlogFile log = importers::UlogFile::parse(std::move(bytes), args.log);
  if (!every) {
    nlohmann::json opts;
    importers::Assembled result = assemble_ulog(args, log, ulog, options, opts);
    finish_import("insid import ulog", std::move(result), std::move(opts), {source},
                  args.shared.out, args.shared.force, t0, args.shared.verbosity);
    return;
  }
  // --imu-instance all: every vehicle_imu instance with data, into --out/vehicle_imu_K; all are
  // assembled before any is written (one that fails is named, and nothing is written).
  std::vector<int> present;
  for (const auto& [instance, n] : log.instances(kUlogMultiImuTopic))
    if (n > 0) present.push_back(instance);
  if (present.empty())
    throw std::runtime_error(args.log +
                             ": no vehicle_imu messages (--imu-instance all imports "
                             "each instance of vehicle_imu)");
  auto dir = [&](int instance) {
    return (fs::path(args.shared.out) / ("vehicle_imu_" + std::to_string(instance))).string();
  };
  for (int instance : present) dataset_destination(dir(instance), args.shared.force, {args.log});
  std::vector<std::pair<importers::Assembled, nlohmann::json>> assembled;
  for (int instance : present) {
    importers::UlogImportOptions one = ulog;
    one.imu_instance = instance;
    try {
      nlohmann::json opts;
      importers::Assembled result = assemble_ulog(args, log, one, options, opts);
      assembled.emplace_back(std::move(result), std::move(opts));
    } catch (const std::bad_alloc&) {
      throw;
    } catch (const std::exception& e) {
      throw std::runtime_error("--imu-instance all: vehicle_imu instance " +
                               std::to_string(instance) + " failed, nothing written: " + e.what() +
                               " (import the others one by one with --imu-instance K)");
    }
  }
  for (std::size_t k = 0; k < assembled.size(); ++k)
    finish_import("insid import ulog", std::move(assembled[k].first),
                  std::move(assembled[k].second), {source}, dir(present[k]), args.shared.force, t0,
                  args.shared.verbosity);
}

/// --imu / --imu-instance value that imports every IMU of a log.
constexpr const char* kEveryImu = "all";

struct ImportArduPilotArgs {
  std::string log;
  importers::ArduPilotImportOptions ardupilot;
  SharedImportArgs shared;
};

// One IMU of a parsed DataFlash log, extracted and assembled into a dataset in memory (nothing
// written): the flight phases printed first, a logging gap refused naming where to cut.
importers::Assembled assemble_ardupilot(const ImportArduPilotArgs& args,
                                        const importers::DataFlashFile& log,
                                        const importers::ArduPilotImportOptions& ardupilot,
                                        const importers::AssembleOptions& options,
                                        nlohmann::json& recorded_options) {
  importers::ArduPilotSeries series = importers::extract_ardupilot(log, args.log, ardupilot);
  // The phases first, even when the import is refused below: they say where to cut.
  for (const std::string& line : series.phases.lines())
    std::cerr << "insid import: " << line << "\n";
  for (const auto& [boot_s, gap_s] : series.imu_gaps_boot_s)
    if (gap_s > PlausibilityBounds::kMaxImuStep_s) {
      char text[512];
      std::snprintf(text, sizeof text,
                    "%s: %s has a logging gap of %.3f s after boot time %.3f s, longer than the "
                    "%g s insid integrates across: import the part before it (--t-end %.3f) or "
                    "after it (--t-start %.3f)",
                    args.log.c_str(), ardupilot.imu.c_str(), gap_s, boot_s,
                    PlausibilityBounds::kMaxImuStep_s, boot_s, boot_s + gap_s);
      throw std::runtime_error(text);
    }
  importers::Assembled result = importers::assemble_dataset(series.imu, series.gnss, options);
  result.provenance.update(series.provenance, true);
  result.notes.insert(result.notes.begin(), series.notes.begin(), series.notes.end());
  if (!series.autopilot_estimates.is_null())
    result.dataset.meta.autopilot_estimates_json = series.autopilot_estimates.dump();
  recorded_options = {{"imu", ardupilot.imu},
                      {"min_status", ardupilot.min_status},
                      {"t_start_boot_s", ardupilot.t_start_s ? nlohmann::json(*ardupilot.t_start_s)
                                                             : nlohmann::json(nullptr)},
                      {"t_end_boot_s", ardupilot.t_end_s ? nlohmann::json(*ardupilot.t_end_s)
                                                         : nlohmann::json(nullptr)},
                      {"rate_samples", "point"},
                      {"axes", "ArduPilot body frame, forward-right-down (no mounting applied)"}};
  if (args.ardupilot.imu == kEveryImu) recorded_options["imu_option"] = kEveryImu;
  args.shared.record(recorded_options);
  return result;
}

// The IMU messages of a DataFlash log that `--imu all` imports, in this order.
constexpr const char* kArduPilotImus[] = {"IMU", "IMU2", "IMU3"};

void run_import_ardupilot(const ImportArduPilotArgs& args) {
  const bool every = args.ardupilot.imu == kEveryImu;
  importers::ArduPilotImportOptions checked = args.ardupilot;
  if (every) checked.imu = "IMU";  // the other options checked as for one IMU
  if (std::string e = checked.validate(); !e.empty()) {
    if (e.rfind("--imu", 0) == 0)
      e += ", or all (every one the log has, into --out/IMU, --out/IMU2, --out/IMU3)";
    throw UsageError(e);
  }
  if (!every) {
    dataset_destination(args.shared.out, args.shared.force, {args.log});
  } else {
    // Every IMU directory is checked before the work (the log itself never in the way).
    for (const char* name : kArduPilotImus)
      dataset_destination(fs::path(args.shared.out) / name, args.shared.force, {args.log});
  }
  importers::AssembleOptions options = args.shared.assemble_options();
  options.gnss_quality = {1};  // the Status selection is made by extract_ardupilot
  if (const std::string e = options.validate(); !e.empty()) throw UsageError(e);
  const auto t0 = std::chrono::steady_clock::now();
  FileReadOptions read = args.shared.read_options();
  read.magic = importers::kDataFlashMagic;
  read.magic_name = "an ArduPilot DataFlash log (records start with 0xA3 0x95)";
  std::string bytes = read_text(args.log, "LOG", read);
  const nlohmann::json source = source_json("dataflash", args.log, bytes);
  const importers::DataFlashFile log = importers::DataFlashFile::parse(std::move(bytes), args.log);
  if (!every) {
    nlohmann::json opts;
    importers::Assembled result = assemble_ardupilot(args, log, args.ardupilot, options, opts);
    finish_import("insid import ardupilot", std::move(result), std::move(opts), {source},
                  args.shared.out, args.shared.force, t0, args.shared.verbosity);
    return;
  }
  // --imu all: every IMU message the log has, each an ordinary dataset in --out/NAME with the
  // same options and window. All are assembled before any is written: one that fails is named
  // and nothing is written.
  std::vector<std::string> present;
  for (const char* name : kArduPilotImus)
    if (log.count(name) > 0) present.emplace_back(name);
  if (present.empty())
    throw std::runtime_error(args.log + ": no IMU, IMU2 or IMU3 messages (--imu all)");
  std::vector<std::pair<importers::Assembled, nlohmann::json>> assembled;
  for (const std::string& name : present) {
    importers::ArduPilotImportOptions one = args.ardupilot;
    one.imu = name;
    std::cerr << "insid import: --imu all: " << name << "\n";
    try {
      nlohmann::json opts;
      importers::Assembled result = assemble_ardupilot(args, log, one, options, opts);
      assembled.emplace_back(std::move(result), std::move(opts));
    } catch (const std::bad_alloc&) {
      throw;
    } catch (const std::exception& e) {
      std::string done;
      for (std::size_t k = 0; k < assembled.size(); ++k) done += (k ? ", " : "") + present[k];
      throw std::runtime_error("--imu all: " + name + " failed, nothing written" +
                               (done.empty() ? "" : " (" + done + " were fine)") + ": " + e.what() +
                               " (import the others one by one with --imu NAME)");
    }
  }
  for (std::size_t k = 0; k < assembled.size(); ++k)
    finish_import("insid import ardupilot", std::move(assembled[k].first),
                  std::move(assembled[k].second), {source},
                  (fs::path(args.shared.out) / present[k]).string(), args.shared.force, t0,
                  args.shared.verbosity);
}

}  // namespace

void add_import_command(CLI::App& app) {
  CLI::App* cmd = app.add_subcommand(
      "import",
      "Read a recording in a user's format and write an insid-dataset/2 directory (measured "
      "timing) with provenance.json: the source files' sizes and SHA-256, every option, what "
      "was dropped or derived.");
  cmd->require_subcommand(1);
  auto a = std::make_shared<ImportCsvArgs>();
  CLI::App* csv = cmd->add_subcommand(
      "csv",
      "an IMU CSV file read with a mapping spec, and a GNSS solution (RTKLIB .pos with velocity)");
  csv->add_option("--imu", a->imu, "IMU CSV file (comma separated; a header line is skipped)")
      ->required();
  csv->add_option("--columns", a->columns,
                  "role of each column in order: t,ax,ay,az,gx,gy,gz or - to ignore "
                  "(e.g. t,ax,ay,az,gx,gy,gz,-,-,-,-); optional heading: hdg (dual-antenna "
                  "heading, deg from true north; empty/nan = none on that row) and hdg_sd (deg), "
                  "or mx,my,mz (magnetometer, sensor axes; needs --declination-deg)")
      ->required();
  csv->add_option("--units", a->units,
                  "TIME,ACCEL,GYRO: s|ms|us, g|g-local|m/s^2|m/s (m/s = increments), "
                  "rad/s|deg/s|rad|deg (rad, deg = increments); g = 9.80665 m/s^2, g-local = the "
                  "normal gravity at the first GNSS position")
      ->required();
  csv->add_option("--gnss", a->gnss, "GNSS solution: RTKLIB .pos (llh, GPST, with velocity)")
      ->required();
  csv->add_option("--imu-time", a->imu_time,
                  "IMU time scale: gpst-unix | gps-sow | relative (seconds from the logger's zero; "
                  "--imu-time-offset-s gives its GPS time of week)")
      ->capture_default_str();
  csv->add_option("--rate-samples", a->rate_samples,
                  "rate rows are point (the rate at each stamp: trapezoid) | interval-mean (the "
                  "mean over the step each row closes: times the step)")
      ->capture_default_str();
  csv->add_option("--gps-week", a->gps_week,
                  "GPS week for --imu-time gps-sow (default: the GNSS file's)")
      ->check(whole_in(0, 100000));
  csv->add_option("--imu-time-offset-s", a->time_offset_s,
                  "added to every IMU time (s, within +-86400); with --imu-time relative the GPS "
                  "time of week at the logger's zero (required)")
      ->check(number_in(-86400, 604800));
  csv->add_option("--mounting-rpy-deg", a->mounting,
                  "R,P,Y: v_body = Rx(R) Ry(P) Rz(Y) v_sensor (passive rotations, the matrix roll/"
                  "pitch/yaw give for C_n^b); e.g. 180,0,-90 turns a resting +1 g on sensor z into "
                  "-1 g on body z (FRD)");
  csv->add_option("--gnss-quality", a->gnss_quality,
                  "RTKLIB quality flags kept (default 1 2: fix, float)")
      ->check(whole_in(1, 7));
  add_shared_import_options(csv, a->shared);
  csv->callback(
      [a] { naming_inputs_on_oom(a->imu + " and " + a->gnss, [&] { run_import_csv(*a); }); });

  auto k = std::make_shared<ImportKfGinsArgs>();
  CLI::App* kf = cmd->add_subcommand(
      "kf-gins",
      "KF-GINS text files: IMU (SOW, dtheta xyz rad, dvel xyz m/s, FRD) and GNSS (7 columns, "
      "velocity then derived from positions; or 13 with velocity), or an RTKLIB .pos as --gnss");
  kf->add_option("--imu", k->imu, "KF-GINS IMU text file")->required();
  kf->add_option("--gnss", k->gnss, "KF-GINS GNSS text file or RTKLIB .pos")->required();
  kf->add_option("--gps-week", k->gps_week,
                 "GPS week of the seconds-of-week times (recorded; default 0)")
      ->check(whole_in(0, 100000));
  add_shared_import_options(kf, k->shared);
  kf->callback(
      [k] { naming_inputs_on_oom(k->imu + " and " + k->gnss, [&] { run_import_kf_gins(*k); }); });

  auto u = std::make_shared<ImportUlogArgs>();
  CLI::App* ul = cmd->add_subcommand(
      "ulog",
      "a PX4 flight log (.ulg): IMU from vehicle_imu (increments) or sensor_combined, GNSS from "
      "vehicle_gps_position or sensor_gps, layouts read from the file's own formats");
  ul->add_option("log", u->log, "the .ulg file")->required();
  ul->add_option("--imu-topic", u->ulog.imu_topic,
                 "vehicle_imu | sensor_combined (default: the one with more samples)");
  ul->add_option("--imu-instance", u->imu_instance,
                 "multi-instance IMU topic: which one (default 0); all: every vehicle_imu "
                 "instance, each an ordinary dataset in --out/vehicle_imu_K (for insid "
                 "cross-imu)")
      ->capture_default_str();
  ul->add_option("--gnss-instance", u->ulog.gnss_instance, "which GNSS instance (default 0)")
      ->check(whole_in(0, 255));
  ul->add_option("--min-fix-type", u->ulog.min_fix_type,
                 "PX4 fix_type kept: 3 = 3D (default), 4 = DGPS, 5 = RTK float, 6 = RTK fixed")
      ->check(whole_in(0, 8));
  ul->add_option("--heading", u->ulog.heading,
                 "a measured heading into heading.csv: gps (the GNSS topic's dual-antenna "
                 "'heading') | mag (sensor_mag or vehicle_magnetometer; needs --declination-deg)");
  ul->add_option("--mag-instance", u->ulog.mag_instance,
                 "--heading mag: which magnetometer instance (default 0)")
      ->check(whole_in(0, 255));
  add_shared_import_options(ul, u->shared);
  ul->callback([u] { naming_inputs_on_oom(u->log, [&] { run_import_ulog(*u); }); });

  auto ap = std::make_shared<ImportArduPilotArgs>();
  CLI::App* apc = cmd->add_subcommand(
      "ardupilot",
      "an ArduPilot DataFlash log (.bin): IMU, IMU2 or IMU3 (sampled rates and specific forces), "
      "GPS fixes (Spd along GCrs, VZ), layouts read from the file's own FMT records");
  apc->add_option("log", ap->log, "the .bin file")->required();
  apc->add_option("--imu", ap->ardupilot.imu,
                  "IMU | IMU2 | IMU3: which IMU (default IMU); all: every IMU the log has, each "
                  "an ordinary dataset in --out/IMU, --out/IMU2, --out/IMU3 (same options and "
                  "window; for insid cross-imu)")
      ->capture_default_str();
  apc->add_option("--min-status", ap->ardupilot.min_status,
                  "GPS Status kept: 3 = 3D fix (default) and above")
      ->check(whole_in(0, 6));
  apc->add_option("--t-start", ap->ardupilot.t_start_s, "boot time (s) from which records are kept")
      ->check(number_in(0, 1e7));
  apc->add_option("--t-end", ap->ardupilot.t_end_s,
                  "boot time (s) after which records are cut (e.g. before a crash)")
      ->check(number_in(0, 1e7));
  add_shared_import_options(apc, ap->shared);
  apc->callback([ap] { naming_inputs_on_oom(ap->log, [&] { run_import_ardupilot(*ap); }); });
}

}  // namespace insid::cli
