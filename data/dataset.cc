// Dataset I/O for `insid-dataset/1` (docs/design.md sec. 5).
//
// Decisions (beyond the design notes):
// - CSV: the header must list exactly the format's columns, in order (a UTF-8 BOM, spaces
//   around names and a trailing CR are tolerated); unknown extra columns are rejected. Fields
//   may carry surrounding spaces and a leading '+'. Blank lines are allowed only at the end.
// - Numbers are parsed with std::from_chars (whole file read at once) and written with the
//   shortest representation that round-trips (std::to_chars), so SI values round-trip exactly.
// - Angles are stored in degrees and converted once at load with `deg * kDegToRad`. The writer
//   picks, among the doubles next to `rad * kRadToDeg`, one that maps back to exactly the same
//   radians (preferring the shortest text), so every value load can produce round-trips bit
//   for bit; a radian value that no degree double maps to comes back within 1 ulp. Yaw is
//   written in [0, 360) deg (load keeps whatever the file says).
// - write_dataset validates first (it never writes a dataset load_dataset would reject),
//   creates missing parent directories, writes to a sibling temporary directory and renames it
//   into place; on failure it removes everything it created. It replaces only a directory that
//   holds nothing but an insid dataset (base/output_dir.h); with --force it adds its files to
//   any other directory and deletes nothing.
// - Latitudes must lie strictly inside (-90, 90) deg: the ENU mechanization is singular at the
//   poles.
#include "data/dataset.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/xattr.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <string_view>
#include <system_error>

#include <nlohmann/json.hpp>

#include "base/digest.h"
#include "base/enum_table.h"
#include "base/file_read.h"
#include "base/json_object.h"
#include "base/json_reader.h"
#include "base/number_text.h"
#include "base/output_dir.h"
#include "model/sensor_errors.h"

namespace insid {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr std::string_view kFormat = "insid-dataset/1";
constexpr std::string_view kFormat2 = "insid-dataset/2";
constexpr std::string_view kImuFile = "imu.csv";
constexpr std::string_view kGnssFile = "gnss.csv";
constexpr std::string_view kTruthFile = "truth.csv";
constexpr std::string_view kMetaFile = "meta.json";
constexpr std::string_view kHeadingFile = "heading.csv";

constexpr std::array<std::string_view, 7> kImuColumns = {
    "t_s", "dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad", "dv_x_mps", "dv_y_mps", "dv_z_mps"};
constexpr std::array<std::string_view, 7> kGnssColumns = {"t_s",    "lat_deg", "lon_deg", "h_m",
                                                          "vE_mps", "vN_mps",  "vU_mps"};
constexpr std::array<std::string_view, 10> kTruthColumns = {
    "t_s",    "lat_deg", "lon_deg",  "h_m",       "vE_mps",
    "vN_mps", "vU_mps",  "roll_deg", "pitch_deg", "yaw_deg"};

// heading.csv: with or without the per-sample sd (the header says which).
constexpr std::array<std::string_view, 2> kHeadingColumns = {"t_s", "heading_deg"};
constexpr std::array<std::string_view, 3> kHeadingSdColumns = {"t_s", "heading_deg", "sd_deg"};

constexpr double kImuRateTolerance = 0.01;  // each IMU dt within 1% of 1 / imu_rate_hz
constexpr double kGnssEndAllowance = 1.5;   // GNSS may end 1.5 GNSS periods before the IMU

[[noreturn]] void fail(const std::string& message) { throw DatasetError(message); }

template <std::size_t N>
std::string join(const std::array<std::string_view, N>& cols) {
  std::string s;
  for (std::size_t i = 0; i < N; ++i) {
    if (i) s += ',';
    s += cols[i];
  }
  return s;
}

void append_num(std::string& out, double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

// Quote untrusted text for an error message (shortened, control characters escaped).
std::string quote_text(std::string_view text) {
  constexpr std::size_t kMax = 40;
  std::string s = "'";
  for (std::size_t i = 0; i < text.size() && i < kMax; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 || c == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      s += buf;
    } else {
      s += static_cast<char>(c);
    }
  }
  if (text.size() > kMax) s += "...";
  s += "'";
  return s;
}

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  return s;
}

bool all_whitespace(const char* p, const char* end) {
  for (; p < end; ++p)
    if (!(is_blank(*p) || *p == '\n')) return false;
  return true;
}

// ------------------------------------------------------------------------------------------
// Reading

// Whole file into memory (base/file_read.h). `where` names it in messages.
std::string read_whole_file(const fs::path& path, const std::string& where) {
  FileReadOptions options;
  options.not_regular_hint = "; a dataset's files must be regular files";
  try {
    return read_file_whole(path, where, options);
  } catch (const FileReadError& e) {
    fail(e.what());
  }
}

// Location prefix of a CSV message: "<dir>: imu.csv line 12, column dv_x_mps: ".
struct CsvWhere {
  std::string prefix;  // "<dir>: " or ""
  std::string_view file;

  std::string at(std::size_t line, std::string_view column) const {
    std::string s = prefix;
    s += file;
    s += " line " + std::to_string(line);
    if (!column.empty()) {
      s += ", column ";
      s += column;
    }
    s += ": ";
    return s;
  }
};

// Parse one numeric field; `field` is untrimmed.
inline double parse_field(std::string_view field, const CsvWhere& where, std::size_t line,
                          std::string_view column) {
  field = trim(field);
  if (field.empty()) fail(where.at(line, column) + "empty field, expected a number");
  const char* first = field.data();
  const char* last = first + field.size();
  if (*first == '+' && field.size() > 1 && first[1] != '-' && first[1] != '+') ++first;
  double v = 0.0;
  const auto r = std::from_chars(first, last, v, std::chars_format::general);
  if (r.ec == std::errc::result_out_of_range && r.ptr == last)
    fail(where.at(line, column) + "number out of the double range, got " + quote_text(field));
  if (r.ec != std::errc() || r.ptr != last)
    fail(where.at(line, column) + "expected a number, got " + quote_text(field));
  if (!std::isfinite(v))
    fail(where.at(line, column) + "expected a finite number, got " + quote_text(field));
  return v;
}

template <std::size_t N>
void check_header(std::string_view header, const std::array<std::string_view, N>& cols,
                  const CsvWhere& where) {
  std::vector<std::string_view> got;
  for (;;) {
    const std::size_t comma = header.find(',');
    got.push_back(trim(header.substr(0, comma)));
    if (comma == std::string_view::npos) break;
    header.remove_prefix(comma + 1);
  }
  if (got.size() == N && std::equal(got.begin(), got.end(), cols.begin())) return;

  std::string got_text;
  for (std::size_t i = 0; i < got.size(); ++i) {
    if (i) got_text += ',';
    got_text += got[i];
  }
  const std::string tail = "; expected header '" + join(cols) + "', got " + quote_text(got_text);
  for (const auto& c : cols)
    if (std::find(got.begin(), got.end(), c) == got.end())
      fail(where.at(1, c) + "missing column" + tail);
  for (const auto& g : got)
    if (std::find(cols.begin(), cols.end(), g) == cols.end())
      fail(where.at(1, g.empty() ? std::string_view("(empty name)") : g) + "unknown column" + tail);
  for (std::size_t i = 0; i < std::min(got.size(), N); ++i)
    if (got[i] != cols[i])
      fail(where.at(1, cols[i]) + "column out of order (found '" + std::string(got[i]) +
           "' in its place)" + tail);
  fail(where.at(1, "") + "duplicate column" + tail);
}

