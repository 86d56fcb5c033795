// The only file that sees the TOML library (toml++ is slow to compile): it
// turns the document into SettingsTables with source lines, and everything
// else reads those.
#include "hw/rig_profile.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>

#include "hw/backend_registry.hpp"
#include "hw/default_profile.hpp"
#include "hw/format.hpp"
#include "hw/memory.hpp"
#include "hw/try.hpp"

namespace collide::hw {

namespace {

const std::vector<std::string> kSections = {
    "regulator",   "valves",    "camera", "burst",      "geometry", "launcher", "spheres",
    "calibration", "sequencer", "safety", "simulation", "analysis", "wall"};

std::string at(const std::string& source, const toml::source_region& where) {
  return source + ":" + std::to_string(where.begin.line);
}

Status convertValue(const toml::node& node, const std::string& source, const std::string& field,
                    SettingValue& out) {
  out.line = static_cast<int>(node.source().begin.line);
  if (const auto* b = node.as_boolean()) {
    out.value = b->get();
  } else if (const auto* i = node.as_integer()) {
    out.value = i->get();
  } else if (const auto* f = node.as_floating_point()) {
    out.value = f->get();
  } else if (const auto* s = node.as_string()) {
    out.value = s->get();
  } else if (const auto* a = node.as_array()) {
    std::vector<double> numbers;
    std::vector<std::string> strings;
    for (const toml::node& e : *a) {
      if (const auto* ei = e.as_integer())
        numbers.push_back(static_cast<double>(ei->get()));
      else if (const auto* ef = e.as_floating_point())
        numbers.push_back(ef->get());
      else if (const auto* es = e.as_string())
        strings.push_back(es->get());
      else
        return fail(at(source, node.source()) + ": " + field +
                    ": arrays may hold only numbers or only strings");
    }
    if (!numbers.empty() && !strings.empty())
      return fail(at(source, node.source()) + ": " + field +
                  ": arrays may hold only numbers or only strings, not both");
    if (strings.empty())
      out.value = std::move(numbers);
    else
      out.value = std::move(strings);
  } else {
    return fail(at(source, node.source()) + ": " + field +
                ": dates and times are not used in a rig profile");
  }
  return Ok{};
}

// Nested tables become dotted keys: [camera.fault] x -> "fault.x".
Status flatten(const toml::table& table, const std::string& prefix, SettingsTable& out) {
  for (auto&& [key, node] : table) {
    const std::string name = prefix + std::string(key.str());
    const std::string field = out.name.empty() ? name : out.name + "." + name;
    if (const auto* sub = node.as_table()) {
      COLLIDE_RETURN_IF_ERROR(flatten(*sub, name + ".", out));
    } else if (node.is_array_of_tables()) {
      return fail(at(out.source, node.source()) + ": " + field +
                  ": arrays of tables are not used here");
    } else {
      SettingValue v;
      COLLIDE_RETURN_IF_ERROR(convertValue(node, out.source, field, v));
      out.values.emplace(name, std::move(v));
    }
  }
  return Ok{};
}

std::string sectionList() {
  std::string s;
  for (const auto& k : kSections) s += (s.empty() ? "" : ", ") + k;
  return s;
}

struct Document {
  SettingsTable top;
  std::map<std::string, SettingsTable> sections;
  std::vector<SettingsTable> launchers;
};

Result<Document> toDocument(std::string_view text, const std::string& source) {
  toml::table root;
  try {
    root = toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    return fail(source + ":" + std::to_string(e.source().begin.line) + ":" +
                std::to_string(e.source().begin.column) +
                ": not valid TOML: " + std::string(e.description()));
  }
  Document doc;
  doc.top.source = source;
  for (auto&& [k, node] : root) {
    const std::string key(k.str());
    const bool known = std::find(kSections.begin(), kSections.end(), key) != kSections.end();
    if (node.is_table() || node.is_array_of_tables()) {
      if (!known)
        return fail(at(source, node.source()) + ": [" + key +
                    "] is not a section of a rig profile (known: " + sectionList() + ")");
      if (key == "launcher") {
        if (!node.is_array_of_tables())
          return fail(at(source, node.source()) +
                      ": launcher: write one [[launcher]] table per tube (two of them)");
        int n = 0;
        for (const toml::node& t : *node.as_array()) {
          SettingsTable table{"launcher[" + std::to_string(++n) + "]",
                              source,
                              static_cast<int>(t.source().begin.line),
                              {}};
          COLLIDE_RETURN_IF_ERROR(flatten(*t.as_table(), "", table));
          doc.launchers.push_back(std::move(table));
        }
      } else {
        if (!node.is_table())
          return fail(at(source, node.source()) + ": " + key + ": write it as one [" + key +
                      "] table");
        SettingsTable table{key, source, static_cast<int>(node.source().begin.line), {}};
        COLLIDE_RETURN_IF_ERROR(flatten(*node.as_table(), "", table));
        doc.sections.emplace(key, std::move(table));
      }
    } else {
      if (known)
        return fail(at(source, node.source()) + ": " + key + " must be a [" + key + "] section");
      SettingValue v;
      COLLIDE_RETURN_IF_ERROR(convertValue(node, source, key, v));
      doc.top.values.emplace(key, std::move(v));
    }
  }
  return doc;
}

Result<const SettingsTable*> section(const Document& doc, const std::string& name) {
  const auto it = doc.sections.find(name);
  if (it == doc.sections.end())
    return fail(doc.top.source + ": [" + name +
                "] is missing: add the section (config/sim.toml documents every one)");
  return &it->second;
}

// Reads what every backend of a role shares: backend and device, plus the
// role keys the caller reads with `reader` before finish.
Result<DeviceProfile> deviceHead(const SettingsTable& table, SettingsReader& r) {
  DeviceProfile d;
  d.table = table;
  COLLIDE_ASSIGN_OR_RETURN(d.backend, r.text("backend"));
  COLLIDE_ASSIGN_OR_RETURN(d.device, r.text("device", d.backend));
  return d;
}

void keepRoleKeys(DeviceProfile& d, const std::vector<std::string>& keys) {
  d.role_keys = keys;
  d.role_keys.push_back("backend");
  d.role_keys.push_back("device");
}

Result<int> wholePixel(SettingsReader& r, const std::string& key, double v, double min) {
  if (!(std::floor(v) == v && v >= min))
    return r.invalid(key, min > 0 ? "each element must be a whole number > 0"
                                  : "x and y must be whole numbers >= 0");
  if (v > vision::kMaxFrameSidePx)
    return r.invalid(
        key, "each element must be at most " + std::to_string(vision::kMaxFrameSidePx) + " pixels");
  return static_cast<int>(v);
}

/// Highest frame rate a profile may ask for: the fastest cameras made (about
/// 10 million frames/s) with a margin; beyond it periods lose their meaning
/// in integer nanoseconds.
constexpr double kMaxFps = 2e7;
/// Lowest: a collision lasts well under a second; below one frame a second a
/// burst spans minutes and its timing overflows nothing but helps no one.
constexpr double kMinFps = 1.0;

Status parseCameraCalibration(const SettingsTable& t, SettingsReader& r, RigProfile& p);

Status parseCamera(const SettingsTable& t, RigProfile& p) {
  SettingsReader r(t);
  COLLIDE_ASSIGN_OR_RETURN(p.camera, deviceHead(t, r));
  keepRoleKeys(p.camera, {"roi", "format", "fps", "exposure_us", "gain_db"});
  CameraConfig& c = p.camera_config;
  COLLIDE_ASSIGN_OR_RETURN(const std::vector<double> roi, r.numbers("roi", 4));
  COLLIDE_ASSIGN_OR_RETURN(c.roi_x, wholePixel(r, "roi", roi[0], 0));
  COLLIDE_ASSIGN_OR_RETURN(c.roi_y, wholePixel(r, "roi", roi[1], 0));
  COLLIDE_ASSIGN_OR_RETURN(c.width, wholePixel(r, "roi", roi[2], 1));
  COLLIDE_ASSIGN_OR_RETURN(c.height, wholePixel(r, "roi", roi[3], 1));
  COLLIDE_ASSIGN_OR_RETURN(const std::string format, r.text("format"));
  if (!vision::parsePixelFormat(format, c.format))
    return r.invalid("format", "must be \"Mono8\", \"Mono12\" or \"Mono16\"");
  if (c.roi_x + c.width > vision::kMaxFrameSidePx || c.roi_y + c.height > vision::kMaxFrameSidePx)
    return r.invalid("roi", "the region must end within " +
                                std::to_string(vision::kMaxFrameSidePx) + " pixels of the origin");
  COLLIDE_ASSIGN_OR_RETURN(c.fps, r.number("fps", std::nullopt, {.ge = kMinFps, .le = kMaxFps}));
  COLLIDE_ASSIGN_OR_RETURN(c.exposure_us, r.number("exposure_us", std::nullopt, {.gt = 0.0}));
  if (c.exposure_us > 1e6 / c.fps)
    return r.invalid("exposure_us", "must be at most one frame period (" + num(1e6 / c.fps) +
                                        " us at " + num(c.fps) + " frames/s)");
  COLLIDE_ASSIGN_OR_RETURN(c.gain_db, r.number("gain_db", 0.0, {.ge = 0.0}));
  COLLIDE_RETURN_IF_ERROR(parseCameraCalibration(t, r, p));
  return checkBackendKnown<Camera>(p.camera);
}

// [camera.calibration] (keys "calibration.*" of the [camera] table).
Status parseCameraCalibration(const SettingsTable& t, SettingsReader& r, RigProfile& p) {
  static const std::vector<std::string> kKeys = {"image_px",
                                                 "focal_px",
                                                 "focal_px_sigma",
                                                 "principal_px",
                                                 "principal_px_sigma",
                                                 "distortion",
                                                 "distortion_sigma",
                                                 "plane_distance_m",
                                                 "plane_distance_m_sigma",
                                                 "plane_pixel_size_m",
                                                 "plane_pixel_size_m_sigma",
                                                 "rms_px",
                                                 "views"};
  bool any = false;
  for (const auto& [key, value] : t.values) {
    if (key.rfind("calibration.", 0) != 0) continue;
    any = true;
    const std::string field = key.substr(12);
    if (std::find(kKeys.begin(), kKeys.end(), field) == kKeys.end())
      return r.invalid(key, "not a field of [camera.calibration] (config/sim.toml lists them)");
    p.camera.role_keys.push_back(key);
  }
  if (!any) return Ok{};
  CameraCalibrationProfile c;
  const std::string k = "calibration.";
  COLLIDE_ASSIGN_OR_RETURN(const std::vector<double> size,
                           r.numbers(k + "image_px", 2, std::nullopt, {.ge = 1.0}));
  COLLIDE_ASSIGN_OR_RETURN(c.image_px[0], wholePixel(r, k + "image_px", size[0], 1));
  COLLIDE_ASSIGN_OR_RETURN(c.image_px[1], wholePixel(r, k + "image_px", size[1], 1));
  if (c.image_px[0] != p.camera_config.width || c.image_px[1] != p.camera_config.height)
    return r.invalid(k + "image_px", "the calibration's pictures were " +
                                         std::to_string(c.image_px[0]) + " x " +
                                         std::to_string(c.image_px[1]) + " px but camera.roi is " +
                                         std::to_string(p.camera_config.width) + " x " +
                                         std::to_string(p.camera_config.height) +
                                         ": calibrate again with this region");
  COLLIDE_ASSIGN_OR_RETURN(c.focal_px, r.number(k + "focal_px", std::nullopt, {.gt = 0.0}));
  COLLIDE_ASSIGN_OR_RETURN(c.focal_px_sigma,
                           r.number(k + "focal_px_sigma", std::nullopt, {.ge = 0.0}));
  COLLIDE_ASSIGN_OR_RETURN(const std::vector<double> pp, r.numbers(k + "principal_px", 2));
  COLLIDE_ASSIGN_OR_RETURN(const std::vector<double> pps,
                           r.numbers(k + "principal_px_sigma", 2, std::nullopt, {.ge = 0.0}));
  c.principal_px = {pp[0], pp[1]};
  c.principal_px_sigma = {pps[0], pps[1]};
  COLLIDE_ASSIGN_OR_RETURN(const std::vector<double> d,
                           r.numbers(k + "distortion", 4, std::nullopt, {.ge = -10.0, .le = 10.0}));
  COLLIDE_ASSIGN_OR_RETURN(const std::vector<double> ds,
                           r.numbers(k + "distortion_sigma", 4, std::nullopt, {.ge = 0.0}));
  std::copy(d.begin(), d.end(), c.distortion.begin());
  std::copy(ds.begin(), ds.end(), c.distortion_sigma.begin());
  const auto optionalPair = [&](const std::string& key, std::optional<double>& value,
                                std::optional<double>& sigma) -> Status {
    if (t.has(k + key) != t.has(k + key + "_sigma"))
      return r.invalid(k + key + (t.has(k + key) ? "_sigma" : ""),
                       "give " + key + " and " + key + "_sigma together");
    if (!t.has(k + key)) return Ok{};
    COLLIDE_ASSIGN_OR_RETURN(value, r.number(k + key, std::nullopt, {.gt = 0.0}));
    COLLIDE_ASSIGN_OR_RETURN(sigma, r.number(k + key + "_sigma", std::nullopt, {.ge = 0.0}));
    return Ok{};
  };
  COLLIDE_RETURN_IF_ERROR(
      optionalPair("plane_distance_m", c.plane_distance_m, c.plane_distance_m_sigma));
  COLLIDE_RETURN_IF_ERROR(
      optionalPair("plane_pixel_size_m", c.plane_pixel_size_m, c.plane_pixel_size_m_sigma));
  COLLIDE_ASSIGN_OR_RETURN(c.rms_px, r.number(k + "rms_px", 0.0, {.ge = 0.0}));
  COLLIDE_ASSIGN_OR_RETURN(const std::int64_t views,
                           r.integer(k + "views", 0, {.ge = 0, .le = 100000}));
  c.views = static_cast<int>(views);
  p.camera_calibration = c;
  return Ok{};
}

Status parseRegulator(const SettingsTable& t, RigProfile& p, double& min_kPa, double& max_kPa) {
  SettingsReader r(t);
  COLLIDE_ASSIGN_OR_RETURN(p.regulator, deviceHead(t, r));
  keepRoleKeys(p.regulator, {"min_kpa", "max_kpa"});
  COLLIDE_ASSIGN_OR_RETURN(min_kPa, r.number("min_kpa", 0.0, {.ge = 0.0}));
  COLLIDE_ASSIGN_OR_RETURN(max_kPa, r.number("max_kpa", std::nullopt, {.gt = min_kPa}));
  p.regulator_config = {min_kPa, std::min(max_kPa, p.safety.max_pressure_kPa)};
  return checkBackendKnown<PressureRegulator>(p.regulator);
}

Status parseValves(const SettingsTable& t, RigProfile& p) {
  SettingsReader r(t);
  COLLIDE_ASSIGN_OR_RETURN(p.valves, deviceHead(t, r));
  keepRoleKeys(p.valves, {});
  p.valve_config.max_pulse_us = p.safety.max_valve_pulse_us;
  return checkBackendKnown<ValveBank>(p.valves);
}

Status parseBurst(const SettingsTable& t, RigProfile& p) {
  SettingsReader r(t);
  COLLIDE_ASSIGN_OR_RETURN(p.burst.pre_trigger_frames,
                           r.integer("pre_trigger_frames", std::nullopt, {.ge = 0, .le = 100000}));
  COLLIDE_ASSIGN_OR_RETURN(p.burst.post_trigger_frames,
                           r.integer("post_trigger_frames", std::nullopt, {.ge = 1, .le = 100000}));
  COLLIDE_RETURN_IF_ERROR(r.finish("[burst]"));
  // The whole burst is held in memory (the pre-trigger ring and the frames
  // after it): refuse one this machine cannot hold, with the figures, before
  // anything is armed.
  const CameraConfig& c = p.camera_config;
  const double bytes = static_cast<double>(c.width) * c.height *
                       (c.format == vision::PixelFormat::Mono8 ? 1 : 2) *
                       (p.burst.pre_trigger_frames + p.burst.post_trigger_frames);
  if (const auto avail = availableMemoryBytes(); avail && bytes > 0.8 * static_cast<double>(*avail))
    return r.invalid("post_trigger_frames",
                     "a burst of " + std::to_string(p.burst.pre_trigger_frames) + " + " +
                         std::to_string(p.burst.post_trigger_frames) + " frames of " +
                         std::to_string(c.width) + " x " + std::to_string(c.height) + " " +
                         vision::toString(c.format) + " needs " + formatBytes(bytes) +
                         ", more than the " + formatBytes(0.8 * static_cast<double>(*avail)) +
                         " this machine can spare: record fewer frames or a smaller camera.roi");
  return Ok{};
}

Result<Vec3> vec3(SettingsReader& r, const std::string& key) {
  COLLIDE_ASSIGN_OR_RETURN(const std::vector<double> v, r.numbers(key, 3));
  return Vec3(v[0], v[1], v[2]);
}

Status parseGeometry(const SettingsTable& t, RigProfile& p) {
  SettingsReader r(t);
  GeometryProfile& g = p.geometry;
  COLLIDE_ASSIGN_OR_RETURN(g.pixel_size_m, r.number("pixel_size_m", std::nullopt, {.gt = 0.0}));
  COLLIDE_ASSIGN_OR_RETURN(const std::vector<double> origin, r.numbers("origin_px", 2));
  g.origin_u_px = origin[0];
  g.origin_v_px = origin[1];
  if (t.has("meet_point_m")) {
    COLLIDE_ASSIGN_OR_RETURN(g.meet_point_m, vec3(r, "meet_point_m"));
  }
  return r.finish("[geometry]");
}

Status parseLaunchers(const Document& doc, RigProfile& p) {
  if (doc.launchers.size() != 2)
    return fail(doc.top.source +
                ": the profile needs exactly two [[launcher]] tables, one per "
                "tube (found " +
                std::to_string(doc.launchers.size()) + ")");
  for (std::size_t i = 0; i < 2; ++i) {
    SettingsReader r(doc.launchers[i]);
    LauncherProfile& l = p.launchers[i];
    COLLIDE_ASSIGN_OR_RETURN(l.name, r.text("name", "launcher " + std::to_string(i + 1)));
    COLLIDE_ASSIGN_OR_RETURN(l.valve, r.integer("valve", std::nullopt, {.ge = 0, .le = 1023}));
    COLLIDE_ASSIGN_OR_RETURN(l.regulator_channel,
                             r.integer("regulator_channel", std::nullopt, {.ge = 0, .le = 1023}));
    COLLIDE_ASSIGN_OR_RETURN(l.exit_m, vec3(r, "exit_m"));
    COLLIDE_ASSIGN_OR_RETURN(l.direction, vec3(r, "direction"));
    if (!(l.direction.norm() > 1e-9))
      return r.invalid("direction", "must point somewhere (it is the tube's axis)");
    l.direction.normalize();
    if (doc.launchers[i].has("slide_travel_m")) {
      COLLIDE_ASSIGN_OR_RETURN(const std::vector<double> travel, r.numbers("slide_travel_m", 2));
      if (!(travel[0] <= 0 && travel[1] >= 0 && travel[1] - travel[0] <= 1.0))
        return r.invalid("slide_travel_m",
                         "must be [down, up] in metres around exit_m, down <= 0 <= up, at most "
                         "1 m apart");
      l.slide_travel_m = std::array<double, 2>{travel[0], travel[1]};
    }
    if (i == 1 && l.valve == p.launchers[0].valve)
      return r.invalid("valve", "launcher[1] fires that valve already");
    if (i == 1 && l.regulator_channel == p.launchers[0].regulator_channel)
      return r.invalid("regulator_channel", "launcher[1] uses that channel already");
    COLLIDE_RETURN_IF_ERROR(r.finish("[[launcher]]"));
  }
  return Ok{};
}

// [wall]: after the launchers and spheres, which it is checked against.
Status parseWall(const SettingsTable& t, RigProfile& p) {
  SettingsReader r(t);
  Wall w;
  COLLIDE_ASSIGN_OR_RETURN(w.point_m, vec3(r, "point_m"));
  COLLIDE_ASSIGN_OR_RETURN(w.normal, vec3(r, "normal"));
  if (!(w.normal.norm() > 1e-9))
    return r.invalid("normal",
                     "must point somewhere (out of the plate's face, towards launcher 1)");
  w.normal.normalize();
  const LauncherProfile& l = p.launchers[0];
  const double height_m = (l.exit_m - w.point_m).dot(w.normal);
  if (!(height_m > 0.5 * p.spheres.diameter_m[0]))
    return r.invalid("normal",
                     "launcher 1's exit_m must lie more than a sphere radius in front of the "
                     "plate's face (it is " +
                         num(height_m) + " m along the normal): flip the normal or move point_m");
  // Whether the sphere reaches the plate (gravity bends grazing shots onto
  // it) is the launch plan's question, not the profile's.
  COLLIDE_ASSIGN_OR_RETURN(p.wall_level, r.number("level", 0.0, {.ge = 0.0, .le = 1.0}));
  COLLIDE_RETURN_IF_ERROR(r.finish("[wall]"));
  p.wall = w;
  return Ok{};
}

Status parseSpheres(const SettingsTable& t, RigProfile& p) {
  SettingsReader r(t);
  SpheresProfile& s = p.spheres;
  COLLIDE_ASSIGN_OR_RETURN(s.material_name, r.text("material"));
  COLLIDE_ASSIGN_OR_RETURN(const std::vector<double> d,
                           r.numberOrNumbers("diameter_m", 2, std::nullopt, {.gt = 0.0}));
  COLLIDE_ASSIGN_OR_RETURN(const std::vector<double> m,
                           r.numberOrNumbers("mass_kg", 2, std::nullopt, {.gt = 0.0}));
  s.diameter_m = {d[0], d[1]};
  s.mass_kg = {m[0], m[1]};
  const Material defaults;
  COLLIDE_ASSIGN_OR_RETURN(s.material.e, r.number("e", defaults.e, {.ge = 0.0, .le = 1.0}));
  COLLIDE_ASSIGN_OR_RETURN(s.material.mu, r.number("mu", defaults.mu, {.ge = 0.0}));
  COLLIDE_ASSIGN_OR_RETURN(s.material.beta0,
                           r.number("beta0", defaults.beta0, {.ge = -1.0, .le = 1.0}));
  return r.finish("[spheres]");
}

Status parseCalibration(const SettingsTable& t, RigProfile& p) {
  SettingsReader r(t);
  CalibrationProfile& c = p.calibration;
  COLLIDE_ASSIGN_OR_RETURN(const std::vector<double> k, r.numbers("coefficients", 4));
  std::copy(k.begin(), k.end(), c.coefficients.begin());
  COLLIDE_ASSIGN_OR_RETURN(c.min_kPa, r.number("min_kpa", std::nullopt, {.ge = 0.0}));
  COLLIDE_ASSIGN_OR_RETURN(c.max_kPa, r.number("max_kpa", std::nullopt, {.gt = c.min_kPa}));
  COLLIDE_ASSIGN_OR_RETURN(const double delay_ms,
                           r.number("exit_delay_ms", std::nullopt, {.ge = 0.0, .le = 1000.0}));
  c.exit_delay_s = delay_ms * 1e-3;
  // Speeds become pressures by inverting v(p): it must rise over the range.
  Result<LaunchCalibration> curve = c.curve();
  if (!curve) return r.invalid("coefficients", curve.error().message);
  if (!(curve->minSpeed_m_s() > 0.0))
    return r.invalid("coefficients", "v(min_kpa) = " + num(curve->minSpeed_m_s()) +
                                         " m/s: the exit speed must be > 0 over the range");
  return r.finish("[calibration]");
}

Status parseSequencer(const SettingsTable& t, RigProfile& p) {
  SettingsReader r(t);
  SequencerProfile& s = p.sequencer;
  COLLIDE_ASSIGN_OR_RETURN(s.settle_tolerance_kPa,
                           r.number("settle_tolerance_kpa", std::nullopt, {.gt = 0.0}));
  COLLIDE_ASSIGN_OR_RETURN(const double hold_ms, r.number("settle_hold_ms", 0.0, {.ge = 0.0}));
  s.settle_hold_s = hold_ms * 1e-3;
  COLLIDE_ASSIGN_OR_RETURN(s.settle_timeout_s,
                           r.number("settle_timeout_s", std::nullopt, {.gt = 0.0}));
  COLLIDE_ASSIGN_OR_RETURN(const double poll_ms,
                           r.number("poll_interval_ms", 1.0, {.gt = 0.0, .le = 1000.0}));
  s.poll_interval_s = poll_ms * 1e-3;
  COLLIDE_ASSIGN_OR_RETURN(s.pulse_us, r.integer("pulse_us", std::nullopt, {.gt = 0}));
  COLLIDE_ASSIGN_OR_RETURN(s.collect_timeout_s,
                           r.number("collect_timeout_s", std::nullopt, {.gt = 0.0}));
  COLLIDE_ASSIGN_OR_RETURN(s.max_dropped_frames,
                           r.integer("max_dropped_frames", 0, {.ge = 0, .le = 1e6}));
  if (s.pulse_us > p.safety.max_valve_pulse_us)
    return r.invalid("pulse_us", "exceeds safety.max_valve_pulse_us = " +
                                     std::to_string(p.safety.max_valve_pulse_us));
  return r.finish("[sequencer]");
}

Status parseSafety(const SettingsTable& t, RigProfile& p) {
  SettingsReader r(t);
  SafetyProfile& s = p.safety;
  COLLIDE_ASSIGN_OR_RETURN(s.max_pressure_kPa,
                           r.number("max_pressure_kpa", std::nullopt, {.gt = 0.0}));
  COLLIDE_ASSIGN_OR_RETURN(s.max_valve_pulse_us,
                           r.integer("max_valve_pulse_us", std::nullopt, {.gt = 0}));
  COLLIDE_ASSIGN_OR_RETURN(s.vent_on_failure, r.boolean("vent_on_failure"));
  return r.finish("[safety]");
}

Status parseSimulation(const SettingsTable& t, RigProfile& p) {
  SettingsReader r(t);
  SimulationProfile& s = p.simulation;
  COLLIDE_ASSIGN_OR_RETURN(const std::int64_t seed, r.integer("seed", 1, {.ge = 0}));
  s.seed = static_cast<std::uint64_t>(seed);
  COLLIDE_ASSIGN_OR_RETURN(s.speed_scatter, r.number("speed_scatter", 0.0, {.ge = 0.0, .lt = 1.0}));
  COLLIDE_ASSIGN_OR_RETURN(s.direction_scatter_rad,
                           r.number("direction_scatter_rad", 0.0, {.ge = 0.0, .le = 0.5}));
  COLLIDE_ASSIGN_OR_RETURN(
      const std::vector<double> spin,
      r.numbers("spin_at_exit_rad_s", 2, std::vector<double>{0.0, 0.0}, {.ge = 0.0}));
  if (spin[0] > spin[1]) return r.invalid("spin_at_exit_rad_s", "must be [smallest, largest]");
  s.spin_at_exit_rad_s = {spin[0], spin[1]};
  COLLIDE_ASSIGN_OR_RETURN(const double tilt_deg,
                           r.number("contact_tilt_deg", 0.0, {.ge = -30.0, .le = 30.0}));
  s.contact_tilt_rad = tilt_deg * std::numbers::pi / 180.0;
  COLLIDE_ASSIGN_OR_RETURN(s.out_of_plane_drift,
                           r.number("out_of_plane_drift", 0.0, {.ge = -0.3, .le = 0.3}));
  COLLIDE_ASSIGN_OR_RETURN(const std::string law, r.text("restitution", "constant",
                                                         {"constant", "power", "viscoelastic"}));
  s.restitution = law == "power"          ? RestitutionLaw::Power
                  : law == "viscoelastic" ? RestitutionLaw::Viscoelastic
                                          : RestitutionLaw::Constant;
  COLLIDE_ASSIGN_OR_RETURN(s.restitution_ref_speed_m_s,
                           r.number("restitution_ref_speed_m_s", 1.0, {.gt = 0.0}));
  COLLIDE_ASSIGN_OR_RETURN(s.restitution_exponent,
                           r.number("restitution_exponent", 0.0, {.ge = 0.0, .le = 5.0}));
  COLLIDE_ASSIGN_OR_RETURN(s.air_density_kg_m3, r.number("air_density_kg_m3", kAirDensity_kg_m3,
                                                         {.ge = 0.0, .le = 2.0}));
  return r.finish("[simulation]");
}

Status parseAnalysis(const SettingsTable& t, RigProfile& p) {
  SettingsReader r(t);
  AnalysisProfile& a = p.analysis;
  COLLIDE_ASSIGN_OR_RETURN(
      a.line_of_centres_tilt_deg,
      r.number("line_of_centres_tilt_deg", a.line_of_centres_tilt_deg, {.gt = 0.0, .le = 30.0}));
  COLLIDE_ASSIGN_OR_RETURN(a.launch_out_of_plane_fraction,
                           r.number("launch_out_of_plane_fraction", a.launch_out_of_plane_fraction,
                                    {.gt = 0.0, .le = 0.3}));
  COLLIDE_ASSIGN_OR_RETURN(a.launch_spin_rad_s, r.number("launch_spin_rad_s", a.launch_spin_rad_s,
                                                         {.gt = 0.0, .le = 1000.0}));
  COLLIDE_ASSIGN_OR_RETURN(
      a.contact_distance_sigma_px,
      r.number("contact_distance_sigma_px", a.contact_distance_sigma_px, {.ge = 0.0, .le = 5.0}));
  COLLIDE_ASSIGN_OR_RETURN(
      a.radius_systematic_px,
      r.number("radius_systematic_px", a.radius_systematic_px, {.ge = 0.0, .le = 2.0}));
  COLLIDE_ASSIGN_OR_RETURN(
      a.centre_offset_px, r.number("centre_offset_px", a.centre_offset_px, {.ge = 0.0, .le = 2.0}));
  COLLIDE_ASSIGN_OR_RETURN(
      a.blur_offset_onset_px,
      r.number("blur_offset_onset_px", a.blur_offset_onset_px, {.ge = 0.0, .le = 100.0}));
  COLLIDE_ASSIGN_OR_RETURN(
      a.blur_offset_per_px2,
      r.number("blur_offset_per_px2", a.blur_offset_per_px2, {.ge = 0.0, .le = 1.0}));
  COLLIDE_ASSIGN_OR_RETURN(a.air_density_kg_m3, r.number("air_density_kg_m3", a.air_density_kg_m3,
                                                         {.ge = 0.0, .le = 2.0}));
  return r.finish("[analysis]");
}

}  // namespace

PinholeCamera CameraCalibrationProfile::lens(const GeometryProfile& g) const {
  PinholeCamera c;
  c.focal_px = focal_px;
  c.principal_u_px = principal_px[0];
  c.principal_v_px = principal_px[1];
  c.k1 = distortion[0], c.k2 = distortion[1], c.p1 = distortion[2], c.p2 = distortion[3];
  const double d = plane_distance_m.value_or(g.pixel_size_m * focal_px);
  c.centre_m = Vec3(0, 0, d);
  // Shift the optical centre so that the world origin appears at origin_px.
  const Vec3 origin = c.onPlane(g.origin_u_px, g.origin_v_px);
  c.centre_m = Vec3(-origin.x(), -origin.y(), d);
  return c;
}

SettingsReader DeviceProfile::backendSettings() const {
  SettingsReader r(table);
  for (const auto& k : role_keys) r.markRead(k);
  return r;
}

Result<RigProfile> parseRigProfile(std::string_view text, const std::string& source_name) {
  COLLIDE_ASSIGN_OR_RETURN(const Document doc, toDocument(text, source_name));
  RigProfile p;
  p.source = source_name;
  p.text = std::string(text);
  {
    SettingsReader r(doc.top);
    COLLIDE_ASSIGN_OR_RETURN(p.name, r.text("name"));
    COLLIDE_RETURN_IF_ERROR(r.finish("a rig profile (top level)"));
  }
  // Safety first: later sections are checked against its limits.
  COLLIDE_ASSIGN_OR_RETURN(const SettingsTable* safety, section(doc, "safety"));
  COLLIDE_RETURN_IF_ERROR(parseSafety(*safety, p));

  double regulator_min = 0.0, regulator_max = 0.0;
  COLLIDE_ASSIGN_OR_RETURN(const SettingsTable* regulator, section(doc, "regulator"));
  COLLIDE_RETURN_IF_ERROR(parseRegulator(*regulator, p, regulator_min, regulator_max));
  COLLIDE_ASSIGN_OR_RETURN(const SettingsTable* valves, section(doc, "valves"));
  COLLIDE_RETURN_IF_ERROR(parseValves(*valves, p));
  COLLIDE_ASSIGN_OR_RETURN(const SettingsTable* camera, section(doc, "camera"));
  COLLIDE_RETURN_IF_ERROR(parseCamera(*camera, p));
  COLLIDE_ASSIGN_OR_RETURN(const SettingsTable* burst, section(doc, "burst"));
  COLLIDE_RETURN_IF_ERROR(parseBurst(*burst, p));
  COLLIDE_ASSIGN_OR_RETURN(const SettingsTable* geometry, section(doc, "geometry"));
  COLLIDE_RETURN_IF_ERROR(parseGeometry(*geometry, p));
  COLLIDE_RETURN_IF_ERROR(parseLaunchers(doc, p));
  COLLIDE_ASSIGN_OR_RETURN(const SettingsTable* spheres, section(doc, "spheres"));
  COLLIDE_RETURN_IF_ERROR(parseSpheres(*spheres, p));
  COLLIDE_ASSIGN_OR_RETURN(const SettingsTable* calibration, section(doc, "calibration"));
  COLLIDE_RETURN_IF_ERROR(parseCalibration(*calibration, p));
  if (p.calibration.max_kPa > p.safety.max_pressure_kPa) {
    SettingsReader r(*calibration);
    return r.invalid("max_kpa",
                     "exceeds safety.max_pressure_kpa = " + num(p.safety.max_pressure_kPa));
  }
  if (p.calibration.max_kPa > regulator_max || p.calibration.min_kPa < regulator_min) {
    SettingsReader r(*calibration);
    return r.invalid(p.calibration.max_kPa > regulator_max ? "max_kpa" : "min_kpa",
                     "the launch range must lie inside the regulator's " + num(regulator_min) +
                         ".." + num(regulator_max) + " kPa");
  }
  COLLIDE_ASSIGN_OR_RETURN(const SettingsTable* sequencer, section(doc, "sequencer"));
  COLLIDE_RETURN_IF_ERROR(parseSequencer(*sequencer, p));
  // [simulation] is optional: a real rig has no use for it.
  const auto sim = doc.sections.find("simulation");
  const SettingsTable empty_sim{"simulation", source_name, 0, {}};
  COLLIDE_RETURN_IF_ERROR(parseSimulation(sim == doc.sections.end() ? empty_sim : sim->second, p));
  // [analysis] is optional: the alignment the user states for their rig.
  if (const auto an = doc.sections.find("analysis"); an != doc.sections.end())
    COLLIDE_RETURN_IF_ERROR(parseAnalysis(an->second, p));
  if (const auto wall = doc.sections.find("wall"); wall != doc.sections.end()) {
    COLLIDE_RETURN_IF_ERROR(parseWall(wall->second, p));
  }
  return p;
}

Result<RigProfile> loadRigProfile(const std::filesystem::path& path) {
  // A profile is a small text file: a folder, a device or a pipe given by
  // mistake is named as such, and nothing is read without limit.
  constexpr std::streamsize kMaxProfileBytes = 1 << 20;
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    return fail(path.string() + " is a folder, not a rig profile: give a .toml file, e.g. " +
                (path / "sim.toml").string());
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec))
    return fail(path.string() +
                " is not a regular file (a device or a pipe?): give a rig "
                "profile .toml file");
  std::ifstream in(path, std::ios::binary);
  if (!in)
    return fail("cannot read rig profile " + path.string() +
                ": check the path (config/sim.toml is the simulated rig)");
  std::string text(static_cast<std::size_t>(kMaxProfileBytes) + 1, '\0');
  in.read(text.data(), kMaxProfileBytes + 1);
  text.resize(static_cast<std::size_t>(in.gcount()));
  if (static_cast<std::streamsize>(text.size()) > kMaxProfileBytes)
    return fail("rig profile " + path.string() +
                " is larger than 1 MB: not a rig profile? check the path");
  return parseRigProfile(text, path.string());
}

std::string_view defaultRigProfileText() {
  return generated::kDefaultProfileToml;
}

Result<RigProfile> defaultRigProfile() {
  return parseRigProfile(defaultRigProfileText(), "config/sim.toml (built in)");
}

}  // namespace collide::hw
