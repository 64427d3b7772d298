#include "import/kf_gins.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "base/number_text.h"
#include "import/text_lines.h"
#include "model/earth.h"
#include "model/units.h"

namespace insid::importers {
namespace {

// Splits on commas, spaces and tabs, skipping empty fields (KF-GINS's rule).
std::vector<std::string_view> fields_of(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  const auto sep = [](char c) { return c == ',' || c == ' ' || c == '\t' || c == '\r'; };
  while (i < line.size()) {
    while (i < line.size() && sep(line[i])) ++i;
    const std::size_t b = i;
    while (i < line.size() && !sep(line[i])) ++i;
    if (i > b) out.push_back(line.substr(b, i - b));
  }
  return out;
}

// Calls on_row(values, line_no) for every non-blank line; every line must have one of the allowed
// field counts, all finite numbers, and time increasing.
template <class OnRow>
void parse_rows(const std::string& text, const std::string& where, std::vector<std::size_t> counts,
                OnRow&& on_row) {
  double t_prev = -INFINITY;
  std::size_t line_prev = 0;
  std::vector<double> values;
  TextLines lines(text);
  std::string_view line;
  std::size_t line_no = 0;
  while (lines.next(&line, &line_no)) {
    const auto fields = fields_of(line);
    if (fields.empty()) continue;
    const std::string at = where + " line " + std::to_string(line_no);
    bool allowed = false;
    std::string expected;
    for (std::size_t c : counts) {
      allowed = allowed || fields.size() == c;
      expected += (expected.empty() ? "" : " or ") + std::to_string(c);
    }
    if (!allowed)
      throw std::runtime_error(at + ": " + std::to_string(fields.size()) + " fields, expected " +
                               expected);
    values.assign(fields.size(), 0.0);
    for (std::size_t k = 0; k < fields.size(); ++k) {
      const auto [end, ec] =
          std::from_chars(fields[k].data(), fields[k].data() + fields[k].size(), values[k]);
      if (ec != std::errc() || end != fields[k].data() + fields[k].size() ||
          !std::isfinite(values[k]))
        throw std::runtime_error(at + ", column " + std::to_string(k + 1) +
                                 ": expected a finite number, got '" + std::string(fields[k]) +
                                 "'");
    }
    if (!(values[0] > t_prev))
      throw std::runtime_error(at + ", column 1: time " + std::string(fields[0]) +
                               " does not increase after line " + std::to_string(line_prev));
    t_prev = values[0];
    line_prev = line_no;
    on_row(values, line_no);
  }
}

GpstTime week_base(std::optional<int> gps_week) {
  return kGpsEpochGpstUnix_s + (gps_week ? *gps_week : 0) * kSecondsPerWeek;
}

void append_number(std::string& out, double v, const char* separator) {
  out += separator;
  out += number_text(v, 17);
}

}  // namespace

CsvImu parse_kf_gins_imu(const std::string& text, const std::string& where,
                         std::optional<int> gps_week) {
  CsvImu out;
  out.origin = where;
  out.accel_is_increment = true;
  out.gyro_is_increment = true;
  const GpstTime base = week_base(gps_week);
  parse_rows(text, where, {7, 8}, [&](const std::vector<double>& v, std::size_t line) {
    if (v[0] < 0.0 || v[0] >= kSecondsPerWeek + 86400.0)
      throw std::runtime_error(where + " line " + std::to_string(line) +
                               ", column 1: GPS seconds of week " + number_text(v[0], 17) +
                               " outside [0, 691200)");
    out.t_gpst_unix_s.push_back(base + static_cast<GpstTime>(v[0]));
    out.gyro_b.emplace_back(v[1], v[2], v[3]);
    out.accel_b.emplace_back(v[4], v[5], v[6]);
    out.line.push_back(line);
  });
  if (out.line.size() < 3)
    throw std::runtime_error(where + ": " + std::to_string(out.line.size()) +
                             " IMU rows; need at least 3");
  return out;
}

bool looks_like_kf_gins_gnss(const std::string& text) {
  const std::size_t nl = text.find('\n');
  const auto fields = fields_of(std::string_view(text).substr(0, nl));
  if (fields.size() != 7 && fields.size() != 13) return false;
  for (const auto f : fields) {
    double v = 0.0;
    const auto [end, ec] = std::from_chars(f.data(), f.data() + f.size(), v);
    if (ec != std::errc() || end != f.data() + f.size()) return false;
  }
  return true;
}

GnssSolution parse_kf_gins_gnss(const std::string& text, const std::string& where,
                                std::optional<int> gps_week) {
  GnssSolution out;
  out.source = where;
  const GpstTime base = week_base(gps_week);
  std::size_t columns = 0;
  parse_rows(text, where, {7, 13}, [&](const std::vector<double>& v, std::size_t line) {
    const std::string at = where + " line " + std::to_string(line);
    if (columns == 0) columns = v.size();
    if (v.size() != columns)
      throw std::runtime_error(at + ": " + std::to_string(v.size()) +
                               " fields, the file's first row has " + std::to_string(columns));
    if (!(std::fabs(v[1]) < 90.0) || !(std::fabs(v[2]) <= 360.0))
      throw std::runtime_error(at + ": latitude/longitude " + number_text(v[1], 17) + ", " +
                               number_text(v[2], 17) + " deg outside (-90, 90) / [-360, 360]");
    GnssEpoch e;
    e.line = line;
    e.t_gpst_unix_s = base + static_cast<GpstTime>(v[0]);
    e.lat_deg = v[1];
    e.lon_deg = v[2];
    e.h_m = v[3];
    e.quality = 1;
    if (columns == 13) {
      e.v_n_mps = v[4], e.v_e_mps = v[5], e.v_u_mps = -v[6];
      e.sd_n_m = v[7], e.sd_e_m = v[8], e.sd_u_m = v[9];
      e.sd_vn_mps = v[10], e.sd_ve_mps = v[11], e.sd_vu_mps = v[12];
    } else {
      e.sd_n_m = v[4], e.sd_e_m = v[5], e.sd_u_m = v[6];
    }
    out.epochs.push_back(e);
  });
  if (out.epochs.size() < 3)
    throw std::runtime_error(where + ": " + std::to_string(out.epochs.size()) +
                             " GNSS epochs; need at least 3");
  if (columns == 13) {
    out.format = "kf-gins (position and velocity, 13 columns)";
    return out;
  }
  // Position-only: central differences in local north/east/up (WGS-84 radii).
  out.format = "kf-gins (position, 7 columns; velocity derived by central differences)";
  const EarthModel earth = EarthModel::wgs84();
  std::vector<GnssEpoch>& ep = out.epochs;
  std::vector<Eigen::Vector3d> v_neu(ep.size());
  for (std::size_t k = 0; k < ep.size(); ++k) {
    const std::size_t a = k == 0 ? 0 : k - 1;
    const std::size_t b = k + 1 == ep.size() ? k : k + 1;
    const double lat = ep[k].lat_deg * kDegToRad;
    const double dt = static_cast<double>(ep[b].t_gpst_unix_s - ep[a].t_gpst_unix_s);
    const double R_N = earth.meridian_radius_m(lat) + ep[k].h_m;
    const double R_E = earth.prime_vertical_radius_m(lat) + ep[k].h_m;
    v_neu[k] = {(ep[b].lat_deg - ep[a].lat_deg) * kDegToRad * R_N / dt,
                (ep[b].lon_deg - ep[a].lon_deg) * kDegToRad * R_E * std::cos(lat) / dt,
                (ep[b].h_m - ep[a].h_m) / dt};
  }
  for (std::size_t k = 0; k < ep.size(); ++k)
    ep[k].v_n_mps = v_neu[k].x(), ep[k].v_e_mps = v_neu[k].y(), ep[k].v_u_mps = v_neu[k].z();
  return out;
}

std::string kf_gins_imu_text(const Dataset& ds, double sow_offset_s) {
  std::string out;
  for (const ImuSample& s : ds.imu) {
    append_number(out, s.t_s + sow_offset_s, "");
    for (int k = 0; k < 3; ++k) append_number(out, s.dtheta_b_rad[k], " ");
    for (int k = 0; k < 3; ++k) append_number(out, s.dv_b_mps[k], " ");
    out += '\n';
  }
  return out;
}

std::string kf_gins_gnss_text(const Dataset& ds, double sow_offset_s, double pos_std_m,
                              double vel_std_mps) {
  std::string out;
  for (const GnssSample& g : ds.gnss) {
    append_number(out, g.t_s + sow_offset_s, "");
    for (const double v : {g.lat_rad * kRadToDeg, g.lon_rad * kRadToDeg, g.h_m, g.v_eb_n_mps.y(),
                           g.v_eb_n_mps.x(), -g.v_eb_n_mps.z()})
      append_number(out, v, " ");
    for (int k = 0; k < 3; ++k) append_number(out, pos_std_m, " ");
    for (int k = 0; k < 3; ++k) append_number(out, vel_std_mps, " ");
    out += '\n';
  }
  return out;
}

}  // namespace insid::importers