// Parse a CSV file with exactly the columns `cols`; on_row(const double* values, line).
template <std::size_t N, class OnRow>
void parse_csv(const std::string& text, const std::array<std::string_view, N>& cols,
               const CsvWhere& where, OnRow&& on_row) {
  const char* p = text.data();
  const char* const end = p + text.size();
  if (text.size() >= 3 && std::memcmp(p, "\xEF\xBB\xBF", 3) == 0) p += 3;  // UTF-8 BOM
  if (all_whitespace(p, end))
    fail(where.prefix + std::string(where.file) + " line 1: empty file, expected the header '" +
         join(cols) + "'");

  auto next_line = [&](const char*& cur) -> std::string_view {
    const char* nl = static_cast<const char*>(std::memchr(cur, '\n', end - cur));
    const char* line_end = nl ? nl : end;
    std::string_view line(cur, line_end - cur);
    cur = nl ? nl + 1 : end;
    while (!line.empty() && is_blank(line.back())) line.remove_suffix(1);
    return line;
  };

  check_header(next_line(p), cols, where);

  std::array<double, N> values{};
  std::size_t line_no = 1;
  while (p < end) {
    ++line_no;
    const char* const line_start = p;
    const std::string_view line = next_line(p);
    if (trim(line).empty()) {
      if (all_whitespace(line_start, end)) break;  // trailing blank lines
      fail(where.at(line_no, "") +
           "empty line (blank lines are only allowed at the end of the file)");
    }
    const char* f = line.data();
    const char* const lend = f + line.size();
    for (std::size_t i = 0; i < N; ++i) {
      const char* comma = static_cast<const char*>(std::memchr(f, ',', lend - f));
      if (i + 1 < N) {
        if (!comma)
          fail(where.at(line_no, cols[i + 1]) + "truncated row, expected " + std::to_string(N) +
               " fields (" + join(cols) + "), got " + std::to_string(i + 1));
      } else if (comma) {
        const std::size_t extra = static_cast<std::size_t>(std::count(comma, lend, ','));
        fail(where.at(line_no, "") + "too many fields, expected " + std::to_string(N) + " (" +
             join(cols) + "), got " + std::to_string(N + extra));
      }
      const char* fend = comma ? comma : lend;
      values[i] = parse_field(std::string_view(f, fend - f), where, line_no, cols[i]);
      f = fend + 1;
    }
    on_row(values.data(), line_no);
  }
}

// What write_dataset records of each data file in meta.json ("files"), and load_dataset checks:
// the number of data rows (catches a file cut or extended at a line boundary) and the SHA-256 of
// its values as parsed (IEEE-754 bits, Sha256::update_doubles), which catches any changed value
// while a line-ending conversion, a BOM or blank padding (which change no value) do not count.
struct RecordedFile {
  std::size_t rows = 0;
  std::string sha256;
};

// parse_csv that also returns the file's RecordedFile (rows and digest of the values).
template <std::size_t N, class OnRow>
RecordedFile parse_csv_recorded(const std::string& text,
                                const std::array<std::string_view, N>& cols, const CsvWhere& where,
                                OnRow&& on_row) {
  RecordedFile record;
  Sha256 sha;
  parse_csv(text, cols, where, [&](const double* values, std::size_t line) {
    sha.update_doubles(values, N);
    ++record.rows;
    on_row(values, line);
  });
  record.sha256 = sha.hex();
  return record;
}

// heading.csv, with or without its sd column: the header's field count picks the column set
// (the header check then names any wrong or missing column). on_row(t_s, heading_deg, sd_deg or
// NaN, line).
template <class OnRow>
RecordedFile parse_heading_csv(const std::string& text, const CsvWhere& where, OnRow&& on_row) {
  std::string_view body(text);
  if (body.size() >= 3 && body.substr(0, 3) == "\xEF\xBB\xBF") body.remove_prefix(3);
  const std::string_view header = body.substr(0, body.find('\n'));
  if (std::count(header.begin(), header.end(), ',') >= 2)
    return parse_csv_recorded(text, kHeadingSdColumns, where,
                              [&](const double* v, std::size_t l) { on_row(v[0], v[1], v[2], l); });
  return parse_csv_recorded(text, kHeadingColumns, where, [&](const double* v, std::size_t l) {
    on_row(v[0], v[1], std::numeric_limits<double>::quiet_NaN(), l);
  });
}

// ------------------------------------------------------------------------------------------
// meta.json

// The keys insid has written into meta.json (every one ever: a dataset written earlier reads).
// Other keys at the top level are left alone (a dataset made by hand may carry its notes,
// "comment"); the blocks insid defines (earth, initial, noise, heading, files) refuse a key
// they do not have, naming theirs.
const std::vector<std::string> kMetaKeys = {"format",
                                            "imu_rate_hz",
                                            "gnss_rate_hz",
                                            "earth",
                                            "align_s",
                                            "initial",
                                            "injected",
                                            "noise",
                                            "heading",
                                            "files",
                                            "autopilot_estimates",
                                            "motors"};

// meta.json's "heading": {"source": ...}.
constexpr EnumTable<HeadingSourceKind, 2> kHeadingSourceKindNames{
    "heading source",
    {{{HeadingSourceKind::kDualAntenna, "dual_antenna"},
      {HeadingSourceKind::kMagnetometer, "magnetometer"}}}};

// The fields of meta.json through insid's one typed reader (base/json_object.h): errors name the
// field's path ("<dir>: meta.json: initial.lat_deg: expected a finite number, found ...").
// `files` receives the "files" block (the data files' rows and digests) when meta.json has one.
DatasetMeta read_meta_fields(const json& j, const std::string& source,
                             std::map<std::string, RecordedFile>& files) {
  const JsonObject r = JsonObject::with_other_keys(j, source, "", kMetaKeys);
  DatasetMeta m;
  m.format = r.field("format").choice({kFormat, kFormat2}) == kFormat ? DatasetFormat::kV1
                                                                      : DatasetFormat::kV2;
  m.imu_rate_hz = r.number("imu_rate_hz");
  m.gnss_rate_hz = r.number("gnss_rate_hz");
  const JsonObject earth = r.object("earth", {"a_m", "f", "omega_ie_rad_s", "g_eq_mps2"});
  m.earth.ellipsoid.a_m = earth.number("a_m");
  m.earth.ellipsoid.f = earth.number("f");
  m.earth.omega_ie_rad_s = earth.number("omega_ie_rad_s");
  m.earth.g_eq_mps2 = earth.number("g_eq_mps2");
  m.align_s = r.number("align_s");

  const JsonObject ini =
      r.object("initial", {"t_s", "lat_deg", "lon_deg", "h_m", "vE_mps", "vN_mps", "vU_mps",
                           "roll_deg", "pitch_deg", "yaw_deg"});
  m.initial.t_s = ini.number("t_s");
  m.initial.lat_rad = ini.number("lat_deg") * kDegToRad;
  m.initial.lon_rad = ini.number("lon_deg") * kDegToRad;
  m.initial.h_m = ini.number("h_m");
  m.initial.v_eb_n_mps = {ini.number("vE_mps"), ini.number("vN_mps"), ini.number("vU_mps")};
  // insid-dataset/2: an unknown initial attitude is written as roll/pitch/yaw null.
  if (m.format == DatasetFormat::kV2 && ini.has("roll_deg") && ini.field("roll_deg").is_null()) {
    for (const char* key : {"pitch_deg", "yaw_deg"})
      if (!ini.field(key).is_null())
        ini.fail(key, "must be null like initial.roll_deg (an unknown attitude is unknown whole)");
    m.initial_attitude_known = false;
  } else {
    m.initial.attitude.roll_rad = ini.number("roll_deg") * kDegToRad;
    m.initial.attitude.pitch_rad = ini.number("pitch_deg") * kDegToRad;
    m.initial.attitude.yaw_rad = ini.number("yaw_deg") * kDegToRad;
  }

  // Optional parts: absent or null means "not given".
  if (const std::optional<JsonField> injected = r.optional_given("injected")) {
    const JsonObject inj = injected->map();
    std::map<std::string, double> values;
    for (const auto& item : inj.value().items()) {
      const std::string& name = item.key();
      if (!is_effect_name(name)) {
        std::string known;
        for (const auto& e : effect_catalogue()) {
          if (!known.empty()) known += ", ";
          known += e.name;
        }
        inj.fail(name, "unknown effect name \"" + name + "\"; the effect catalogue has: " + known);
      }
      values[name] = inj.number(name);
    }
    m.injected = std::move(values);
  }
  if (const std::optional<JsonField> noise_field = r.optional_given("noise")) {
    const JsonObject noise = noise_field->object(
        {"arw_deg_rth", "vrw_mps_rth", "gnss_vel_sigma_mps", "gnss_pos_sigma_m"});
    NoiseLevels n;
    n.arw_deg_rth = noise.number("arw_deg_rth");
    n.vrw_mps_rth = noise.number("vrw_mps_rth");
    n.gnss_vel_sigma_mps = noise.number("gnss_vel_sigma_mps");
    n.gnss_pos_sigma_m = noise.number("gnss_pos_sigma_m");
    m.noise = n;
  }
  if (const std::optional<JsonField> heading_field = r.optional_given("heading")) {
    const JsonObject heading = heading_field->object({"source", "declination_deg"});
    HeadingMeta h;
    h.source = heading.field("source").choice(kHeadingSourceKindNames);
    if (heading.given("declination_deg")) h.declination_deg = heading.number("declination_deg");
    m.heading = h;
  }
  if (const std::optional<JsonField> motors_field = r.optional_given("motors")) {
    const JsonObject motors = motors_field->object({"source", "on_s"});
    m.motors_source = motors.string("source");
    m.motors = read_motor_schedule(motors.array("on_s"));
  }
  if (const std::optional<JsonField> ap = r.optional_given("autopilot_estimates"))
    m.autopilot_estimates_json = ap->map().value().dump();  // kept verbatim, never computed with
  if (const std::optional<JsonField> recorded = r.optional_given("files")) {
    const JsonObject records = recorded->map();
    for (const auto& item : records.value().items()) {
      const std::string& name = item.key();
      if (name != kImuFile && name != kGnssFile && name != kTruthFile && name != kHeadingFile)
        records.fail(name,
                     "not a data file of a dataset (imu.csv, gnss.csv, truth.csv, "
                     "heading.csv)");
      const JsonObject record = records.object(name, {"rows", "sha256"});
      // Row counts up to 2^53, where doubles (JSON numbers) still count every integer.
      const std::int64_t rows = record.field("rows").integer(0, std::int64_t{1} << 53);
      const std::string digest = record.string("sha256");
      if (digest.size() != 64 || digest.find_first_not_of("0123456789abcdef") != std::string::npos)
        record.fail("sha256", "expected 64 lowercase hex digits, found " +
                                  describe_json_value(record.field("sha256").value()));
      files[name] = {static_cast<std::size_t>(rows), digest};
    }
  }
  return m;
}

