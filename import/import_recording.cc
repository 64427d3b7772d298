#include "import/import_recording.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <new>
#include <stdexcept>
#include <string_view>
#include <utility>

#include "base/digest.h"
#include "base/file_read.h"
#include "base/number_text.h"
#include "data/plausibility.h"
#include "import/dataflash.h"
#include "import/gnss_solution.h"
#include "import/kf_gins.h"
#include "import/ulog.h"
#include "kernel/build_info.h"

namespace insid::importers {
namespace {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// Recorded as "imu_option" / "imu_instance_option" when every IMU of a log was imported.
constexpr const char* kEveryImu = "all";

// The multi-instance IMU topic of a ULog imported with every instance: one vehicle_imu instance
// per physical IMU (sensor_combined is PX4's one selected IMU).
constexpr const char* kUlogMultiImuTopic = "vehicle_imu";

// The IMU messages of a DataFlash log imported with every IMU, in this order.
constexpr const char* kArduPilotImus[] = {"IMU", "IMU2", "IMU3"};

// The GNSS quality flags a source's assembly keeps.
std::set<int> gnss_quality_of(const ImportSource& source) {
  if (const auto* csv = std::get_if<CsvImportSource>(&source))
    return {csv->gnss_quality.begin(), csv->gnss_quality.end()};
  if (std::holds_alternative<KfGinsImportSource>(source)) return AssembleOptions{}.gnss_quality;
  return {1};  // a log's fix-type / Status selection is made by its reader
}

// The input files of a source, for the out-of-memory message.
std::string input_names(const ImportSource& source) {
  return std::visit(
      [](const auto& s) -> std::string {
        if constexpr (requires { s.log_path; })
          return s.log_path;
        else
          return s.imu_path + " and " + s.gnss_path;
      },
      source);
}

// One import under way: its spec, where it reports, when the reading started, what it wrote.
struct ImportRun {
  const ImportSpec& spec;
  const ImportProgress& progress;
  Clock::time_point t0;  // set by each source when its reading starts
  ImportReport report;

