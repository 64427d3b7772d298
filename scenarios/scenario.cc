#include "scenarios/scenario.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>

#include "base/huge_pages.h"
#include "base/json_object.h"
#include "base/json_reader.h"
#include "base/number_text.h"
#include "model/rotation.h"
#include "nav/alignment.h"
#include "scenarios/presets.h"
#include "scenarios/synthesis.h"

namespace insid::scenarios {
namespace {

using json = nlohmann::json;

const std::map<std::string, std::vector<std::string>>& segment_keys() {
  static const std::map<std::string, std::vector<std::string>> keys = {
      {"static", {"type", "duration_s", "comment"}},
      {"straight", {"type", "duration_s", "comment"}},
      {"speed", {"type", "speed_mps", "accel_mps2", "comment"}},
      {"turn", {"type", "turn_deg", "direction", "bank_deg", "rate_deg_s", "ramp_s", "comment"}},
      {"loiter", {"type", "circles", "direction", "bank_deg", "rate_deg_s", "ramp_s", "comment"}},
      {"s_turns",
       {"type", "count", "turn_deg", "direction", "bank_deg", "rate_deg_s", "ramp_s", "straight_s",
        "comment"}},
      {"climb", {"type", "dh_m", "vz_mps", "ramp_s", "pitch_deg", "comment"}},
      {"descend", {"type", "dh_m", "vz_mps", "ramp_s", "pitch_deg", "comment"}},
      {"takeoff", {"type", "dh_m", "vz_mps", "ramp_s", "comment"}},
  };
  return keys;
}

// One segment at `path` ("segments[2]") of `source`, with the keys of its type; its keys' types
// checked (their meaning is checked when it is applied).
JsonObject segment_reader(const json& seg, const std::string& source, const std::string& path) {
  const std::string type = JsonObject::any_keys(seg, source, path)
                               .field("type")
                               .choice({"static", "straight", "speed", "turn", "loiter", "s_turns",
                                        "climb", "descend", "takeoff"});
  const JsonObject r(seg, source, path, segment_keys().at(type));
  for (const auto& item : seg.items()) {
    if (item.key() == "direction")
      r.field("direction").choice({"left", "right"});
    else if (item.key() == "type" || item.key() == "comment")
      r.string(item.key());
    else
      r.number(item.key());
  }
  return r;
}

TurnDirection direction_of(const JsonObject& r) {
  return r.string("direction", "right") == "left" ? TurnDirection::kLeft : TurnDirection::kRight;
}

TurnSharpness sharpness_of(const JsonObject& r) {
  TurnSharpness s;
  if (r.has("bank_deg")) {
    s.bank_rad = r.number("bank_deg") * kDegToRad;
    if (!(s.bank_rad > 0.0))
      r.fail("bank_deg", "must be in (0, 60] deg, got " + number_text(r.number("bank_deg"), 12));
  }
  if (r.has("rate_deg_s")) {
    s.rate_rad_s = r.number("rate_deg_s") * kDegToRad;
    if (!(s.rate_rad_s > 0.0))
      r.fail("rate_deg_s",
             "must be in (0, 30] deg/s, got " + number_text(r.number("rate_deg_s"), 12));
  }
  if (r.has("bank_deg") == r.has("rate_deg_s"))
    r.fail("give exactly one of bank_deg or rate_deg_s");
  return s;
}

// Apply one segment at `path` of `source` to the builder; `context` (" (cycle 3)") follows its
// type in the messages of the builder ("segments[2]: turn segment: bank_deg must be ...").
void apply_segment(TrajectoryBuilder& b, const json& seg, const std::string& source,
                   const std::string& path, const std::string& context = "") {
  const JsonObject r = segment_reader(seg, source, path);
  const std::string type = r.string("type");
  try {
    if (type == "static") {
      b.hold_static(r.number("duration_s"));
    } else if (type == "straight") {
      b.straight(r.number("duration_s"));
    } else if (type == "speed") {
      const double target = r.number("speed_mps");
      if (target != b.speed_mps()) b.change_speed(target, r.number("accel_mps2", 1.0));
    } else if (type == "turn") {
      b.turn(r.number("turn_deg") * kDegToRad, direction_of(r), sharpness_of(r),
             r.number("ramp_s", 3.0));
    } else if (type == "loiter") {
      const double circles = r.number("circles", 1.0);
      if (!(circles > 0.0)) r.fail("circles", "must be > 0, got " + number_text(circles, 12));
      b.turn(circles * 360.0 * kDegToRad, direction_of(r), sharpness_of(r),
             r.number("ramp_s", 3.0));
    } else if (type == "s_turns") {
      const int count = static_cast<int>(r.has("count") ? r.field("count").integer(1, 1000) : 2);
      const double straight_s = r.number("straight_s", 0.0);
      if (!(straight_s >= 0.0))
        r.fail("straight_s", "must be >= 0, got " + number_text(straight_s, 12));
      TurnDirection dir = direction_of(r);
      for (int i = 0; i < count; ++i) {
        b.turn(r.number("turn_deg") * kDegToRad, dir, sharpness_of(r), r.number("ramp_s", 3.0));
        if (straight_s > 0.0 && i + 1 < count) b.straight(straight_s);
        dir = dir == TurnDirection::kLeft ? TurnDirection::kRight : TurnDirection::kLeft;
      }
    } else if (type == "climb" || type == "descend") {
      const double dh = r.number("dh_m");
      if (!(dh > 0.0))
        r.fail("dh_m", "must be > 0 (the height " +
                           std::string(type == "climb" ? "gained" : "lost") + "), got " +
                           number_text(dh, 12));
      const std::optional<double> pitch_deg = r.optional_number("pitch_deg");
      const double pitch_rad = pitch_deg.value_or(0.0) * kDegToRad;
      b.climb(type == "climb" ? dh : -dh, r.number("vz_mps", 2.0), r.number("ramp_s", 3.0),
              pitch_deg ? &pitch_rad : nullptr);
    } else if (type == "takeoff") {
      b.takeoff(r.number("dh_m"), r.number("vz_mps", 2.0), r.number("ramp_s", 2.0));
    }
  } catch (const JsonFieldError&) {
    throw;  // already in the reader's wording, with the field's path
  } catch (const std::invalid_argument& e) {
    r.fail(type + " segment" + context + ": " + e.what());  // the builder's check of a value
  }
}

EarthModel parse_earth(const JsonObject& r, const InitialPose& initial, std::string& model_out) {
  const std::string model = r.has("model") ? r.field("model").choice({"wgs84", "paper"}) : "wgs84";
  EarthModel e;
  if (model == "wgs84") {
    e = EarthModel::wgs84();
    if (r.has("g0_mps2")) r.fail("g0_mps2", "only for model 'paper'; use g_eq_mps2");
  } else {
    if (r.has("g_eq_mps2"))
      r.fail("g_eq_mps2", "model 'paper' sets g_eq_mps2 from g0_mps2; give g0_mps2");
    e = EarthModel::paper(initial.lat_rad, initial.h_m, r.number("g0_mps2", 9.801));
  }
  e.ellipsoid.a_m = r.number("a_m", e.ellipsoid.a_m);
  e.ellipsoid.f = r.number("f", e.ellipsoid.f);
  e.omega_ie_rad_s = r.number("omega_ie_rad_s", e.omega_ie_rad_s);
  e.g_eq_mps2 = r.number("g_eq_mps2", e.g_eq_mps2);
  if (const std::string err = e.validate(); !err.empty()) r.fail(err);
  model_out = model;
  return e;
}

NoiseSpec parse_noise(const JsonObject& r) {
  NoiseSpec n;
  const std::string grade = r.string("grade", "none");
  try {
    n = noise_grade(grade);
  } catch (const std::invalid_argument& e) {
    r.fail("grade", e.what());
  }
  n.arw_deg_rth = r.number("arw_deg_rth", n.arw_deg_rth);
  n.vrw_mps_rth = r.number("vrw_mps_rth", n.vrw_mps_rth);
  n.gnss_vel_sigma_mps = r.number("gnss_vel_sigma_mps", n.gnss_vel_sigma_mps);
  n.gnss_pos_sigma_m = r.number("gnss_pos_sigma_m", n.gnss_pos_sigma_m);
  n.gm_gyro_sigma_deg_h = r.number("gm_gyro_sigma_deg_h", n.gm_gyro_sigma_deg_h);
  n.gm_accel_sigma_mps2 = r.number("gm_accel_sigma_mps2", n.gm_accel_sigma_mps2);
  n.gm_tau_s = r.number("gm_tau_s", n.gm_tau_s);
  if (const std::string err = n.validate(); !err.empty()) r.fail(err);
  return n;
}

// "injected" (SI) or "injected_sigma" (in catalogue sigma): effect name -> value.
void parse_injected(const JsonObject& r, bool in_sigma, SensorErrors& errors) {
  for (const auto& item : r.value().items()) {
    const std::string& name = item.key();
    if (!is_effect_name(name))
      r.fail(name, "unknown effect name '" + name +
                       "' (see the effect catalogue, docs/design.md sec. 4)");
    add_effect(errors, name, r.number(name) * (in_sigma ? effect_info(name).sigma : 1.0));
  }
}

bool is_multiple(double duration_s, double rate_hz) {
  const double n = duration_s * rate_hz;
  return std::fabs(n - std::round(n)) < 1e-6;
}

}  // namespace

ScenarioConfig parse_scenario(const json& j, const std::string& origin) {
  const JsonObject r =
      JsonObject::document(j, origin,
                           {"name", "description", "comment", "imu_rate_hz", "gnss_rate_hz",
                            "earth", "initial", "align_s", "flight_s", "substeps", "seed", "noise",
                            "injected", "injected_sigma", "segments", "repeat", "motors_on_s"});
  ScenarioConfig c;
  c.origin = origin;
  c.name = r.string("name", "custom");
  c.description = r.string("description", "");
  if (r.has("comment")) r.string("comment");
  c.imu_rate_hz = r.number("imu_rate_hz", c.imu_rate_hz);
  c.gnss_rate_hz = r.number("gnss_rate_hz", c.gnss_rate_hz);
  const JsonObject initial = r.object(
      "initial", {"lat_deg", "lon_deg", "h_m", "roll_deg", "pitch_deg", "yaw_deg", "comment"});
  c.initial.lat_rad = initial.number("lat_deg") * kDegToRad;
  c.initial.lon_rad = initial.number("lon_deg") * kDegToRad;
  c.initial.h_m = initial.number("h_m", 0.0);
  c.initial.attitude.roll_rad = initial.number("roll_deg", 0.0) * kDegToRad;
  c.initial.attitude.pitch_rad = initial.number("pitch_deg", 0.0) * kDegToRad;
  c.initial.attitude.yaw_rad = initial.number("yaw_deg", 0.0) * kDegToRad;
  if (r.has("earth"))
    c.earth = parse_earth(r.object("earth", {"model", "a_m", "f", "omega_ie_rad_s", "g_eq_mps2",
                                             "g0_mps2", "comment"}),
                          c.initial, c.earth_model);
  c.align_s = r.number("align_s", c.align_s);
  c.flight_s = r.optional_number("flight_s");
  if (r.has("substeps")) c.substeps = static_cast<int>(r.field("substeps").integer(1, 1000));
  // Seeds up to 2^53, where doubles (JSON numbers) still count every integer.
  if (r.has("seed"))
    c.seed = static_cast<std::uint64_t>(r.field("seed").integer(0, std::int64_t{1} << 53));
  if (r.has("noise"))
    c.noise = parse_noise(r.object(
        "noise", {"grade", "arw_deg_rth", "vrw_mps_rth", "gnss_vel_sigma_mps", "gnss_pos_sigma_m",
                  "gm_gyro_sigma_deg_h", "gm_accel_sigma_mps2", "gm_tau_s", "comment"}));
  if (r.has("injected")) parse_injected(r.field("injected").map(), false, c.injected);
  if (r.has("injected_sigma")) parse_injected(r.field("injected_sigma").map(), true, c.injected);
  if (r.has("motors_on_s")) c.motors = read_motor_schedule(r.array("motors_on_s"));
  if (r.has("segments")) c.segments = r.array("segments").value();
  if (r.has("repeat")) c.repeat = r.array("repeat").value();
  for (std::size_t i = 0; i < c.segments.size(); ++i)
    segment_reader(c.segments[i], origin, json_index_path("segments", i));
  for (std::size_t i = 0; i < c.repeat.size(); ++i)
    segment_reader(c.repeat[i], origin, json_index_path("repeat", i));
  plan_scenario(c);  // all semantic checks now, with the origin in every message
  return c;
}

ScenarioConfig load_scenario_file(const std::filesystem::path& path) {
  json j;
  try {
    j = read_json_file(path);
  } catch (const std::runtime_error& e) {
    throw std::invalid_argument(e.what());
  }
  return parse_scenario(j, path.string());
}

std::vector<std::string> preset_names() {
  std::vector<std::string> names;
  for (const auto& [name, text] : preset_texts()) names.push_back(name);
  return names;
}

ScenarioConfig with_overrides(ScenarioConfig cfg, const ScenarioOverrides& overrides) {
  if (overrides.seed) cfg.seed = *overrides.seed;
  if (overrides.grade) cfg.noise = noise_grade(*overrides.grade);
  if (overrides.flight_s) cfg.flight_s = *overrides.flight_s;
  if (overrides.clean) cfg.injected = SensorErrors{};
  for (const auto& [name, value] : overrides.set) add_effect(cfg.injected, name, value);
  return cfg;
}

Dataset simulate_preset(std::string_view preset, const ScenarioOverrides& overrides,
                        bool record_truth_in_meta, int threads) {
  return simulate(with_overrides(preset_scenario(preset), overrides), record_truth_in_meta,
                  threads);
}

ScenarioConfig preset_scenario(std::string_view name) {
  for (const auto& [n, text] : preset_texts())
    if (n == name)
      return parse_scenario(parse_json_strict(text, "preset '" + n + "'"), "preset '" + n + "'");
  std::string list;
  for (const auto& n : preset_names()) list += (list.empty() ? "" : ", ") + n;
  throw std::invalid_argument("unknown preset '" + std::string(name) + "' (valid: " + list + ")");
}

json scenario_to_json(const ScenarioConfig& c) {
  json j;
  j["name"] = c.name;
  if (!c.description.empty()) j["description"] = c.description;
  j["imu_rate_hz"] = c.imu_rate_hz;
  j["gnss_rate_hz"] = c.gnss_rate_hz;
  j["earth"] = {{"model", c.earth_model == "paper" ? "paper" : "wgs84"},
                {"a_m", c.earth.ellipsoid.a_m},
                {"f", c.earth.ellipsoid.f},
                {"omega_ie_rad_s", c.earth.omega_ie_rad_s}};
  if (c.earth_model == "paper") {
    j["earth"]["g0_mps2"] = c.earth.normal_gravity_mps2(c.initial.lat_rad, c.initial.h_m);
  } else {
    j["earth"]["g_eq_mps2"] = c.earth.g_eq_mps2;
  }
  j["initial"] = {{"lat_deg", c.initial.lat_rad * kRadToDeg},
                  {"lon_deg", c.initial.lon_rad * kRadToDeg},
                  {"h_m", c.initial.h_m},
                  {"roll_deg", c.initial.attitude.roll_rad * kRadToDeg},
                  {"pitch_deg", c.initial.attitude.pitch_rad * kRadToDeg},
                  {"yaw_deg", c.initial.attitude.yaw_rad * kRadToDeg}};
  j["align_s"] = c.align_s;
  if (c.flight_s) j["flight_s"] = *c.flight_s;
  j["substeps"] = c.substeps;
  j["seed"] = c.seed;
  j["noise"] = {{"grade", c.noise.grade},
                {"arw_deg_rth", c.noise.arw_deg_rth},
                {"vrw_mps_rth", c.noise.vrw_mps_rth},
                {"gnss_vel_sigma_mps", c.noise.gnss_vel_sigma_mps},
                {"gnss_pos_sigma_m", c.noise.gnss_pos_sigma_m},
                {"gm_gyro_sigma_deg_h", c.noise.gm_gyro_sigma_deg_h},
                {"gm_accel_sigma_mps2", c.noise.gm_accel_sigma_mps2},
                {"gm_tau_s", c.noise.gm_tau_s}};
  j["injected"] = json::object();
  for (const auto& [k, v] : nonzero_effects(c.injected)) j["injected"][k] = v;
  j["segments"] = c.segments;
  j["repeat"] = c.repeat;
  if (!c.motors.empty()) {
    j["motors_on_s"] = json::array();
    for (const auto& [t_on, t_off] : c.motors.on_s) j["motors_on_s"].push_back({t_on, t_off});
  }
  return j;
}

ScenarioPlan plan_scenario(const ScenarioConfig& c) {
  auto fail = [&](const std::string& what) { throw std::invalid_argument(c.origin + ": " + what); };
  // A motor offset acts only while the motors run: without a schedule it would do nothing.
  if (c.motors.empty())
    for (const auto& [name, value] : nonzero_effects(c.injected))
      if (effect_info(name).kind == EffectKind::kMotorOffset)
        fail("injected " + name +
             " acts only while the motors run, and the scenario has no "
             "motors_on_s");
  if (!(c.imu_rate_hz > 0.0 && c.imu_rate_hz <= 10000.0))
    fail("imu_rate_hz must be in (0, 10000] Hz, got " + number_text(c.imu_rate_hz, 12));
  if (!(c.gnss_rate_hz > 0.0 && c.gnss_rate_hz <= c.imu_rate_hz))
    fail("gnss_rate_hz must be in (0, imu_rate_hz = " + number_text(c.imu_rate_hz, 12) +
         "] Hz, got " + number_text(c.gnss_rate_hz, 12));
  const double ratio = c.imu_rate_hz / c.gnss_rate_hz;
  if (std::fabs(ratio - std::round(ratio)) > 1e-9 * ratio)
    fail("gnss_rate_hz = " + number_text(c.gnss_rate_hz, 12) +
         " Hz does not divide imu_rate_hz = " + number_text(c.imu_rate_hz, 12) +
         " Hz (the GNSS epochs must fall on IMU epochs)");
  if (!(c.align_s > 0.0) || !std::isfinite(c.align_s))
    fail("align_s must be > 0 s, got " + number_text(c.align_s, 12));
  if (!is_multiple(c.align_s, c.imu_rate_hz))
    fail("align_s = " + number_text(c.align_s, 12) + " s is not a whole number of IMU periods (1/" +
         number_text(c.imu_rate_hz, 12) + " s)");
  if (c.flight_s) {
    if (!(*c.flight_s > 0.0) || !std::isfinite(*c.flight_s))
      fail("flight_s must be > 0 s, got " + number_text(*c.flight_s, 12));
    if (*c.flight_s > 30.0 * 3600.0)
      fail("flight_s must be at most 30 h, got " + number_text(*c.flight_s, 12));
    if (!is_multiple(*c.flight_s, c.imu_rate_hz))
      fail("flight_s = " + number_text(*c.flight_s, 12) +
           " s is not a whole number of IMU periods (1/" + number_text(c.imu_rate_hz, 12) + " s)");
  }
  if (const std::string e = c.noise.validate(); !e.empty()) fail(e);
  if (const std::string e = c.earth.validate(); !e.empty()) fail(e);
  if (!(c.substeps >= 1 && c.substeps <= 1000))
    fail("substeps must be in [1, 1000], got " + std::to_string(c.substeps));
  if (!(std::fabs(c.injected.gnss_latency_s) <= 1.0))
    fail("gnss_latency must be within [-1, 1] s, got " +
         number_text(c.injected.gnss_latency_s, 12));

  TrajectoryBuilder b = [&] {
    try {
      return TrajectoryBuilder(c.initial,
                               c.earth.normal_gravity_mps2(c.initial.lat_rad, c.initial.h_m));
    } catch (const std::invalid_argument& e) {
      fail(e.what());
    }
    throw std::logic_error("unreachable");
  }();
  b.hold_static(c.align_s);
  for (std::size_t i = 0; i < c.segments.size(); ++i)
    apply_segment(b, c.segments[i], c.origin, json_index_path("segments", i));
  double flight_s = 0.0;
  if (c.flight_s) {
    flight_s = *c.flight_s;
    const double t_end = c.align_s + flight_s;
    if (!c.repeat.empty()) {
      for (std::size_t cycle = 0; b.now_s() < t_end; ++cycle) {
        const double before = b.now_s();
        for (std::size_t i = 0; i < c.repeat.size() && b.now_s() < t_end; ++i)
          apply_segment(b, c.repeat[i], c.origin, json_index_path("repeat", i),
                        " (cycle " + std::to_string(cycle) + ")");
        if (!(b.now_s() > before)) fail("repeat segments take no time");
      }
    }
  } else {
    if (!c.repeat.empty()) fail("'repeat' needs 'flight_s' (how long to keep repeating)");
    const double flown = b.now_s() - c.align_s;
    if (!(flown > 0.0)) fail("no flight after the alignment: give 'segments' or 'flight_s'");
    // Round up to a whole GNSS period.
    flight_s = std::ceil(flown * c.gnss_rate_hz - 1e-6) / c.gnss_rate_hz;
  }
  ScenarioPlan p;
  p.trajectory = b.build();
  p.flight_s = flight_s;
  p.num_imu_steps = static_cast<std::size_t>(std::llround((c.align_s + flight_s) * c.imu_rate_hz));
  p.num_gnss =
      static_cast<std::size_t>(std::floor((c.align_s + flight_s) * c.gnss_rate_hz + 1e-6)) + 1;
  return p;
}

std::string HeadingStreamSpec::validate() const {
  const auto bad = [](const char* name, double v, const char* range) {
    std::ostringstream s;
    s << name << " " << v << ": must be " << range;
    return s.str();
  };
  if (!(std::isfinite(rate_hz) && rate_hz > 0.0 && rate_hz <= 1000.0))
    return bad("--heading-rate-hz", rate_hz, "in (0, 1000] Hz");
  if (!(std::isfinite(sd_deg) && sd_deg > 0.0 && sd_deg <= 180.0))
    return bad("--heading-sd-deg", sd_deg, "in (0, 180] deg");
  if (!(std::isfinite(declination_deg) && std::abs(declination_deg) <= 180.0))
    return bad("--declination-deg", declination_deg, "within [-180, 180] deg");
  if (!(std::isfinite(inclination_deg) && std::abs(inclination_deg) < 89.0))
    return bad("--inclination-deg", inclination_deg,
               "within (-89, 89) deg (a vertical field gives no heading)");
  if (!(std::isfinite(mag_noise_fraction) && mag_noise_fraction >= 0.0 &&
        mag_noise_fraction <= 1.0))
    return bad("--mag-noise", mag_noise_fraction, "in [0, 1] (a fraction of the field)");
  return "";
}

void add_heading_stream(Dataset& ds, const HeadingStreamSpec& spec) {
  if (const std::string why = spec.validate(); !why.empty()) throw std::invalid_argument(why);
  if (ds.truth.empty() || ds.imu.size() < 2)
    throw std::invalid_argument("a simulated heading needs the simulation's truth.csv");
  GaussianRng rng(splitmix64(spec.seed ^ 0x48444EULL));  // "HDN"
  const bool magnetometer = spec.source == HeadingSourceKind::kMagnetometer;
  const double t0 = ds.imu.front().t_s;
  const double t1 = magnetometer ? t0 + ds.meta.align_s : ds.imu.back().t_s;
  // The static window's mean specific force, as the importer levels a magnetometer with it.
  Eigen::Vector3d f_mean_b = Eigen::Vector3d::Zero();
  if (magnetometer) {
    const std::optional<Eigen::Vector3d> f = mean_specific_force_b(ds.imu, t1);
    if (!f)
      throw std::invalid_argument("a simulated magnetometer needs a static window (align_s > 0)");
    f_mean_b = *f;
  }
  const double D = spec.declination_deg * kDegToRad, I = spec.inclination_deg * kDegToRad;
  const Eigen::Vector3d B_n(std::cos(I) * std::sin(D), std::cos(I) * std::cos(D), -std::sin(I));
  std::size_t row = 0;
  ds.heading.clear();
  for (long k = 0;; ++k) {
    const double t = t0 + static_cast<double>(k) / spec.rate_hz;
    if (t > t1 + 1e-9) break;
    while (row + 1 < ds.truth.size() &&
           std::abs(ds.truth[row + 1].t_s - t) <= std::abs(ds.truth[row].t_s - t))
      ++row;
    const TruthSample& truth = ds.truth[row];
    HeadingSample s;
    s.t_s = truth.t_s;
    if (!ds.heading.empty() && !(s.t_s > ds.heading.back().t_s)) continue;
    if (magnetometer) {
      // The field in body axes, C_b_n^T B_n (C_b_n: body FRD -> ENU), plus white noise.
      Eigen::Vector3d m_b = C_b_n_from_euler(truth.attitude).transpose() * B_n;
      for (int i = 0; i < 3; ++i) m_b[i] += spec.mag_noise_fraction * rng.normal();
      s.yaw_rad = magnetometer_true_heading_rad(m_b, f_mean_b, D);
    } else {
      s.yaw_rad = wrap_pi(truth.attitude.yaw_rad + spec.sd_deg * kDegToRad * rng.normal());
      s.sd_rad = spec.sd_deg * kDegToRad;
    }
    ds.heading.push_back(s);
  }
  HeadingMeta meta;
  meta.source = spec.source;
  if (magnetometer) meta.declination_deg = spec.declination_deg;
  ds.meta.heading = meta;
}

Dataset simulate(const ScenarioConfig& cfg, bool record_truth_in_meta, int threads) {
  return simulate(cfg, plan_scenario(cfg), record_truth_in_meta, threads);
}

Dataset simulate(const ScenarioConfig& cfg, const ScenarioPlan& plan, bool record_truth_in_meta,
                 int threads) {
  ImuSynthesizer synth(plan.trajectory, cfg.earth, cfg.imu_rate_hz, cfg.substeps);
  synth.run(plan.num_imu_steps, threads);

  Dataset ds;
  DatasetMeta& m = ds.meta;
  m.imu_rate_hz = cfg.imu_rate_hz;
  m.gnss_rate_hz = cfg.gnss_rate_hz;
  m.earth = cfg.earth;
  m.align_s = cfg.align_s;
  m.initial.t_s = 0.0;
  m.initial.lat_rad = cfg.initial.lat_rad;
  m.initial.lon_rad = cfg.initial.lon_rad;
  m.initial.h_m = cfg.initial.h_m;
  m.initial.attitude = cfg.initial.attitude;
  // The motor state is what an autopilot logs, measured like the IMU: written in any case.
  m.motors = cfg.motors;
  if (!cfg.motors.empty()) m.motors_source = "scenario motors_on_s";
  if (record_truth_in_meta) {
    m.injected = nonzero_effects(cfg.injected);
    m.noise = cfg.noise.levels();
  }

  // --- IMU: errors (docs/design.md sec. 3 sensor model), bias instability, white noise.
  const double dt = 1.0 / cfg.imu_rate_hz;
  const NoiseSpec& n = cfg.noise;
  const bool noisy = !n.is_zero();
  GaussianRng imu_rng(splitmix64(cfg.seed ^ 0x494D55ULL));     // "IMU"
  GaussianRng gm_rng(splitmix64(cfg.seed ^ 0x474D42ULL));      // "GMB"
  GaussianRng gnss_rng(splitmix64(cfg.seed ^ 0x474E5353ULL));  // "GNSS"
  const double sigma_dtheta = n.arw_deg_rth * kDegToRad / 60.0 * std::sqrt(dt);
  const double sigma_dv = n.vrw_mps_rth / 60.0 * std::sqrt(dt);
  const double gm_phi = std::exp(-dt / n.gm_tau_s);
  const double gm_drive = std::sqrt(std::max(0.0, 1.0 - gm_phi * gm_phi));
  const double gm_gyro = n.gm_gyro_sigma_deg_h * kDegToRad / 3600.0;
  const double gm_accel = n.gm_accel_sigma_mps2;
  const bool has_gm = gm_gyro > 0.0 || gm_accel > 0.0;
  Eigen::Vector3d gm_b_gyro = Eigen::Vector3d::Zero(), gm_b_accel = Eigen::Vector3d::Zero();
  if (has_gm) {  // stationary start
    for (int i = 0; i < 3; ++i) gm_b_gyro[i] = gm_gyro * gm_rng.normal();
    for (int i = 0; i < 3; ++i) gm_b_accel[i] = gm_accel * gm_rng.normal();
  }
  ds.imu = synth.take_imu();  // moved, not copied: 860 000 rows for paper-fig9
  for (ImuSample& s : ds.imu) {
    apply_imu_errors(cfg.injected, s.t_s, dt, s.dtheta_b_rad, s.dv_b_mps,
                     cfg.motors.empty() ? 0.0 : cfg.motors.fraction(s.t_s - dt, s.t_s));
    if (has_gm) {
      for (int i = 0; i < 3; ++i)
        gm_b_gyro[i] = gm_phi * gm_b_gyro[i] + gm_gyro * gm_drive * gm_rng.normal();
      for (int i = 0; i < 3; ++i)
        gm_b_accel[i] = gm_phi * gm_b_accel[i] + gm_accel * gm_drive * gm_rng.normal();
      s.dtheta_b_rad += gm_b_gyro * dt;
      s.dv_b_mps += gm_b_accel * dt;
    }
    if (noisy) {
      for (int i = 0; i < 3; ++i) s.dtheta_b_rad[i] += sigma_dtheta * imu_rng.normal();
      for (int i = 0; i < 3; ++i) s.dv_b_mps[i] += sigma_dv * imu_rng.normal();
    }
  }
  ds.truth = synth.take_truth();

  // --- GNSS: antenna (lever arm) at the tagged time minus the latency, plus white noise.
  const double latency = cfg.injected.gnss_latency_s;
  const Eigen::Vector3d& lever = cfg.injected.lever_arm_b_m;
  const std::size_t decim =
      static_cast<std::size_t>(std::llround(cfg.imu_rate_hz / cfg.gnss_rate_hz));
  reserve_huge_pages(ds.gnss, plan.num_gnss);  // base/huge_pages.h
  for (std::size_t j = 0; j < plan.num_gnss; ++j) {
    const double t = static_cast<double>(j) / cfg.gnss_rate_hz;
    GnssSample g;
    const std::size_t k = j * decim;  // IMU epoch index (0 = start)
    if (latency == 0.0 && lever.isZero(0) && k >= 1 && k <= ds.truth.size()) {
      const TruthSample& tr = ds.truth[k - 1];
      g.lat_rad = tr.lat_rad;
      g.lon_rad = tr.lon_rad;
      g.h_m = tr.h_m;
      g.v_eb_n_mps = tr.v_eb_n_mps;
    } else {
      g = antenna_solution(cfg.earth, synth.state_at(t - latency), lever);
    }
    g.t_s = t;
    if (noisy) {
      const double dE = n.gnss_pos_sigma_m * gnss_rng.normal();
      const double dN = n.gnss_pos_sigma_m * gnss_rng.normal();
      const double dU = n.gnss_pos_sigma_m * gnss_rng.normal();
      g.lat_rad += dN / (cfg.earth.meridian_radius_m(g.lat_rad) + g.h_m);
      g.lon_rad +=
          dE / ((cfg.earth.prime_vertical_radius_m(g.lat_rad) + g.h_m) * std::cos(g.lat_rad));
      g.h_m += dU;
      for (int i = 0; i < 3; ++i) g.v_eb_n_mps[i] += n.gnss_vel_sigma_mps * gnss_rng.normal();
    }
    ds.gnss.push_back(g);
  }
  return ds;
}

json answer_json(const ScenarioConfig& cfg) {
  json a;
  a["format"] = "insid-answer/1";
  a["scenario"] = cfg.name;
  a["seed"] = cfg.seed;
  a["injected"] = json::object();
  a["injected_sigma"] = json::object();
  for (const auto& [k, v] : nonzero_effects(cfg.injected)) {
    a["injected"][k] = v;
    a["injected_sigma"][k] = v / effect_info(k).sigma;
  }
  const NoiseSpec& n = cfg.noise;
  a["noise"] = {{"grade", n.grade},
                {"arw_deg_rth", n.arw_deg_rth},
                {"vrw_mps_rth", n.vrw_mps_rth},
                {"gnss_vel_sigma_mps", n.gnss_vel_sigma_mps},
                {"gnss_pos_sigma_m", n.gnss_pos_sigma_m},
                {"gm_gyro_sigma_deg_h", n.gm_gyro_sigma_deg_h},
                {"gm_accel_sigma_mps2", n.gm_accel_sigma_mps2},
                {"gm_tau_s", n.gm_tau_s}};
  a["config"] = scenario_to_json(cfg);
  return a;
}

}  // namespace insid::scenarios
