// insid import: a user's recording -> insid-dataset/2 directory with a provenance record
// (import/). Formats: csv (an IMU CSV with a mapping spec + an RTKLIB .pos GNSS solution).
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "core/dataset.h"
#include "core/digest.h"
#include "identification/identify.h"
#include "import/csv_imu.h"
#include "import/gnss_solution.h"
#include "import/importer.h"

namespace insid::cli {
namespace {
namespace fs = std::filesystem;

struct ImportCsvArgs {
  std::string imu, gnss, columns, units, imu_time = "gpst-unix", mounting, out;
  std::optional<int> gps_week;
  double time_offset_s = 0.0;
  std::vector<int> gnss_quality = {1, 2};
  std::optional<double> align_s;
  double static_speed_mps = 0.2;
  bool force = false;
};

std::string read_text(const std::string& path, const char* option) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec))
    throw std::invalid_argument(std::string(option) + " " + path + ": not a regular file");
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) throw std::invalid_argument(std::string(option) + " " + path + ": cannot open");
  std::string text;
  char buffer[1 << 16];
  std::size_t n = 0;
  while ((n = std::fread(buffer, 1, sizeof buffer, f)) > 0) text.append(buffer, n);
  const bool bad = std::ferror(f) != 0;
  std::fclose(f);
  if (bad) throw std::runtime_error(std::string(option) + " " + path + ": read error");
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

nlohmann::json source_json(const std::string& role, const std::string& path, const std::string& text) {
  return {{"role", role},
          {"path", path},
          {"file_name", fs::path(path).filename().string()},
          {"bytes", text.size()},
          {"sha256", sha256_hex(text)}};
}

