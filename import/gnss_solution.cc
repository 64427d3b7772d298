#include "import/gnss_solution.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string_view>

#include "import/text_lines.h"

namespace insid::importers {
namespace {

std::vector<std::string_view> split_ws(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    const std::size_t b = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > b) out.push_back(line.substr(b, i - b));
  }
  return out;
}

double number(std::string_view token, const std::string& at) {
  double v = 0.0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), v);
  if (ec != std::errc() || end != token.data() + token.size() || !std::isfinite(v))
    throw std::runtime_error(at + ": expected a finite number, got '" + std::string(token) + "'");
  return v;
}

// Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant's days_from_civil).
long long days_from_civil(long long y, unsigned m, unsigned d) {
  y -= m <= 2;
  const long long era = (y >= 0 ? y : y - 399) / 400;
  const auto yoe = static_cast<unsigned>(y - era * 400);
  const unsigned doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + static_cast<long long>(doe) - 719468;
}

// A time field in extended precision.
GpstTime parse_time_value(std::string_view token, const std::string& at) {
  GpstTime v = 0.0L;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), v);
  if (ec != std::errc() || end != token.data() + token.size() || !std::isfinite(v))
    throw std::runtime_error(at + ": expected a finite number, got '" + std::string(token) + "'");
  return v;
}

// "2025/08/28" "17:30:39.749" -> seconds since 1970 on the same (GPST) scale.
GpstTime date_time_seconds(std::string_view date, std::string_view time, const std::string& at) {
  int y = 0, mo = 0, d = 0, h = 0, mi = 0;
  long double s = 0.0L;
  char sep1 = 0, sep2 = 0, sep3 = 0, sep4 = 0;
  std::istringstream ds{std::string(date)}, ts{std::string(time)};
  if (!(ds >> y >> sep1 >> mo >> sep2 >> d) || sep1 != '/' || sep2 != '/' || !ds.eof() || mo < 1 ||
      mo > 12 || d < 1 || d > 31 || y < 1980 || y > 2200)
    throw std::runtime_error(at + ": expected a GPST date yyyy/mm/dd, got '" + std::string(date) +
                             "'");
  // A day the month does not have (2025/02/30, 2025/04/31) is refused, not rolled over.
  static constexpr int kDaysInMonth[12] = {31, 29, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  const bool leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
  if (d > kDaysInMonth[mo - 1] || (mo == 2 && d == 29 && !leap))
    throw std::runtime_error(at + ": the date '" + std::string(date) + "' does not exist");
  if (!(ts >> h >> sep3 >> mi >> sep4 >> s) || sep3 != ':' || sep4 != ':' || h < 0 || h > 23 ||
      mi < 0 || mi > 59 || !(s >= 0.0 && s < 61.0))
    throw std::runtime_error(at + ": expected a GPST time hh:mm:ss.sss, got '" + std::string(time) +
                             "'");
  return static_cast<GpstTime>(
             days_from_civil(y, static_cast<unsigned>(mo), static_cast<unsigned>(d))) *
             86400.0L +
         h * 3600.0L + mi * 60.0L + s;
}

}  // namespace

bool looks_like_rtklib_pos(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  for (int n = 0; n < 200 && std::getline(in, line); ++n) {
    if (line.empty() || line[0] != '%') return false;
    if (line.find("latitude(deg)") != std::string::npos) return true;
  }
  return false;
}

