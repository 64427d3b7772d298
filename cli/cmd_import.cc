// insid import: a user's recording -> insid-dataset/2 directory with a provenance record. Each
// format's options fill an importers::ImportSpec; the import is the library's
// (import/import_recording.h). Formats: csv (an IMU CSV with a mapping spec + an RTKLIB .pos
// GNSS solution), kf-gins, ulog (PX4) and ardupilot (DataFlash .bin). The other way,
// `insid export`: cmd_export.cc.
#include <charconv>
#include <cmath>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "cli/progress.h"
#include "import/import_recording.h"

namespace insid::cli {
namespace {

using importers::ImportSpec;

/// --imu / --imu-instance value that imports every IMU of a log.
constexpr const char* kEveryImu = "all";

// A subcommand's command line: the spec its options fill (the source's part and the options
// every import takes), and the verbosity.
template <class Source>
struct ImportArgs {
  ImportArgs() { spec.source = Source{}; }
  ImportSpec spec;
  Verbosity verbosity = Verbosity::kNormal;
  Source& source() { return std::get<Source>(spec.source); }
};

// The options every import subcommand takes: the assembly's static window and IMU rate, the
// input size limit, the output directory and the verbosity.
void add_shared_import_options(CLI::App* sub, ImportSpec& spec, Verbosity& verbosity) {
  importers::ImportAssembly& a = spec.assembly;
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
  sub->add_option("--max-input-mb", spec.max_input_mb,
                  "largest input file read (MiB; each is read whole, checked before reading: an "
                  "honest bigger log needs about twice its size in memory)")
      ->capture_default_str()
      ->check(number_in(1, 1048576));
  sub->add_option("--out", spec.out_dir,
                  "output dataset directory (new, empty or an insid dataset)")
      ->required();
  sub->add_flag("--force", spec.force, "write into a --out directory that holds other files");
  add_verbosity_flags(sub, verbosity);
}

// Runs the spec the command line filled: what validate() refuses is a usage error, found before
// any work. The import's notes about the data are printed even with --quiet.
void run_import(const ImportSpec& spec, Verbosity verbosity) {
  if (const std::string e = spec.validate(); !e.empty()) throw UsageError(e);
  ProgressPrinter progress("insid import", verbosity);
  importers::ImportProgress reporting;
  reporting.data_note = [](const std::string& text) {
    std::cerr << "insid import: " << text << "\n";
  };
  reporting.note = [&progress](const std::string& text) { progress.note(text); };
  importers::import_recording(spec, reporting);
}

// The csv subcommand's options that are text to parse into the spec.
struct ImportCsvArgs : ImportArgs<importers::CsvImportSource> {
  std::string columns, units, mounting;
  std::optional<double> time_offset_s;  // required with --imu-time relative
};

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

void run_import_csv(const ImportCsvArgs& args) {
  ImportSpec spec = args.spec;
  importers::CsvImuSpec& imu = std::get<importers::CsvImportSource>(spec.source).imu;
  imu.columns =
      parse_option("--columns", [&] { return importers::CsvImuSpec::parse_columns(args.columns); });
  parse_option("--units", [&] {
    imu.parse_units(args.units);
    return 0;
  });
  if (imu.time_scale == "relative" && !args.time_offset_s)
    throw UsageError(
        "--imu-time relative needs --imu-time-offset-s: the GPS time of week (s) at the logger's "
        "zero, so that the IMU can be paired with the GNSS solution");
  imu.time_offset_s = args.time_offset_s.value_or(0.0);
  if (!args.mounting.empty()) {
    const std::vector<double> rpy = parse_option("--mounting-rpy-deg", [&] {
      return parse_number_list(args.mounting, "--mounting-rpy-deg");
    });
    if (rpy.size() != 3)
      throw UsageError("--mounting-rpy-deg: expected R,P,Y (three angles in degrees)");
    imu.mounting_rpy_deg = {rpy[0], rpy[1], rpy[2]};
  }
  run_import(spec, args.verbosity);
}

// --imu-instance: a whole number 0-255, or all.
struct ImportUlogArgs : ImportArgs<importers::UlogImportSource> {
  std::string imu_instance = "0";
};

void run_import_ulog(const ImportUlogArgs& args) {
  ImportSpec spec = args.spec;
  importers::UlogImportSource& ulog = std::get<importers::UlogImportSource>(spec.source);
  ulog.every_imu_instance = args.imu_instance == kEveryImu;
  if (!ulog.every_imu_instance) {
    ulog.options.imu_instance = parse_option("--imu-instance", [&] {
      int v = -1;
      const std::string& t = args.imu_instance;
      const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
      if (ec != std::errc() || end != t.data() + t.size() || v < 0 || v > 255)
        throw std::invalid_argument("--imu-instance '" + t +
                                    "': must be a whole number in 0-255, or all");
      return v;
    });
  }
  run_import(spec, args.verbosity);
}

void run_import_ardupilot(const ImportArgs<importers::ArduPilotImportSource>& args) {
  ImportSpec spec = args.spec;
  importers::ArduPilotImportSource& ardupilot =
      std::get<importers::ArduPilotImportSource>(spec.source);
  ardupilot.every_imu = ardupilot.options.imu == kEveryImu;
  run_import(spec, args.verbosity);
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
  csv->add_option("--imu", a->source().imu_path,
                  "IMU CSV file (comma separated; a header line is skipped)")
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
  csv->add_option("--gnss", a->source().gnss_path,
                  "GNSS solution: RTKLIB .pos (llh, GPST, with velocity)")
      ->required();
  csv->add_option("--imu-time", a->source().imu.time_scale,
                  "IMU time scale: gpst-unix | gps-sow | relative (seconds from the logger's zero; "
                  "--imu-time-offset-s gives its GPS time of week)")
      ->capture_default_str();
  csv->add_option("--rate-samples", a->source().imu.rate_samples,
                  "rate rows are point (the rate at each stamp: trapezoid) | interval-mean (the "
                  "mean over the step each row closes: times the step)")
      ->capture_default_str();
  csv->add_option("--gps-week", a->source().imu.gps_week,
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
  csv->add_option("--gnss-quality", a->source().gnss_quality,
                  "RTKLIB quality flags kept (default 1 2: fix, float)")
      ->check(whole_in(1, 7));
  add_shared_import_options(csv, a->spec, a->verbosity);
  csv->callback([a] { run_import_csv(*a); });

  auto k = std::make_shared<ImportArgs<importers::KfGinsImportSource>>();
  CLI::App* kf = cmd->add_subcommand(
      "kf-gins",
      "KF-GINS text files: IMU (SOW, dtheta xyz rad, dvel xyz m/s, FRD) and GNSS (7 columns, "
      "velocity then derived from positions; or 13 with velocity), or an RTKLIB .pos as --gnss");
  kf->add_option("--imu", k->source().imu_path, "KF-GINS IMU text file")->required();
  kf->add_option("--gnss", k->source().gnss_path, "KF-GINS GNSS text file or RTKLIB .pos")
      ->required();
  kf->add_option("--gps-week", k->source().gps_week,
                 "GPS week of the seconds-of-week times (recorded; default 0)")
      ->check(whole_in(0, 100000));
  add_shared_import_options(kf, k->spec, k->verbosity);
  kf->callback([k] { run_import(k->spec, k->verbosity); });

  auto u = std::make_shared<ImportUlogArgs>();
  CLI::App* ul = cmd->add_subcommand(
      "ulog",
      "a PX4 flight log (.ulg): IMU from vehicle_imu (increments) or sensor_combined, GNSS from "
      "vehicle_gps_position or sensor_gps, layouts read from the file's own formats");
  ul->add_option("log", u->source().log_path, "the .ulg file")->required();
  ul->add_option("--imu-topic", u->source().options.imu_topic,
                 "vehicle_imu | sensor_combined (default: the one with more samples)");
  ul->add_option("--imu-instance", u->imu_instance,
                 "multi-instance IMU topic: which one (default 0); all: every vehicle_imu "
                 "instance, each an ordinary dataset in --out/vehicle_imu_K (for insid "
                 "cross-imu)")
      ->capture_default_str();
  ul->add_option("--gnss-instance", u->source().options.gnss_instance,
                 "which GNSS instance (default 0)")
      ->check(whole_in(0, 255));
  ul->add_option("--min-fix-type", u->source().options.min_fix_type,
                 "PX4 fix_type kept: 3 = 3D (default), 4 = DGPS, 5 = RTK float, 6 = RTK fixed")
      ->check(whole_in(0, 8));
  ul->add_option("--heading", u->source().options.heading,
                 "a measured heading into heading.csv: gps (the GNSS topic's dual-antenna "
                 "'heading') | mag (sensor_mag or vehicle_magnetometer; needs --declination-deg)");
  ul->add_option("--mag-instance", u->source().options.mag_instance,
                 "--heading mag: which magnetometer instance (default 0)")
      ->check(whole_in(0, 255));
  add_shared_import_options(ul, u->spec, u->verbosity);
  ul->callback([u] { run_import_ulog(*u); });

  auto ap = std::make_shared<ImportArgs<importers::ArduPilotImportSource>>();
  CLI::App* apc = cmd->add_subcommand(
      "ardupilot",
      "an ArduPilot DataFlash log (.bin): IMU, IMU2 or IMU3 (sampled rates and specific forces), "
      "GPS fixes (Spd along GCrs, VZ), layouts read from the file's own FMT records");
  apc->add_option("log", ap->source().log_path, "the .bin file")->required();
  apc->add_option("--imu", ap->source().options.imu,
                  "IMU | IMU2 | IMU3: which IMU (default IMU); all: every IMU the log has, each "
                  "an ordinary dataset in --out/IMU, --out/IMU2, --out/IMU3 (same options and "
                  "window; for insid cross-imu)")
      ->capture_default_str();
  apc->add_option("--min-status", ap->source().options.min_status,
                  "GPS Status kept: 3 = 3D fix (default) and above")
      ->check(whole_in(0, 6));
  apc->add_option("--t-start", ap->source().options.t_start_s,
                  "boot time (s) from which records are kept")
      ->check(number_in(0, 1e7));
  apc->add_option("--t-end", ap->source().options.t_end_s,
                  "boot time (s) after which records are cut (e.g. before a crash)")
      ->check(number_in(0, 1e7));
  add_shared_import_options(apc, ap->spec, ap->verbosity);
  apc->callback([ap] { run_import_ardupilot(*ap); });
}

}  // namespace insid::cli