// `files` receives the "files" block (the data files' rows and digests) when meta.json has one.
DatasetMeta parse_meta(const std::string& text, const std::string& dir_prefix,
                       std::map<std::string, RecordedFile>& files) {
  const std::string source = dir_prefix + std::string(kMetaFile);  // "<dir>: meta.json"
  if (all_whitespace(text.data(), text.data() + text.size()))
    fail(json_field_message(source, "", "empty file, expected a JSON object"));
  try {
    return read_meta_fields(parse_json_strict(text, source), source, files);
  } catch (const std::runtime_error& e) {
    fail(e.what());  // not strict JSON (with line and column), or a key given twice
  } catch (const JsonFieldError& e) {
    fail(e.what());  // a field: unknown, missing, of the wrong type or value
  }
}

// A data file against what meta.json recorded when insid wrote it (after every other check, so
// that a malformed value is reported as such first).
void check_recorded(const std::map<std::string, RecordedFile>& files, std::string_view name,
                    const RecordedFile& found, const std::string& prefix) {
  const auto it = files.find(std::string(name));
  if (it == files.end()) return;
  const std::string where = prefix + std::string(name) + ": ";
  const std::string undo = "; if the change is intended, remove \"files\" from meta.json";
  if (found.rows != it->second.rows)
    fail(where + "holds " + std::to_string(found.rows) + " data rows, but meta.json (files." +
         std::string(name) + ".rows) records " + std::to_string(it->second.rows) +
         " written by insid: the file was cut or extended since" + undo);
  if (found.sha256 != it->second.sha256)
    fail(where + "its values differ from those whose SHA-256 meta.json (files." +
         std::string(name) + ".sha256) records: the file was edited since insid wrote it" + undo);
}

// ------------------------------------------------------------------------------------------
// Validation

struct Validator {
  std::string prefix;  // "<dir>: " or ""
  const DatasetSources* sources = nullptr;

  [[noreturn]] void meta_fail(const std::string& msg) const {
    fail(prefix + std::string(kMetaFile) + ": " + msg);
  }
  // `field` ("align_s") and `rest` (" = 1000 s must ..."): "meta.json: field "align_s" = ..."
  // or, where the sources name what set the field, "--align-s = 1000 s must ...".
  [[noreturn]] void field_fail(std::string_view field, const std::string& rest) const {
    if (sources && sources->field)
      if (const std::string by = sources->field(field); !by.empty()) fail(prefix + by + rest);
    meta_fail("field \"" + std::string(field) + "\"" + rest);
  }
  // The row `index` of `file` inside a message about that file: "line 7" (header = line 1), or
  // where the row came from ("rover.pos line 201").
  std::string row(std::string_view file, std::size_t index) const {
    if (sources && sources->row)
      if (const std::string s = sources->row(file, index); !s.empty()) return s;
    return "line " + std::to_string(index + 2);
  }
  // The same with the file named: "imu.csv line 7", or where the row came from.
  std::string file_row(std::string_view file, std::size_t index) const {
    if (sources && sources->row)
      if (const std::string s = sources->row(file, index); !s.empty()) return s;
    return std::string(file) + " line " + std::to_string(index + 2);
  }
  std::string at(std::string_view file, std::size_t index, std::string_view column) const {
    if (sources && sources->row)
      if (const std::string s = sources->row(file, index); !s.empty())
        return s + " (" + std::string(column) + "): ";
    return CsvWhere{prefix, file}.at(index + 2, column);  // header is line 1
  }

  void finite(std::string_view file, std::size_t index, std::string_view column, double v) const {
    if (!std::isfinite(v))
      fail(at(file, index, column) + "expected a finite number, got " + number_text(v));
  }

  // |v| <= bound, else "<file> line, column: <what> <v> <unit> is beyond the plausibility
  // bound <bound> <unit> (<why>)".
  void bounded(std::string_view file, std::size_t index, std::string_view column, double v,
               double bound, std::string_view what, std::string_view unit,
               std::string_view why) const {
    if (!(std::fabs(v) <= bound))
      fail(at(file, index, column) + std::string(what) + " " + number_text(v) + " " +
           std::string(unit) + " is beyond the plausibility bound " + number_text(bound) + " " +
           std::string(unit) + " (" + std::string(why) + ")");
  }

  // Longitude, height and velocity of a GNSS or truth row.
  void position_velocity(std::string_view file, std::size_t index, double lon_rad, double h_m,
                         const Eigen::Vector3d& v_eb_n_mps) const {
    using B = PlausibilityBounds;
    bounded(file, index, "lon_deg", lon_rad * kRadToDeg, B::kMaxLonAbs_deg, "longitude", "deg",
            "longitudes lie in [-180, 360] deg");
    if (!(h_m >= B::kMinHeight_m && h_m <= B::kMaxHeight_m))
      fail(at(file, index, "h_m") + "height " + number_text(h_m) + " m is outside the plausible [" +
           number_text(B::kMinHeight_m) + ", " + number_text(B::kMaxHeight_m) + "] m");
    static constexpr std::string_view kVel[3] = {"vE_mps", "vN_mps", "vU_mps"};
    for (int k = 0; k < 3; ++k)
      bounded(file, index, kVel[k], v_eb_n_mps[k], B::kMaxSpeed_mps, "velocity", "m/s",
              "faster than any drone or aircraft insid is for");
  }

  void latitude(std::string_view file, std::size_t index, double lat_rad) const {
    if (!(std::fabs(lat_rad) < kPi / 2))
      fail(at(file, index, "lat_deg") + "latitude " + number_text(lat_rad * kRadToDeg) +
           " deg must lie strictly within (-90, 90) deg");
  }