  void data_note(const std::string& text) const {
    if (progress.data_note) progress.data_note(text);
  }
  // How an input file is read: the size limit, and what lifts it.
  FileReadOptions read_options() const {
    FileReadOptions o;
    o.max_bytes = static_cast<std::uint64_t>(spec.max_input_mb * 1048576.0);
    o.limit_option = "--max-input-mb";
    return o;
  }
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

nlohmann::json source_json(const std::string& role, const std::string& path,
                           const std::string& text) {
  return {{"role", role},
          {"path", path},
          {"file_name", fs::path(path).filename().string()},
          {"bytes", text.size()},
          {"sha256", sha256_hex(text)}};
}

// The GNSS file of a csv or kf-gins import: an RTKLIB .pos or a KF-GINS GNSS text file, told
// apart by content; its text is kept for the provenance.
struct GnssFile {
  std::string text;
  GnssSolution solution;
};
GnssFile read_gnss_file(const ImportRun& run, const std::string& path,
                        std::optional<int> gps_week) {
  GnssFile file;
  file.text = read_text_log(path, "--gnss", run.read_options());
  if (looks_like_rtklib_pos(file.text))
    file.solution = parse_rtklib_pos(file.text, path);
  else if (looks_like_kf_gins_gnss(file.text))
    file.solution = parse_kf_gins_gnss(file.text, path, gps_week);
  else
    throw std::invalid_argument("--gnss " + path +
                                ": neither an RTKLIB solution (a '%' header naming latitude(deg)) "
                                "nor a KF-GINS GNSS file (7 or 13 numbers per line)");
  return file;
}

// A binary log read whole, its magic checked before the rest is read; `source` records it.
std::string read_log(const ImportRun& run, const std::string& path, std::string_view magic,
                     const char* magic_name, const char* role, nlohmann::json& source) {
  FileReadOptions read = run.read_options();
  read.magic = magic;
  read.magic_name = magic_name;
  std::string bytes = read_text(path, "LOG", read);
  source = source_json(role, path, bytes);
  return bytes;
}

// Provenance, the plausibility check, the atomic write, and the summary: common to every
// source.
void finish_import(ImportRun& run, const std::string& command, Assembled result,
                   nlohmann::json options, nlohmann::json sources, const std::string& out) {
  nlohmann::json& prov = result.provenance;
  prov["format"] = "insid-provenance/1";
  prov["command"] = command;
  prov["insid"] = build_info_json();
  prov["sources"] = std::move(sources);
  prov["options"] = std::move(options);
  DatasetWriteOptions write_options;
  write_options.into_foreign_directory = run.spec.force;
  for (const nlohmann::json& source : prov["sources"])
    write_options.inputs.emplace_back(source.at("path").get<std::string>());
  // Does the result obey the physics it must (data/plausibility.h)? Said before anything is
  // written; a refusal writes nothing.
  const PlausibilityReport plausibility = check_plausibility(result.dataset);
  for (const PlausibilityFinding& f : plausibility.findings) run.data_note(f.text());
  if (plausibility.refused())
    throw std::runtime_error("the imported data cannot be right (above); nothing written to " +
                             out);
  prov["plausibility"] = plausibility.to_json();
  write_options.extra_files["provenance.json"] = prov.dump(2) + "\n";
  write_dataset(out, result.dataset, write_options);
  // Notes say what was dropped or derived (also in provenance.json).
  for (const std::string& note : result.notes) run.data_note(note);
  const Dataset& ds = result.dataset;
  char line[256];
  std::snprintf(line, sizeof line,
                " (insid-dataset/2): %zu IMU rows (median %.4g Hz), %zu GNSS epochs (%.3g Hz), "
                "%.1f s, in %.2f s",
                ds.imu.size(), ds.meta.imu_rate_hz, ds.gnss.size(), ds.meta.gnss_rate_hz,
                ds.imu.back().t_s - ds.imu.front().t_s,
                std::chrono::duration<double>(Clock::now() - run.t0).count());
  if (run.progress.note) run.progress.note("wrote " + out + line);
  run.report.datasets.push_back(
      {out, std::make_shared<const Dataset>(std::move(result.dataset)), std::move(prov)});
}

// A dataset of a log assembled in memory, not yet written: with every IMU of a log, all are
// assembled before any is written.
struct PendingDataset {
  Assembled result;
  nlohmann::json options;  ///< recorded in provenance.json
  std::string dir;
};

void finish_log_import(ImportRun& run, const std::string& command,
                       std::vector<PendingDataset> pending, const nlohmann::json& source) {
  for (PendingDataset& p : pending)
    finish_import(run, command, std::move(p.result), std::move(p.options), {source}, p.dir);
}

void import_source(ImportRun& run, const CsvImportSource& source) {
  const ImportSpec& spec = run.spec;
  // Refuse a directory before the work (its own input files included).
  dataset_destination(spec.out_dir, spec.force, {source.imu_path, source.gnss_path});
  const AssembleOptions options = spec.assembly.assemble_options(gnss_quality_of(source));
  run.t0 = Clock::now();
  const GnssFile gnss = read_gnss_file(run, source.gnss_path, source.imu.gps_week);
  const std::optional<int> gnss_week = static_cast<int>(
      static_cast<double>(gnss.solution.epochs.front().t_gpst_unix_s - kGpsEpochGpstUnix_s) /
      kSecondsPerWeek);
  const std::string imu_text = read_text_log(source.imu_path, "--imu", run.read_options());
  const CsvImu imu = read_csv_imu(imu_text, source.imu_path, source.imu, gnss_week);
  Assembled result = assemble_dataset(imu, gnss.solution, options);

  const CsvImuSpec& csv = source.imu;
  nlohmann::json recorded_options = {
      {"columns", csv.columns},
      {"units", {{"time", csv.time_unit}, {"accel", csv.accel_unit}, {"gyro", csv.gyro_unit}}},
      {"imu_time", csv.time_scale},
      {"rate_samples", csv.rate_samples},
      {"gps_week", csv.gps_week ? nlohmann::json(*csv.gps_week) : nlohmann::json(nullptr)},
      {"imu_time_offset_s", csv.time_offset_s},
      {"mounting_rpy_deg",
       {csv.mounting_rpy_deg.x(), csv.mounting_rpy_deg.y(), csv.mounting_rpy_deg.z()}},
      {"mounting", "v_b = Rx(R) Ry(P) Rz(Y) v_s, applied at import"},
      {"gnss_quality", source.gnss_quality}};
  spec.assembly.record(recorded_options);
  finish_import(run, "insid import csv", std::move(result), std::move(recorded_options),
                {source_json("imu", source.imu_path, imu_text),
                 source_json("gnss", source.gnss_path, gnss.text)},
                spec.out_dir);
}

void import_source(ImportRun& run, const KfGinsImportSource& source) {
  const ImportSpec& spec = run.spec;
  dataset_destination(spec.out_dir, spec.force, {source.imu_path, source.gnss_path});
  const AssembleOptions options = spec.assembly.assemble_options(gnss_quality_of(source));
  run.t0 = Clock::now();
  const GnssFile gnss = read_gnss_file(run, source.gnss_path, source.gps_week);
  const std::string imu_text = read_text_log(source.imu_path, "--imu", run.read_options());
  const CsvImu imu = parse_kf_gins_imu(imu_text, source.imu_path, source.gps_week);
  Assembled result = assemble_dataset(imu, gnss.solution, options);
  if (gnss.solution.format.find("derived") != std::string::npos)
    result.notes.push_back(
        "GNSS velocity derived from positions by central differences (the "
        "file has no velocity columns); see README, insid import kf-gins");
  nlohmann::json opts = {
      {"gps_week", source.gps_week ? nlohmann::json(*source.gps_week) : nlohmann::json(nullptr)},
      {"axes", "body forward-right-down as KF-GINS defines its IMU file (no mounting applied)"}};
  spec.assembly.record(opts);
  finish_import(run, "insid import kf-gins", std::move(result), std::move(opts),
                {source_json("imu", source.imu_path, imu_text),
                 source_json("gnss", source.gnss_path, gnss.text)},
                spec.out_dir);
}

// One IMU instance of a parsed ULog, extracted and assembled in memory (nothing written).
PendingDataset assemble_ulog(const ImportRun& run, const UlogImportSource& source,
                             const UlogFile& log, const UlogImportOptions& ulog,
                             const AssembleOptions& options, std::string dir) {
  UlogSeries series = extract_ulog(log, source.log_path, ulog);
  Assembled result = assemble_dataset(series.imu, series.gnss, options,
                                      series.heading ? &*series.heading : nullptr);
  // The ULog clock is PX4's boot clock, not GPST: name the origin accordingly.
  nlohmann::json& prov = result.provenance;
  prov["time_origin_boot_s"] = prov["time_origin_gpst_unix_s"];
  prov.erase("time_origin_gpst_unix_s");
  prov.update(series.provenance, true);
  result.notes.insert(result.notes.begin(), series.notes.begin(), series.notes.end());
  if (!series.autopilot_estimates.is_null())
    result.dataset.meta.autopilot_estimates_json = series.autopilot_estimates.dump();
  nlohmann::json opts = {{"imu_topic", ulog.imu_topic.empty() ? "auto" : ulog.imu_topic},
                         {"imu_instance", ulog.imu_instance},
                         {"gnss_instance", ulog.gnss_instance},
                         {"min_fix_type", ulog.min_fix_type}};
  if (source.every_imu_instance) opts["imu_instance_option"] = kEveryImu;
  if (!ulog.heading.empty()) {  // only when given: earlier records stay as they were
    opts["heading"] = ulog.heading;
    if (ulog.heading == "mag") opts["mag_instance"] = ulog.mag_instance;
  }
  run.spec.assembly.record(opts);
  return {std::move(result), std::move(opts), std::move(dir)};
}

void import_source(ImportRun& run, const UlogImportSource& source) {
  const ImportSpec& spec = run.spec;
  UlogImportOptions ulog = source.options;
  if (source.every_imu_instance) ulog.imu_topic = kUlogMultiImuTopic;
  if (!source.every_imu_instance) dataset_destination(spec.out_dir, spec.force, {source.log_path});
  const AssembleOptions options = spec.assembly.assemble_options(gnss_quality_of(source));
  run.t0 = Clock::now();
  nlohmann::json log_source;
  const UlogFile log =
      UlogFile::parse(read_log(run, source.log_path, kUlogMagic,
                               "a PX4 ULog (magic 'ULog' 01 12 35)", "ulog", log_source),
                      source.log_path);
  std::vector<PendingDataset> pending;
  if (!source.every_imu_instance) {
    pending.push_back(assemble_ulog(run, source, log, ulog, options, spec.out_dir));
    finish_log_import(run, "insid import ulog", std::move(pending), log_source);
    return;
  }
  // Every vehicle_imu instance with data, into out_dir/vehicle_imu_K; all are assembled before
  // any is written (one that fails is named, and nothing is written).
  std::vector<int> present;
  for (const auto& [instance, n] : log.instances(kUlogMultiImuTopic))
    if (n > 0) present.push_back(instance);
  if (present.empty())
    throw std::runtime_error(source.log_path +
                             ": no vehicle_imu messages (--imu-instance all imports "
                             "each instance of vehicle_imu)");
  auto dir = [&](int instance) {
    return (fs::path(spec.out_dir) / ("vehicle_imu_" + std::to_string(instance))).string();
  };
  for (int instance : present) dataset_destination(dir(instance), spec.force, {source.log_path});
  for (int instance : present) {
    UlogImportOptions one = ulog;
    one.imu_instance = instance;
    try {
      pending.push_back(assemble_ulog(run, source, log, one, options, dir(instance)));
    } catch (const std::bad_alloc&) {
      throw;
    } catch (const std::exception& e) {
      throw std::runtime_error("--imu-instance all: vehicle_imu instance " +
                               std::to_string(instance) + " failed, nothing written: " + e.what() +
                               " (import the others one by one with --imu-instance K)");
    }
  }
  finish_log_import(run, "insid import ulog", std::move(pending), log_source);
}

// One IMU of a parsed DataFlash log, extracted and assembled in memory (nothing written): the
// flight phases told first, a logging gap refused naming where to cut.
PendingDataset assemble_ardupilot(const ImportRun& run, const ArduPilotImportSource& source,
                                  const DataFlashFile& log, const ArduPilotImportOptions& ardupilot,
                                  const AssembleOptions& options, std::string dir) {
  ArduPilotSeries series = extract_ardupilot(log, source.log_path, ardupilot);
  // The phases first, even when the import is refused below: they say where to cut.
  for (const std::string& line : series.phases.lines()) run.data_note(line);
  for (const auto& [boot_s, gap_s] : series.imu_gaps_boot_s)
    if (gap_s > PlausibilityBounds::kMaxImuStep_s) {
      char text[512];
      std::snprintf(text, sizeof text,
                    "%s: %s has a logging gap of %.3f s after boot time %.3f s, longer than the "
                    "%g s insid integrates across: import the part before it (--t-end %.3f) or "
                    "after it (--t-start %.3f)",
                    source.log_path.c_str(), ardupilot.imu.c_str(), gap_s, boot_s,
                    PlausibilityBounds::kMaxImuStep_s, boot_s, boot_s + gap_s);
      throw std::runtime_error(text);
    }
  Assembled result = assemble_dataset(series.imu, series.gnss, options);
  result.provenance.update(series.provenance, true);
  result.notes.insert(result.notes.begin(), series.notes.begin(), series.notes.end());
  if (!series.autopilot_estimates.is_null())
    result.dataset.meta.autopilot_estimates_json = series.autopilot_estimates.dump();
  nlohmann::json opts = {
      {"imu", ardupilot.imu},
      {"min_status", ardupilot.min_status},
      {"t_start_boot_s",
       ardupilot.t_start_s ? nlohmann::json(*ardupilot.t_start_s) : nlohmann::json(nullptr)},
      {"t_end_boot_s",
       ardupilot.t_end_s ? nlohmann::json(*ardupilot.t_end_s) : nlohmann::json(nullptr)},
      {"rate_samples", "point"},
      {"axes", "ArduPilot body frame, forward-right-down (no mounting applied)"}};
  if (source.every_imu) opts["imu_option"] = kEveryImu;
  run.spec.assembly.record(opts);
  return {std::move(result), std::move(opts), std::move(dir)};
}

void import_source(ImportRun& run, const ArduPilotImportSource& source) {
  const ImportSpec& spec = run.spec;
  if (!source.every_imu) {
    dataset_destination(spec.out_dir, spec.force, {source.log_path});
  } else {
    // Every IMU directory is checked before the work (the log itself never in the way).
    for (const char* name : kArduPilotImus)
      dataset_destination(fs::path(spec.out_dir) / name, spec.force, {source.log_path});
  }
  const AssembleOptions options = spec.assembly.assemble_options(gnss_quality_of(source));
  run.t0 = Clock::now();
  nlohmann::json log_source;
  const DataFlashFile log =
      DataFlashFile::parse(read_log(run, source.log_path, kDataFlashMagic,
                                    "an ArduPilot DataFlash log (records start with 0xA3 0x95)",
                                    "dataflash", log_source),
                           source.log_path);
  std::vector<PendingDataset> pending;
  if (!source.every_imu) {
    pending.push_back(assemble_ardupilot(run, source, log, source.options, options, spec.out_dir));
    finish_log_import(run, "insid import ardupilot", std::move(pending), log_source);
    return;
  }
  // Every IMU message the log has, each an ordinary dataset in out_dir/NAME with the same
  // options and window. All are assembled before any is written: one that fails is named and
  // nothing is written.
  std::vector<std::string> present;
  for (const char* name : kArduPilotImus)
    if (log.count(name) > 0) present.emplace_back(name);
  if (present.empty())
    throw std::runtime_error(source.log_path + ": no IMU, IMU2 or IMU3 messages (--imu all)");
  for (const std::string& name : present) {
    ArduPilotImportOptions one = source.options;
    one.imu = name;
    run.data_note("--imu all: " + name);
    try {
      pending.push_back(assemble_ardupilot(run, source, log, one, options,
                                           (fs::path(spec.out_dir) / name).string()));
    } catch (const std::bad_alloc&) {
      throw;
    } catch (const std::exception& e) {
      std::string done;
      for (std::size_t k = 0; k < pending.size(); ++k) done += (k ? ", " : "") + present[k];
      throw std::runtime_error("--imu all: " + name + " failed, nothing written" +
                               (done.empty() ? "" : " (" + done + " were fine)") + ": " + e.what() +
                               " (import the others one by one with --imu NAME)");
    }
  }
  finish_log_import(run, "insid import ardupilot", std::move(pending), log_source);
}

}  // namespace

std::string CsvImportSource::validate() const { return imu.validate(); }

std::string KfGinsImportSource::validate() const {
  if (gps_week && (*gps_week < 0 || *gps_week > 100000))
    return "--gps-week " + std::to_string(*gps_week) + ": must be in 0-100000";
  return "";
}

std::string UlogImportSource::validate() const {
  UlogImportOptions checked = options;
  if (every_imu_instance) {
    if (!options.imu_topic.empty() && options.imu_topic != kUlogMultiImuTopic)
      return "--imu-instance all imports every instance of vehicle_imu (one per physical IMU); "
             "--imu-topic '" +
             options.imu_topic + "' has one";
    checked.imu_topic = kUlogMultiImuTopic;
    checked.imu_instance = 0;  // not read
  }
  return checked.validate();
}

std::string ArduPilotImportSource::validate() const {
  ArduPilotImportOptions checked = options;
  if (every_imu) checked.imu = kArduPilotImus[0];  // not read: the others checked as for one IMU
  std::string e = checked.validate();
  if (e.rfind("--imu", 0) == 0)
    e += ", or all (every one the log has, into --out/IMU, --out/IMU2, --out/IMU3)";
  return e;
}

AssembleOptions ImportAssembly::assemble_options(std::set<int> gnss_quality) const {
  AssembleOptions options;
  options.gnss_quality = std::move(gnss_quality);
  options.align_s = align_s;
  options.static_speed_mps = static_speed_mps;
  options.static_rate_dps = static_rate_dps;
  options.static_accel_sd_mps2 = static_accel_sd_mps2;
  options.declination_deg = declination_deg;
  options.min_imu_rate_hz = min_imu_rate_hz;
  return options;
}

void ImportAssembly::record(nlohmann::json& options) const {
  options["align_s"] = align_s ? nlohmann::json(*align_s) : nlohmann::json(nullptr);
  options["static_speed_mps"] = static_speed_mps;
  options["static_rate_dps"] = static_rate_dps;
  options["static_accel_sd_mps2"] = static_accel_sd_mps2;
  if (declination_deg) options["declination_deg"] = *declination_deg;  // only when given
  options["min_imu_rate_hz"] = min_imu_rate_hz;
}

std::string ImportSpec::validate() const {
  if (std::string e = std::visit([](const auto& s) { return s.validate(); }, source); !e.empty())
    return e;
  if (!(std::isfinite(max_input_mb) && max_input_mb >= 1.0 && max_input_mb <= 1048576.0))
    return "--max-input-mb " + number_text(max_input_mb, 6) + ": must be in [1, 1048576] MiB";
  return assembly.assemble_options(gnss_quality_of(source)).validate();
}

ImportReport import_recording(const ImportSpec& spec, const ImportProgress& progress) {
  if (const std::string e = spec.validate(); !e.empty()) throw std::invalid_argument(e);
  ImportRun run{spec, progress, Clock::now(), {}};
  // Running out of memory anywhere (reading, parsing, assembling) is reported with the input
  // files named, never as a bare std::bad_alloc.
  try {
    std::visit([&run](const auto& source) { import_source(run, source); }, spec.source);
  } catch (const std::bad_alloc&) {
    throw std::runtime_error("out of memory while importing " + input_names(spec.source) +
                             " (split the log, or give the import more memory)");
  }
  return std::move(run.report);
}

}  // namespace insid::importers