void run_import_csv(const ImportCsvArgs& args) {
  dataset_destination(args.out, args.force);  // refuse a directory before the work
  import::CsvImuSpec spec;
  spec.columns = import::CsvImuSpec::parse_columns(args.columns);
  spec.parse_units(args.units);
  spec.time_scale = args.imu_time;
  spec.gps_week = args.gps_week;
  spec.time_offset_s = args.time_offset_s;
  if (!args.mounting.empty()) {
    const std::vector<double> rpy = parse_number_list(args.mounting, "--mounting-rpy-deg");
    if (rpy.size() != 3)
      throw std::invalid_argument("--mounting-rpy-deg: expected R,P,Y (three angles in degrees)");
    spec.mounting_rpy_deg = {rpy[0], rpy[1], rpy[2]};
  }
  if (const std::string e = spec.validate(); !e.empty()) throw std::invalid_argument(e);
  import::AssembleOptions options;
  options.gnss_quality = {args.gnss_quality.begin(), args.gnss_quality.end()};
  options.align_s = args.align_s;
  options.static_speed_mps = args.static_speed_mps;
  if (const std::string e = options.validate(); !e.empty()) throw std::invalid_argument(e);

  const auto t0 = std::chrono::steady_clock::now();
  const std::string gnss_text = read_text(args.gnss, "--gnss");
  if (!import::looks_like_rtklib_pos(gnss_text))
    throw std::invalid_argument("--gnss " + args.gnss +
                                ": not an RTKLIB solution file (no '%' header naming "
                                "latitude(deg)); the csv import reads RTKLIB .pos solutions");
  const import::GnssSolution gnss = import::parse_rtklib_pos(gnss_text, args.gnss);
  const std::optional<int> gnss_week = static_cast<int>(
      (gnss.epochs.front().t_gpst_unix_s - import::kGpsEpochGpstUnix_s) / import::kSecondsPerWeek);
  const std::string imu_text = read_text(args.imu, "--imu");
  const import::CsvImu imu = import::read_csv_imu(imu_text, args.imu, spec, gnss_week);
  import::Assembled result = import::assemble_dataset(imu, gnss, options);

  nlohmann::json& prov = result.provenance;
  prov["format"] = "insid-provenance/1";
  prov["command"] = "insid import csv";
  prov["insid"] = build_info_json();
  prov["sources"] = {source_json("imu", args.imu, imu_text), source_json("gnss", args.gnss, gnss_text)};
  prov["options"] = {{"columns", spec.columns},
                     {"units", {{"time", spec.time_unit}, {"accel", spec.accel_unit}, {"gyro", spec.gyro_unit}}},
                     {"imu_time", spec.time_scale},
                     {"gps_week", args.gps_week ? nlohmann::json(*args.gps_week) : nlohmann::json(nullptr)},
                     {"imu_time_offset_s", spec.time_offset_s},
                     {"mounting_rpy_deg", {spec.mounting_rpy_deg.x(), spec.mounting_rpy_deg.y(), spec.mounting_rpy_deg.z()}},
                     {"mounting", "v_b = Rx(R) Ry(P) Rz(Y) v_s, applied at import"},
                     {"gnss_quality", args.gnss_quality},
                     {"align_s", args.align_s ? nlohmann::json(*args.align_s) : nlohmann::json(nullptr)},
                     {"static_speed_mps", args.static_speed_mps}};
  DatasetWriteOptions write_options;
  write_options.into_foreign_directory = args.force;
  write_options.extra_files["provenance.json"] = prov.dump(2) + "\n";
  write_dataset(args.out, result.dataset, write_options);
  for (const std::string& note : result.notes) std::cerr << "insid import: " << note << "\n";
  const Dataset& ds = result.dataset;
  std::fprintf(stderr,
               "insid import: wrote %s (insid-dataset/2): %zu IMU rows (median %.4g Hz), %zu GNSS "
               "epochs (%.3g Hz), %.1f s, in %.2f s\n",
               args.out.c_str(), ds.imu.size(), ds.meta.imu_rate_hz, ds.gnss.size(),
               ds.meta.gnss_rate_hz, ds.imu.back().t_s - ds.imu.front().t_s,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
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
  csv->add_option("--imu", a->imu, "IMU CSV file (comma separated; a header line is skipped)")->required();
  csv->add_option("--columns", a->columns,
                  "role of each column in order: t,ax,ay,az,gx,gy,gz or - to ignore "
                  "(e.g. t,ax,ay,az,gx,gy,gz,-,-,-,-)")
      ->required();
  csv->add_option("--units", a->units,
                  "TIME,ACCEL,GYRO: s|ms|us, g|g-local|m/s^2|m/s (m/s = increments), "
                  "rad/s|deg/s|rad|deg (rad, deg = increments); g = 9.80665 m/s^2, g-local = the "
                  "normal gravity at the first GNSS position")
      ->required();
  csv->add_option("--gnss", a->gnss, "GNSS solution: RTKLIB .pos (llh, GPST, with velocity)")->required();
  csv->add_option("--imu-time", a->imu_time, "IMU time scale: gpst-unix | gps-sow")->capture_default_str();
  csv->add_option("--gps-week", a->gps_week, "GPS week for --imu-time gps-sow (default: the GNSS file's)")
      ->check(whole_in(0, 100000));
  csv->add_option("--imu-time-offset-s", a->time_offset_s, "added to every IMU time (s)")
      ->check(number_in(-86400, 86400));
  csv->add_option("--mounting-rpy-deg", a->mounting,
                  "R,P,Y: v_body = Rx(R) Ry(P) Rz(Y) v_sensor (passive rotations, the matrix roll/"
                  "pitch/yaw give for C_n^b); e.g. 180,0,-90 turns a resting +1 g on sensor z into "
                  "-1 g on body z (FRD)");
  csv->add_option("--gnss-quality", a->gnss_quality, "RTKLIB quality flags kept (default 1 2: fix, float)")
      ->check(whole_in(1, 7));
  csv->add_option("--align-s", a->align_s,
                  "static alignment window (s); default: until 1 s before the GNSS shows motion")
      ->check(number_in(0, 86400));
  csv->add_option("--static-speed", a->static_speed_mps,
                  "GNSS horizontal speed (m/s) above which the unit is moving (default 0.2)")
      ->check(number_in(1e-6, 10));
  csv->add_option("--out", a->out, "output dataset directory (new, empty or an insid dataset)")->required();
  csv->add_flag("--force", a->force, "write into a --out directory that holds other files");
  csv->callback([a] { run_import_csv(*a); });
}

}  // namespace insid::cli