  template <class Rows>
  void times(std::string_view file, const Rows& rows) const {
    for (std::size_t i = 1; i < rows.size(); ++i) {
      if (!(rows[i].t_s > rows[i - 1].t_s))
        fail(at(file, i, "t_s") + "time " + number_text(rows[i].t_s) +
             (rows[i].t_s == rows[i - 1].t_s ? " repeats" : " is before") + " the time " +
             number_text(rows[i - 1].t_s) + " on " + row(file, i - 1) +
             " (times must be strictly increasing)");
    }
  }

  void meta_number(const std::string& path, double v) const {
    if (!std::isfinite(v)) meta_fail("field \"" + path + "\" must be a finite number");
  }

  // The IMU rows: finite, times increasing, increments within the physical bounds.
  void imu_values(const Dataset& ds) const {
    if (ds.imu.size() < 2)
      fail(prefix + std::string(kImuFile) + ": need at least 2 data rows, got " +
           std::to_string(ds.imu.size()));
    for (std::size_t i = 0; i < ds.imu.size(); ++i) {
      const ImuSample& s = ds.imu[i];
      finite(kImuFile, i, kImuColumns[0], s.t_s);
      for (int k = 0; k < 3; ++k) finite(kImuFile, i, kImuColumns[1 + k], s.dtheta_b_rad[k]);
      for (int k = 0; k < 3; ++k) finite(kImuFile, i, kImuColumns[4 + k], s.dv_b_mps[k]);
    }
    times(kImuFile, ds.imu);
    const double dt_nominal = 1.0 / ds.meta.imu_rate_hz;
    const bool v1 = ds.meta.format == DatasetFormat::kV1;
    {
      using B = PlausibilityBounds;
      // /1: increments over one nominal step (the step check below holds each within 1 %);
      // /2: over the row's own step (the nominal one for the first row).
      for (std::size_t i = 0; i < ds.imu.size(); ++i) {
        const double dt =
            v1 || i == 0 ? dt_nominal : std::max(ds.imu[i].t_s - ds.imu[i - 1].t_s, dt_nominal);
        const double max_dtheta = B::kMaxAngularRate_deg_s * kDegToRad * dt * 1.01;
        const double max_dv = B::kMaxSpecificForce_g * 9.80665 * dt * 1.01;
        const char* step = v1 ? "one step of 1/imu_rate_hz" : "the row's step";
        for (int k = 0; k < 3; ++k)
          bounded(kImuFile, i, kImuColumns[1 + k], ds.imu[i].dtheta_b_rad[k], max_dtheta,
                  "angle increment", "rad", std::string("2000 deg/s over ") + step);
        for (int k = 0; k < 3; ++k)
          bounded(kImuFile, i, kImuColumns[4 + k], ds.imu[i].dv_b_mps[k], max_dv,
                  "velocity increment", "m/s", std::string("50 g over ") + step);
      }
    }
  }