GnssSolution parse_rtklib_pos(const std::string& text, const std::string& where) {
  GnssSolution out;
  out.source = where;
  std::vector<std::string_view> header;
  std::size_t header_line = 0;
  std::map<std::string, std::size_t> col;  // column name -> token index (after the time tokens)
  bool week_tow = false;
  TextLines lines(text);
  std::string_view line;
  std::size_t line_no = 0;
  while (lines.next(&line, &line_no)) {
    const std::string at = where + " line " + std::to_string(line_no);
    if (!line.empty() && line[0] == '%') {
      const auto tokens = split_ws(line.substr(1));
      if (!tokens.empty() && (tokens[0] == "GPST" || tokens[0] == "UTC" || tokens[0] == "JST")) {
        header = tokens;
        header_line = line_no;
      }
      continue;
    }
    if (split_ws(line).empty()) continue;
    if (col.empty()) {
      // The first data row: interpret the header now.
      if (header.empty())
        throw std::runtime_error(
            at +
            ": data before a '%' header line naming the columns (RTKLIB "
            "writes '%  GPST  latitude(deg) ...'); not an RTKLIB solution file?");
      const std::string hat = where + " line " + std::to_string(header_line);
      if (header[0] != "GPST")
        throw std::runtime_error(hat + ": time system " + std::string(header[0]) +
                                 "; insid needs GPST (leap seconds are not applied); rerun "
                                 "RTKLIB with time format GPST (out-timesys = gpst)");
      std::size_t k = 1;
      for (; k < header.size(); ++k) {
        const std::string name(header[k]);
        if (name == "x-ecef(m)" || name == "e-baseline(m)" ||
            name.find("ecef") != std::string::npos)
          throw std::runtime_error(hat + ": column '" + name +
                                   "': insid reads latitude/longitude/"
                                   "height solutions; rerun RTKLIB with out-solformat = llh");
        col[name] = k - 1;
      }
      const auto tokens = split_ws(line);
      week_tow = tokens[0].find('/') == std::string_view::npos;
      out.format = week_tow ? "rtklib-pos (week tow)" : "rtklib-pos (date time)";
      for (const char* needed : {"latitude(deg)", "longitude(deg)", "height(m)", "Q", "ns"})
        if (!col.count(needed))
          throw std::runtime_error(hat + ": no column '" + std::string(needed) +
                                   "' (latitude/longitude in degrees, ellipsoidal height; rerun "
                                   "RTKLIB with out-solformat = llh, out-height = ellipsoidal, "
                                   "not dms)");
      for (const char* needed : {"vn(m/s)", "ve(m/s)", "vu(m/s)"})
        if (!col.count(needed))
          throw std::runtime_error(hat + ": no column '" + std::string(needed) +
                                   "': a position-only solution; insid compares velocities "
                                   "and does not difference positions into them (that would add "
                                   "the position noise over the step); rerun RTKLIB with "
                                   "velocity output (out-outvel = on)");
    }
    const auto tokens = split_ws(line);
    const std::size_t time_tokens = 2;  // "date time" or "week tow"
    std::size_t expected = time_tokens;
    for (const auto& [name, index] : col) expected = std::max(expected, time_tokens + index + 1);
    if (tokens.size() < expected)
      throw std::runtime_error(at + ": " + std::to_string(tokens.size()) +
                               " fields, the header (line " + std::to_string(header_line) +
                               ") needs at least " + std::to_string(expected));
    GnssEpoch e;
    e.line = line_no;
    if (week_tow) {
      const double week = number(tokens[0], at + ", column week");
      const double tow = number(tokens[1], at + ", column tow");
      if (week < 0 || week != std::floor(week) || tow < 0 || tow >= kSecondsPerWeek)
        throw std::runtime_error(at + ": expected GPS week (whole, >= 0) and TOW in [0, 604800) s");
      e.t_gpst_unix_s = kGpsEpochGpstUnix_s + static_cast<GpstTime>(week) * kSecondsPerWeek +
                        parse_time_value(tokens[1], at + ", column tow");
    } else {
      e.t_gpst_unix_s = date_time_seconds(tokens[0], tokens[1], at);
    }
    const auto field = [&](const char* name) {
      return number(tokens[time_tokens + col.at(name)], at + ", column " + name);
    };
    const auto optional = [&](const char* name) { return col.count(name) ? field(name) : 0.0; };
    e.lat_deg = field("latitude(deg)");
    e.lon_deg = field("longitude(deg)");
    e.h_m = field("height(m)");
    // Q and ns are whole numbers in RTKLIB's format: 2.5 is refused, not read as 2.
    const auto whole = [&](const char* name) {
      const double v = field(name);
      if (v != std::floor(v) || std::fabs(v) > 1e6)
        throw std::runtime_error(at + ", column " + name + ": expected a whole number, got '" +
                                 std::string(tokens[time_tokens + col.at(name)]) + "'");
      return static_cast<int>(v);
    };
    e.quality = whole("Q");
    e.satellites = whole("ns");
    e.sd_n_m = optional("sdn(m)");
    e.sd_e_m = optional("sde(m)");
    e.sd_u_m = optional("sdu(m)");
    e.v_n_mps = field("vn(m/s)");
    e.v_e_mps = field("ve(m/s)");
    e.v_u_mps = field("vu(m/s)");
    e.sd_vn_mps = optional("sdvn");
    e.sd_ve_mps = optional("sdve");
    e.sd_vu_mps = optional("sdvu");
    if (!(std::fabs(e.lat_deg) < 90.0) || !(std::fabs(e.lon_deg) <= 360.0))
      throw std::runtime_error(at + ": latitude " +
                               std::string(tokens[time_tokens + col.at("latitude(deg)")]) +
                               " / longitude outside (-90, 90) / [-360, 360] deg");
    if (e.quality < 0 || e.quality > 7)
      throw std::runtime_error(at + ", column Q: quality flag " + std::to_string(e.quality) +
                               " is not an RTKLIB solution status (0-7)");
    if (!out.epochs.empty() && !(e.t_gpst_unix_s > out.epochs.back().t_gpst_unix_s))
      throw std::runtime_error(at + ": time does not increase after line " +
                               std::to_string(out.epochs.back().line) +
                               " (epochs must be in time order)");
    out.epochs.push_back(e);
  }
  if (out.epochs.size() < 2)
    throw std::runtime_error(where + ": " + std::to_string(out.epochs.size()) +
                             " solution epochs; need at least 2");
  return out;
}

}  // namespace insid::importers