  void run(const Dataset& ds) const {
    const DatasetMeta& m = ds.meta;
    meta_number("imu_rate_hz", m.imu_rate_hz);
    meta_number("gnss_rate_hz", m.gnss_rate_hz);
    meta_number("align_s", m.align_s);
    if (!(m.imu_rate_hz > 0))
      meta_fail("field \"imu_rate_hz\" must be > 0, got " + number_text(m.imu_rate_hz));
    if (!(m.gnss_rate_hz > 0))
      meta_fail("field \"gnss_rate_hz\" must be > 0, got " + number_text(m.gnss_rate_hz));
    if (!(m.align_s >= 0)) field_fail("align_s", " must be >= 0, got " + number_text(m.align_s));
    if (const std::string e = m.earth.validate(); !e.empty())
      meta_fail("invalid Earth model: " + e);

    const TruthSample& ini = m.initial;
    const std::pair<const char*, double> initial_fields[] = {
        {"t_s", ini.t_s},
        {"lat_deg", ini.lat_rad},
        {"lon_deg", ini.lon_rad},
        {"h_m", ini.h_m},
        {"vE_mps", ini.v_eb_n_mps.x()},
        {"vN_mps", ini.v_eb_n_mps.y()},
        {"vU_mps", ini.v_eb_n_mps.z()},
        {"roll_deg", m.initial_attitude_known ? ini.attitude.roll_rad : 0.0},
        {"pitch_deg", m.initial_attitude_known ? ini.attitude.pitch_rad : 0.0},
        {"yaw_deg", m.initial_attitude_known ? ini.attitude.yaw_rad : 0.0}};
    if (!m.initial_attitude_known && m.format == DatasetFormat::kV1)
      meta_fail("an unknown initial attitude needs format insid-dataset/2");
    for (const auto& [name, v] : initial_fields) meta_number(std::string("initial.") + name, v);
    if (!(std::fabs(ini.lat_rad) < kPi / 2))
      meta_fail("field \"initial.lat_deg\" = " + number_text(ini.lat_rad * kRadToDeg) +
                " must lie strictly within (-90, 90) deg");

    if (const std::string bad = m.motors.validate(); !bad.empty())
      meta_fail("field \"motors.on_s\": " + bad);
    if (m.injected) {
      for (const auto& [name, v] : *m.injected) {
        if (!is_effect_name(name))
          meta_fail("field \"injected." + name + "\": unknown effect name \"" + name +
                    "\" (not in the effect catalogue)");
        meta_number("injected." + name, v);
      }
    }
    if (m.noise) {
      const std::pair<const char*, double> noise_fields[] = {
          {"arw_deg_rth", m.noise->arw_deg_rth},
          {"vrw_mps_rth", m.noise->vrw_mps_rth},
          {"gnss_vel_sigma_mps", m.noise->gnss_vel_sigma_mps},
          {"gnss_pos_sigma_m", m.noise->gnss_pos_sigma_m}};
      for (const auto& [name, v] : noise_fields)
        if (!(std::isfinite(v) && v >= 0))
          meta_fail(std::string("field \"noise.") + name + "\" must be a finite number >= 0, got " +
                    number_text(v));
    }

    imu_values(ds);
    const double dt_nominal = 1.0 / m.imu_rate_hz;
    const bool v1 = m.format == DatasetFormat::kV1;
    if (!v1) {
      // Measured timing: any positive step up to kMaxImuStep_s; the declared rate must be the
      // data's (median step within 10 %).
      using B = PlausibilityBounds;
      std::vector<double> steps;
      steps.reserve(ds.imu.size());
      for (std::size_t i = 1; i < ds.imu.size(); ++i) {
        const double dt = ds.imu[i].t_s - ds.imu[i - 1].t_s;
        if (dt > B::kMaxImuStep_s)
          fail(at(kImuFile, i, "t_s") + "IMU gap of " + number_text(dt) + " s from " +
               row(kImuFile, i - 1) + " (t = " + number_text(ds.imu[i - 1].t_s) +
               ") is longer than the " + number_text(B::kMaxImuStep_s) +
               " s insid integrates across; cut the data there");
        steps.push_back(dt);
      }
      std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2),
                       steps.end());
      const double median = steps[steps.size() / 2];
      if (!(std::fabs(median - dt_nominal) <= B::kImuRateTolerance2 * dt_nominal))
        meta_fail("field \"imu_rate_hz\" = " + number_text(m.imu_rate_hz) +
                  " Hz disagrees with the median IMU step " + number_text(median) + " s (" +
                  number_text(1.0 / median) + " Hz) by more than 10 %");
    }
    for (std::size_t i = 1; v1 && i < ds.imu.size(); ++i) {
      const double dt = ds.imu[i].t_s - ds.imu[i - 1].t_s;
      if (!(std::fabs(dt - dt_nominal) <= kImuRateTolerance * dt_nominal))
        fail(at(kImuFile, i, "t_s") + "IMU step " + number_text(dt) + " s from line " +
             std::to_string(i + 1) + " (t = " + number_text(ds.imu[i - 1].t_s) + ") to line " +
             std::to_string(i + 2) + " (t = " + number_text(ds.imu[i].t_s) +
             ") is not within 1% of 1/imu_rate_hz = " + number_text(dt_nominal) + " s");
    }
    const double imu_t0 = ds.imu.front().t_s;
    const double imu_t1 = ds.imu.back().t_s;
    if (!(m.align_s < imu_t1 - imu_t0))
      field_fail("align_s", " = " + number_text(m.align_s) +
                                " s must be shorter than the IMU data span " +
                                number_text(imu_t1 - imu_t0) + " s (" + file_row(kImuFile, 0) +
                                " to " + row(kImuFile, ds.imu.size() - 1) + ")");

    // GNSS.
    if (ds.gnss.size() < 2)
      fail(prefix + std::string(kGnssFile) + ": need at least 2 data rows, got " +
           std::to_string(ds.gnss.size()));
    for (std::size_t i = 0; i < ds.gnss.size(); ++i) {
      const GnssSample& s = ds.gnss[i];
      finite(kGnssFile, i, "t_s", s.t_s);
      finite(kGnssFile, i, "lat_deg", s.lat_rad);
      finite(kGnssFile, i, "lon_deg", s.lon_rad);
      finite(kGnssFile, i, "h_m", s.h_m);
      for (int k = 0; k < 3; ++k) finite(kGnssFile, i, kGnssColumns[4 + k], s.v_eb_n_mps[k]);
      latitude(kGnssFile, i, s.lat_rad);
      position_velocity(kGnssFile, i, s.lon_rad, s.h_m, s.v_eb_n_mps);
    }
    times(kGnssFile, ds.gnss);
    {
      // The declared rate against the data's median step, and the longest outage.
      using B = PlausibilityBounds;
      std::vector<double> steps;
      steps.reserve(ds.gnss.size() - 1);
      for (std::size_t i = 1; i < ds.gnss.size(); ++i)
        steps.push_back(ds.gnss[i].t_s - ds.gnss[i - 1].t_s);
      std::vector<double> sorted = steps;
      std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
      const double median_step = sorted[sorted.size() / 2];
      const double declared_step = 1.0 / m.gnss_rate_hz;
      const double max_gap = std::max(B::kMaxGnssGap_s, 20.0 * declared_step);
      for (std::size_t i = 0; i < steps.size(); ++i)
        if (!(steps[i] <= max_gap))
          fail(at(kGnssFile, i + 1, "t_s") + "GNSS gap of " + number_text(steps[i]) + " s from " +
               row(kGnssFile, i) + " (t = " + number_text(ds.gnss[i].t_s) + " s) to " +
               row(kGnssFile, i + 1) + " (t = " + number_text(ds.gnss[i + 1].t_s) +
               " s) is longer than the allowed " + number_text(max_gap) +
               " s (the larger of 10 s and 20 GNSS periods)");
      if (!(std::fabs(median_step - declared_step) <= B::kRateTolerance * declared_step))
        meta_fail("field \"gnss_rate_hz\" = " + number_text(m.gnss_rate_hz) +
                  " Hz does not match " + "gnss.csv, whose median step " +
                  number_text(median_step) + " s is a rate of " + number_text(1.0 / median_step) +
                  " Hz (allowed: within 10 %)");
    }
    const double nav_start = imu_t0 + m.align_s;
    if (!(ds.gnss.front().t_s <= nav_start))
      fail(at(kGnssFile, 0, "t_s") + "GNSS does not cover the start of navigation: the first " +
           "GNSS time " + number_text(ds.gnss.front().t_s) + " s is after the alignment end " +
           number_text(nav_start) + " s (first IMU time " + number_text(imu_t0) + " s + " +
           (sources && sources->field && !sources->field("align_s").empty()
                ? sources->field("align_s")
                : std::string("align_s")) +
           " " + number_text(m.align_s) + " s); uncovered: [" + number_text(nav_start) + ", " +
           number_text(ds.gnss.front().t_s) + ") s");
    const double allowed_gap = kGnssEndAllowance / m.gnss_rate_hz;
    if (!(ds.gnss.back().t_s >= imu_t1 - allowed_gap))
      fail(at(kGnssFile, ds.gnss.size() - 1, "t_s") + "GNSS does not cover the end of the " +
           "flight: the last GNSS time " + number_text(ds.gnss.back().t_s) +
           " s is more than 1.5/gnss_rate_hz = " + number_text(allowed_gap) +
           " s before the last IMU time " + number_text(imu_t1) + " s (" +
           file_row(kImuFile, ds.imu.size() - 1) + "); uncovered: (" +
           number_text(ds.gnss.back().t_s) + ", " + number_text(imu_t1) + "] s");

    // Truth (optional).
    for (std::size_t i = 0; i < ds.truth.size(); ++i) {
      const TruthSample& s = ds.truth[i];
      const double v[10] = {s.t_s,
                            s.lat_rad,
                            s.lon_rad,
                            s.h_m,
                            s.v_eb_n_mps.x(),
                            s.v_eb_n_mps.y(),
                            s.v_eb_n_mps.z(),
                            s.attitude.roll_rad,
                            s.attitude.pitch_rad,
                            s.attitude.yaw_rad};
      for (int k = 0; k < 10; ++k) finite(kTruthFile, i, kTruthColumns[k], v[k]);
      latitude(kTruthFile, i, s.lat_rad);
      position_velocity(kTruthFile, i, s.lon_rad, s.h_m, s.v_eb_n_mps);
    }
    times(kTruthFile, ds.truth);

    // Heading (optional): heading.csv and meta.json "heading" come together.
    if (m.heading && ds.heading.empty())
      meta_fail(
          "field \"heading\" describes a measured heading, but there is no heading.csv (or it "
          "has no data rows); add the file or remove the field");
    if (!m.heading && !ds.heading.empty())
      fail(prefix + std::string(kHeadingFile) +
           ": a measured heading needs its source in meta.json: \"heading\": {\"source\": "
           "\"dual_antenna\"} or {\"source\": \"magnetometer\", \"declination_deg\": D}");
    if (m.heading) {
      const bool magnetometer = m.heading->source == HeadingSourceKind::kMagnetometer;
      if (magnetometer && !m.heading->declination_deg)
        meta_fail(
            "field \"heading.declination_deg\" is required for a magnetometer heading (the "
            "declination the importer applied to make it a true heading)");
      if (!magnetometer && m.heading->declination_deg)
        meta_fail("field \"heading.declination_deg\" is only for a magnetometer heading, not " +
                  to_string(m.heading->source));
      if (m.heading->declination_deg && !(std::fabs(*m.heading->declination_deg) <= 180.0))
        meta_fail("field \"heading.declination_deg\" = " +
                  number_text(*m.heading->declination_deg) + " must lie in [-180, 180] deg");
    }
    const bool with_sd = !ds.heading.empty() && ds.heading.front().sd_rad.has_value();
    for (std::size_t i = 0; i < ds.heading.size(); ++i) {
      using B = PlausibilityBounds;
      const HeadingSample& s = ds.heading[i];
      finite(kHeadingFile, i, "t_s", s.t_s);
      finite(kHeadingFile, i, "heading_deg", s.yaw_rad);
      bounded(kHeadingFile, i, "heading_deg", s.yaw_rad * kRadToDeg, B::kMaxHeadingAbs_deg,
              "heading", "deg", "headings lie in [-180, 360] deg");
      if (s.sd_rad.has_value() != with_sd)
        fail(at(kHeadingFile, i, "sd_deg") + "every row or none gives an sd (the first row " +
             (with_sd ? "does" : "does not") + ")");
      if (s.sd_rad && !(*s.sd_rad > 0.0 && *s.sd_rad * kRadToDeg <= B::kMaxHeadingSd_deg))
        fail(at(kHeadingFile, i, "sd_deg") + "heading sd " + number_text(*s.sd_rad * kRadToDeg) +
             " deg must lie in (0, " + number_text(B::kMaxHeadingSd_deg) + "] deg");
    }
    times(kHeadingFile, ds.heading);
  }
};

// ------------------------------------------------------------------------------------------
// Writing

// Degrees to write for an angle in radians: a double d next to rad * kRadToDeg such that
// d * kDegToRad == rad exactly (shortest text among those), else the plain product.
double degrees_for(double rad) {
  const double d0 = rad * kRadToDeg;
  if (!std::isfinite(d0)) return d0;
  double best = d0;
  std::size_t best_len = 0;
  bool found = false;
  constexpr int kSpan = 4;
  double cand[2 * kSpan + 1];
  cand[kSpan] = d0;
  for (int k = 1; k <= kSpan; ++k) {
    cand[kSpan + k] = std::nextafter(cand[kSpan + k - 1], HUGE_VAL);
    cand[kSpan - k] = std::nextafter(cand[kSpan - k + 1], -HUGE_VAL);
  }
  // Visit d0 first, then outward, so ties in length go to the closest candidate.
  for (int step = 0; step <= 2 * kSpan; ++step) {
    const int k = kSpan + ((step % 2) ? (step + 1) / 2 : -(step / 2));
    const double d = cand[k];
    if (d * kDegToRad != rad) continue;
    const std::size_t len = number_text(d).size();
    if (!found || len < best_len) {
      best = d;
      best_len = len;
      found = true;
    }
  }
  return best;
}

// Yaw in [0, 360) deg.
double yaw_degrees_for(double yaw_rad) {
  const double wrapped = (yaw_rad >= 0 && yaw_rad < 2 * kPi) ? yaw_rad : wrap_two_pi(yaw_rad);
  double d = degrees_for(wrapped);
  if (d >= 360.0) d = std::nextafter(360.0, 0.0);
  if (d < 0.0) d = 0.0;
  return d;
}

template <std::size_t N>
void append_header(std::string& out, const std::array<std::string_view, N>& cols) {
  out += join(cols);
  out += '\n';
}

template <std::size_t N>
void append_row(std::string& out, const std::array<double, N>& v) {
  for (std::size_t i = 0; i < N; ++i) {
    if (i) out += ',';
    append_num(out, v[i]);
  }
  out += '\n';
}

std::string imu_text(const std::vector<ImuSample>& imu) {
  std::string s;
  s.reserve(64 + imu.size() * 7 * 24);
  append_header(s, kImuColumns);
  for (const ImuSample& r : imu)
    append_row<7>(s, {r.t_s, r.dtheta_b_rad.x(), r.dtheta_b_rad.y(), r.dtheta_b_rad.z(),
                      r.dv_b_mps.x(), r.dv_b_mps.y(), r.dv_b_mps.z()});
  return s;
}

std::string gnss_text(const std::vector<GnssSample>& gnss) {
  std::string s;
  s.reserve(64 + gnss.size() * 7 * 24);
  append_header(s, kGnssColumns);
  for (const GnssSample& r : gnss)
    append_row<7>(s, {r.t_s, degrees_for(r.lat_rad), degrees_for(r.lon_rad), r.h_m,
                      r.v_eb_n_mps.x(), r.v_eb_n_mps.y(), r.v_eb_n_mps.z()});
  return s;
}

std::string truth_text(const std::vector<TruthSample>& truth) {
  std::string s;
  s.reserve(64 + truth.size() * 10 * 24);
  append_header(s, kTruthColumns);
  for (const TruthSample& r : truth)
    append_row<10>(s,
                   {r.t_s, degrees_for(r.lat_rad), degrees_for(r.lon_rad), r.h_m, r.v_eb_n_mps.x(),
                    r.v_eb_n_mps.y(), r.v_eb_n_mps.z(), degrees_for(r.attitude.roll_rad),
                    degrees_for(r.attitude.pitch_rad), yaw_degrees_for(r.attitude.yaw_rad)});
  return s;
}

std::string heading_text(const std::vector<HeadingSample>& heading) {
  std::string s;
  const bool with_sd = !heading.empty() && heading.front().sd_rad.has_value();
  s.reserve(64 + heading.size() * 3 * 24);
  if (with_sd) {
    append_header(s, kHeadingSdColumns);
    for (const HeadingSample& r : heading)
      append_row<3>(s, {r.t_s, degrees_for(r.yaw_rad), degrees_for(*r.sd_rad)});
  } else {
    append_header(s, kHeadingColumns);
    for (const HeadingSample& r : heading) append_row<2>(s, {r.t_s, degrees_for(r.yaw_rad)});
  }
  return s;
}

std::string meta_text(const DatasetMeta& m, const std::map<std::string, RecordedFile>& files) {
  nlohmann::ordered_json j;
  j["format"] = m.format == DatasetFormat::kV1 ? kFormat : kFormat2;
  j["imu_rate_hz"] = m.imu_rate_hz;
  j["gnss_rate_hz"] = m.gnss_rate_hz;
  j["earth"] = {{"a_m", m.earth.ellipsoid.a_m},
                {"f", m.earth.ellipsoid.f},
                {"omega_ie_rad_s", m.earth.omega_ie_rad_s},
                {"g_eq_mps2", m.earth.g_eq_mps2}};
  j["align_s"] = m.align_s;
  const TruthSample& i = m.initial;
  j["initial"] = {{"t_s", i.t_s},
                  {"lat_deg", degrees_for(i.lat_rad)},
                  {"lon_deg", degrees_for(i.lon_rad)},
                  {"h_m", i.h_m},
                  {"vE_mps", i.v_eb_n_mps.x()},
                  {"vN_mps", i.v_eb_n_mps.y()},
                  {"vU_mps", i.v_eb_n_mps.z()},
                  {"roll_deg", degrees_for(i.attitude.roll_rad)},
                  {"pitch_deg", degrees_for(i.attitude.pitch_rad)},
                  {"yaw_deg", yaw_degrees_for(i.attitude.yaw_rad)}};
  if (!m.initial_attitude_known)
    for (const char* key : {"roll_deg", "pitch_deg", "yaw_deg"}) j["initial"][key] = nullptr;
  if (m.injected) {
    nlohmann::ordered_json inj = nlohmann::ordered_json::object();
    for (const auto& [name, v] : *m.injected) inj[name] = v;
    j["injected"] = inj;
  }
  if (m.noise) {
    j["noise"] = {{"arw_deg_rth", m.noise->arw_deg_rth},
                  {"vrw_mps_rth", m.noise->vrw_mps_rth},
                  {"gnss_vel_sigma_mps", m.noise->gnss_vel_sigma_mps},
                  {"gnss_pos_sigma_m", m.noise->gnss_pos_sigma_m}};
  }
  if (m.heading) {
    j["heading"] = {{"source", to_string(m.heading->source)}};
    if (m.heading->declination_deg) j["heading"]["declination_deg"] = *m.heading->declination_deg;
  }
  if (!m.motors.empty()) {
    nlohmann::ordered_json on = nlohmann::ordered_json::array();
    for (const auto& [t_on, t_off] : m.motors.on_s) on.push_back({t_on, t_off});
    j["motors"] = {{"source", m.motors_source}, {"on_s", on}};
  }
  if (!m.autopilot_estimates_json.empty())
    j["autopilot_estimates"] = nlohmann::ordered_json::parse(m.autopilot_estimates_json);
  for (const auto& [name, record] : files)
    j["files"][name] = {{"rows", record.rows}, {"sha256", record.sha256}};
  return j.dump(2) + "\n";
}

// `dir` made absolute and without a trailing separator.
fs::path normalized_target(const fs::path& dir) {
  std::error_code ec;
  fs::path p = fs::absolute(dir, ec);
  if (ec) p = dir;
  p = p.lexically_normal();
  if (!p.has_filename() && p.has_parent_path()) p = p.parent_path();
  return p;
}

// --force into a directory that holds other things: each of the dataset's files is written to a
// temporary in `dir` and renamed over its name; nothing else in `dir` is touched. A format file
// the new dataset does not have (truth.csv, answer.json) is refused rather than deleted.
void write_dataset_files_into(const fs::path& dir, const std::map<std::string, std::string>& files,
                              const std::string& where) {
  std::error_code ec;
  for (const std::string& name :
       {std::string(kTruthFile), std::string(kHeadingFile), std::string("answer.json")}) {
    if (!files.count(name) && fs::exists(fs::symlink_status(dir / name, ec)))
      fail(where + ": it holds '" + name +
           "', which the new dataset does not have and insid "
           "will not delete; remove it yourself or choose another directory");
  }
  // --force: the user's files of the same names are replaced (the command's inputs were refused
  // before, dataset_destination).
  WriteOptions replace;
  replace.replace_foreign = true;
  for (const auto& [name, contents] : files) {
    try {
      write_file_atomic(dir / name, contents, replace);
    } catch (const std::exception& e) {
      fail(where + ": " + e.what());
    }
  }
}

}  // namespace

// ------------------------------------------------------------------------------------------

MotorSchedule read_motor_schedule(const JsonArray& on_s) {
  MotorSchedule motors;
  for (std::size_t i = 0; i < on_s.size(); ++i) {
    const std::vector<double> pair = on_s[i].array().numbers();
    if (pair.size() != 2) on_s[i].fail("expected [on_s, off_s], two numbers");
    motors.on_s.emplace_back(pair[0], pair[1]);
  }
  if (const std::string bad = motors.validate(); !bad.empty()) on_s.fail(bad);
  return motors;
}

Dataset load_dataset(const fs::path& dir) {
  const std::string prefix = dir.string() + ": ";
  std::error_code ec;
  const fs::file_status st = fs::status(dir, ec);
  if (!fs::exists(st))
    fail("dataset directory '" + dir.string() + "' does not exist" +
         (ec && ec != std::errc::no_such_file_or_directory ? " (" + ec.message() + ")" : ""));
  if (!fs::is_directory(st))
    fail("'" + dir.string() + "' is not a directory (an " + std::string(kFormat) +
         " dataset is a directory with imu.csv, gnss.csv, meta.json and optional truth.csv)");

  // Present (true), absent (false), or an error: a dangling link or a link loop is not
  // "missing", it is broken.
  auto present = [&](std::string_view name) {
    const fs::path p = dir / name;
    std::error_code status_ec;
    const fs::file_status file_st = fs::status(p, status_ec);
    if (fs::exists(file_st)) return true;
    if (fs::is_symlink(fs::symlink_status(p, ec)))
      fail(prefix + std::string(name) + ": a symbolic link that does not resolve (" +
           (status_ec ? status_ec.message() : std::string("its target is missing")) + ")");
    if (status_ec && status_ec != std::errc::no_such_file_or_directory)
      fail(prefix + std::string(name) + ": " + status_ec.message());
    return false;
  };
  auto require_file = [&](std::string_view name) {
    if (!present(name))
      fail(prefix + "missing file " + std::string(name) + " (required by " + std::string(kFormat) +
           ")");
    return dir / name;
  };

  Dataset ds;
  std::map<std::string, RecordedFile> recorded;
  ds.meta = parse_meta(read_whole_file(require_file(kMetaFile), prefix + std::string(kMetaFile)),
                       prefix, recorded);
  std::map<std::string, RecordedFile> found;  // checked against `recorded` at the end

  {
    const std::string text =
        read_whole_file(require_file(kImuFile), prefix + std::string(kImuFile));
    ds.imu.reserve(static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n')) + 1);
    found[std::string(kImuFile)] = parse_csv_recorded(text, kImuColumns, CsvWhere{prefix, kImuFile},
                                                      [&](const double* v, std::size_t) {
                                                        ImuSample& s = ds.imu.emplace_back();
                                                        s.t_s = v[0];
                                                        s.dtheta_b_rad = {v[1], v[2], v[3]};
                                                        s.dv_b_mps = {v[4], v[5], v[6]};
                                                      });
  }
  {
    const std::string text =
        read_whole_file(require_file(kGnssFile), prefix + std::string(kGnssFile));
    ds.gnss.reserve(static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n')) + 1);
    found[std::string(kGnssFile)] = parse_csv_recorded(
        text, kGnssColumns, CsvWhere{prefix, kGnssFile}, [&](const double* v, std::size_t) {
          GnssSample& s = ds.gnss.emplace_back();
          s.t_s = v[0];
          s.lat_rad = v[1] * kDegToRad;
          s.lon_rad = v[2] * kDegToRad;
          s.h_m = v[3];
          s.v_eb_n_mps = {v[4], v[5], v[6]};
        });
  }
  if (const fs::path p = dir / kTruthFile; present(kTruthFile)) {
    const std::string text = read_whole_file(p, prefix + std::string(kTruthFile));
    ds.truth.reserve(static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n')) + 1);
    found[std::string(kTruthFile)] = parse_csv_recorded(
        text, kTruthColumns, CsvWhere{prefix, kTruthFile}, [&](const double* v, std::size_t) {
          TruthSample& s = ds.truth.emplace_back();
          s.t_s = v[0];
          s.lat_rad = v[1] * kDegToRad;
          s.lon_rad = v[2] * kDegToRad;
          s.h_m = v[3];
          s.v_eb_n_mps = {v[4], v[5], v[6]};
          s.attitude.roll_rad = v[7] * kDegToRad;
          s.attitude.pitch_rad = v[8] * kDegToRad;
          s.attitude.yaw_rad = v[9] * kDegToRad;
        });
  }

  if (const fs::path p = dir / kHeadingFile; present(kHeadingFile)) {
    const std::string text = read_whole_file(p, prefix + std::string(kHeadingFile));
    found[std::string(kHeadingFile)] = parse_heading_csv(
        text, CsvWhere{prefix, kHeadingFile}, [&](double t, double deg, double sd, std::size_t) {
          HeadingSample& s = ds.heading.emplace_back();
          s.t_s = t;
          s.yaw_rad = deg * kDegToRad;
          if (!std::isnan(sd)) s.sd_rad = sd * kDegToRad;
        });
  }

  Validator{prefix}.run(ds);
  for (const auto& [name, record] : found) check_recorded(recorded, name, record, prefix);
  return ds;
}

void validate_dataset(const Dataset& dataset, const DatasetSources& sources) {
  Validator{"", &sources}.run(dataset);
}

void validate_imu_values(const Dataset& dataset, const DatasetSources& sources) {
  Validator{"", &sources}.imu_values(dataset);
}

std::string to_string(HeadingSourceKind kind) {
  return std::string(kHeadingSourceKindNames.name(kind));
}

std::vector<ImuGap> imu_gaps(const Dataset& dataset) {
  std::vector<ImuGap> gaps;
  const double limit = PlausibilityBounds::kImuGapSteps / dataset.meta.imu_rate_hz;
  for (std::size_t i = 1; i < dataset.imu.size(); ++i) {
    const double dt = dataset.imu[i].t_s - dataset.imu[i - 1].t_s;
    if (dt > limit) gaps.push_back({i + 2, dataset.imu[i].t_s, dt});
  }
  return gaps;
}

const std::vector<std::string>& dataset_directory_entries() {
  static const std::vector<std::string> entries = {
      std::string(kMetaFile), std::string(kImuFile),
      std::string(kGnssFile), std::string(kTruthFile),
      "answer.json",          "insid-optimum-cache.json",
      "provenance.json",      std::string(kHeadingFile)};
  return entries;
}

namespace {

// True when `dir` holds nothing but an insid dataset's entries, each a file insid wrote and
// unchanged since (its mark, base/output_dir.h: a user's raw imu.csv is not one, whatever its
// name), its meta.json (when present) declaring the format. Throws DatasetError when it holds
// something else, unless `force`.
bool holds_only_a_dataset(const fs::path& dir, const std::string& where, bool force) {
  const OutputKind kind{"an insid dataset", dataset_directory_entries()};
  try {
    require_own_or_empty(dir, kind, "give --force to add the dataset's files and keep the rest");
  } catch (const std::runtime_error& e) {
    if (force) return false;
    fail(where + ": " + e.what());
  }
  std::error_code ec;
  if (!fs::exists(dir / kMetaFile, ec)) return true;
  bool is_ours = false;
  try {
    const json meta = parse_json_strict(read_whole_file(dir / kMetaFile, where), where);
    is_ours = meta.is_object() &&
              (meta.value("format", "") == kFormat || meta.value("format", "") == kFormat2);
  } catch (const std::exception&) {
    is_ours = false;
  }
  if (!is_ours && !force)
    fail(where + ": its meta.json is not an " + std::string(kFormat) +
         " dataset's; choose a new or empty directory, or give --force to add the dataset's "
         "files and keep the rest");
  return is_ours;
}

}  // namespace

DatasetDestination dataset_destination(const fs::path& dir, bool into_foreign_directory,
                                       const std::vector<fs::path>& inputs) {
  const std::string where = "cannot write dataset '" + dir.string() + "'";
  const fs::path target = normalized_target(dir);
  if (!target.has_filename() || target.filename() == "." || target.filename() == "..")
    fail(where + ": not a usable directory name");
  std::error_code ec;
  const fs::file_status st = fs::symlink_status(target, ec);
  if (!fs::exists(st)) return DatasetDestination::kReplace;
  if (!fs::is_directory(st)) fail(where + ": the path exists and is not a directory");
  const bool force = into_foreign_directory;
  const bool replaceable = holds_only_a_dataset(target, where, force);
  const bool holds_cwd = contains_working_directory(target);
  if (holds_cwd && !force)
    fail(where +
         ": it is the current directory or contains it; give another directory, or "
         "--force to add the dataset's files there");
  const DatasetDestination destination =
      replaceable && !holds_cwd ? DatasetDestination::kReplace : DatasetDestination::kAddFiles;
  try {
    if (destination == DatasetDestination::kReplace) {
      refuse_replacing_inputs(target, inputs, /*whole_directory=*/true);
    } else {
      for (const std::string& name : dataset_directory_entries())
        refuse_replacing_inputs(target / name, inputs, /*whole_directory=*/false);
    }
  } catch (const std::runtime_error& e) {
    fail(where + ": " + e.what());
  }
  return destination;
}

namespace {

// The RecordedFile of CSV text insid has just written (parsed back: the values a loader will see).
RecordedFile record_of(const std::string& name, const std::string& text) {
  const CsvWhere where{"", name};
  const auto nothing = [](const double*, std::size_t) {};
  if (name == kImuFile) return parse_csv_recorded(text, kImuColumns, where, nothing);
  if (name == kGnssFile) return parse_csv_recorded(text, kGnssColumns, where, nothing);
  if (name == kHeadingFile)
    return parse_heading_csv(text, where, [](double, double, double, std::size_t) {});
  return parse_csv_recorded(text, kTruthColumns, where, nothing);
}

}  // namespace

void write_dataset(const fs::path& dir, const Dataset& dataset,
                   const DatasetWriteOptions& options) {
  const std::string where = "cannot write dataset '" + dir.string() + "'";
  try {
    Validator{""}.run(dataset);
  } catch (const DatasetError& e) {
    fail(where + ": invalid dataset: " + e.what());
  }
  for (const auto& [name, contents] : options.extra_files) {
    const auto& own = dataset_directory_entries();
    if (std::find(own.begin(), own.end(), name) == own.end() || name == kMetaFile ||
        name == kImuFile || name == kGnssFile || name == kTruthFile || name == kHeadingFile)
      fail(where + ": '" + name + "' is not an extra file a dataset directory may hold");
  }

  // Everything in memory first: nothing touches the disk until the data are known good.
  std::map<std::string, std::string> files = options.extra_files;
  files[std::string(kImuFile)] = imu_text(dataset.imu);
  files[std::string(kGnssFile)] = gnss_text(dataset.gnss);
  if (!dataset.truth.empty()) files[std::string(kTruthFile)] = truth_text(dataset.truth);
  if (!dataset.heading.empty()) files[std::string(kHeadingFile)] = heading_text(dataset.heading);
  std::map<std::string, RecordedFile> records;
  for (const std::string_view name : {kImuFile, kGnssFile, kTruthFile, kHeadingFile})
    if (const auto it = files.find(std::string(name)); it != files.end())
      records[it->first] = record_of(it->first, it->second);
  files[std::string(kMetaFile)] = meta_text(dataset.meta, records);

  const fs::path target = normalized_target(dir);
  if (dataset_destination(dir, options.into_foreign_directory, options.inputs) ==
      DatasetDestination::kAddFiles) {
    write_dataset_files_into(target, files, where);
    return;
  }
  std::error_code ec;

  // Create missing parents; remember the topmost one created, to remove it on failure.
  const fs::path parent = target.parent_path();
  fs::path created_top;
  for (fs::path p = parent; !p.empty() && !fs::exists(p, ec); p = p.parent_path()) {
    created_top = p;
    if (p == p.parent_path()) break;
  }
  if (!created_top.empty() && !fs::create_directories(parent, ec) && ec) {
    std::error_code ignored;
    fs::remove_all(created_top, ignored);
    fail(where + ": cannot create directory '" + parent.string() + "': " + ec.message());
  }

  // What a killed run of this host left beside the target (its temporary or old directory).
  remove_abandoned_siblings(target);
  const fs::path tmp = temporary_sibling(target, ".tmp-");
  // Only what insid wrote goes on failure (a user's file put there meanwhile stays).
  auto cleanup = [&] {
    remove_own_files(tmp);
    if (!created_top.empty()) remove_own_files(created_top);
  };
  if (!fs::create_directory(tmp, ec)) {
    cleanup();
    fail(where + ": cannot create temporary directory '" + tmp.string() +
         "': " + (ec ? ec.message() : std::string("it already exists")));
  }
  mark_as_temporary(tmp);  // a kill from here on leaves a temporary a rerun removes
  try {
    for (const auto& [name, contents] : files) write_file_atomic(tmp / name, contents);
  } catch (const std::exception& e) {
    cleanup();
    fail(where + ": " + e.what());
  }

  if (fs::exists(fs::symlink_status(target, ec))) {
    // Move the old dataset aside, put the new one in place, then delete the old one. Marked as
    // a temporary first, so that a kill between the renames leaves it for a rerun to remove.
    const fs::path old = temporary_sibling(target, ".old-");
    const bool marked_old = mark_as_temporary(target);
    fs::rename(target, old, ec);
    if (ec) {
      if (marked_old) ::removexattr(target.c_str(), kTemporaryMarkAttribute);
      cleanup();
      fail(where + ": cannot move the existing directory aside to '" + old.string() +
           "': " + ec.message());
    }
    fs::rename(tmp, target, ec);
    if (ec) {
      std::error_code ignored;
      fs::rename(old, target, ignored);
      if (marked_old) ::removexattr(target.c_str(), kTemporaryMarkAttribute);
      cleanup();
      fail(where + ": cannot rename '" + tmp.string() + "' into place: " + ec.message());
    }
    // The old directory held only insid's files (checked above, holds_only_a_dataset); whatever
    // else appeared there meanwhile is kept, in the '.old-' directory.
    remove_own_files(old);
  } else {
    fs::rename(tmp, target, ec);
    if (ec) {
      cleanup();
      fail(where + ": cannot rename '" + tmp.string() + "' into place: " + ec.message());
    }
  }
  ::removexattr(target.c_str(), kTemporaryMarkAttribute);  // the dataset is no temporary now
}

std::string dataset_digest(const fs::path& dir) {
  std::string listing;
  for (const std::string_view name : {kMetaFile, kImuFile, kGnssFile, kHeadingFile}) {
    // heading.csv enters only when present: the digest of a dataset without one is unchanged.
    std::error_code ec;
    if (name == kHeadingFile && !fs::exists(dir / name, ec)) continue;
    try {
      listing += std::string(name) + ":" + sha256_file_hex(dir / name) + "\n";
    } catch (const std::runtime_error& e) {
      fail(dir.string() + ": " + e.what());
    }
  }
  return sha256_hex(listing);
}

}  // namespace insid
