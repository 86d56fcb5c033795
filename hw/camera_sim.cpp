#include "hw/camera_sim.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "hw/backend_registry.hpp"
#include "hw/clock.hpp"
#include "hw/format.hpp"
#include "hw/try.hpp"
#include "vision/random.hpp"

namespace collide::hw {

Result<CameraSimSettings> CameraSimSettings::read(SettingsReader& r) {
  CameraSimSettings s;
  COLLIDE_ASSIGN_OR_RETURN(
      const std::vector<double> sensor,
      r.numbers("sensor_px", 2, std::vector<double>{640, 480},
                {.ge = 1, .le = static_cast<double>(vision::kMaxFrameSidePx)}));
  if (std::floor(sensor[0]) != sensor[0] || std::floor(sensor[1]) != sensor[1])
    return r.invalid("sensor_px", "must be whole numbers of pixels");
  s.sensor_width = static_cast<int>(sensor[0]);
  s.sensor_height = static_cast<int>(sensor[1]);
  COLLIDE_ASSIGN_OR_RETURN(s.realtime, r.boolean("realtime", false));
  COLLIDE_ASSIGN_OR_RETURN(s.noise_grey, r.number("noise_grey", 0.0, {.ge = 0.0}));
  COLLIDE_ASSIGN_OR_RETURN(s.drop_every, r.integer("drop_every", 0, {.ge = 0, .le = 1e9}));
  COLLIDE_ASSIGN_OR_RETURN(s.stop_after_frames,
                           r.integer("stop_after_frames", -1, {.ge = -1, .le = 1e9}));
  COLLIDE_ASSIGN_OR_RETURN(s.silent_after_bursts,
                           r.integer("silent_after_bursts", -1, {.ge = -1, .le = 1e9}));
  const auto& keys = r.table().values;
  if (std::any_of(keys.begin(), keys.end(),
                  [](const auto& kv) { return kv.first.rfind("imaging.", 0) == 0; })) {
    COLLIDE_ASSIGN_OR_RETURN(s.imaging, SimImagingSettings::read(r));
  }
  COLLIDE_RETURN_IF_ERROR(r.finish("the sim camera backend"));
  return s;
}

namespace {

// A key that takes one of two words, `first` (the default) or `second`:
// whether it says `second`.
Result<bool> saysSecond(SettingsReader& r, const std::string& key, const std::string& first,
                        const std::string& second) {
  Result<std::string> v = r.text(key, first, {first, second});
  if (!v) return v.error();
  return v->compare(second) == 0;
}

Status readLighting(SettingsReader& r, vision::Lighting& l) {
  COLLIDE_ASSIGN_OR_RETURN(const bool back, saysSecond(r, "imaging.lighting", "front", "back"));
  l.mode = back ? vision::Lighting::Mode::Back : vision::Lighting::Mode::Front;
  COLLIDE_ASSIGN_OR_RETURN(const std::vector<double> lamp,
                           r.numbers("imaging.lamp_direction", 3, std::vector<double>{0, 0, 1}));
  l.lamp_direction = Vec3(lamp[0], lamp[1], lamp[2]);
  if (!(l.lamp_direction.norm() > 1e-9))
    return r.invalid("imaging.lamp_direction", "must point somewhere (towards the lamp)");
  l.lamp_direction.normalize();
  const Bounds unit{.ge = 0.0, .le = 1.0};
  COLLIDE_ASSIGN_OR_RETURN(l.ambient, r.number("imaging.ambient", 0.2, unit));
  COLLIDE_ASSIGN_OR_RETURN(l.sphere_albedo, r.number("imaging.sphere_albedo", 0.85, unit));
  COLLIDE_ASSIGN_OR_RETURN(l.dot_albedo, r.number("imaging.dot_albedo", 0.05, unit));
  COLLIDE_ASSIGN_OR_RETURN(l.specular_strength, r.number("imaging.specular_strength", 0.0, unit));
  COLLIDE_ASSIGN_OR_RETURN(l.specular_exponent,
                           r.number("imaging.specular_exponent", 60.0, {.ge = 1.0, .le = 10000.0}));
  COLLIDE_ASSIGN_OR_RETURN(l.backdrop_level, r.number("imaging.backdrop_level", 0.02, unit));
  COLLIDE_ASSIGN_OR_RETURN(l.spot_level, r.number("imaging.spot_level", 0.0, unit));
  COLLIDE_ASSIGN_OR_RETURN(l.spot_fraction, r.number("imaging.spot_fraction", 0.0, unit));
  return Ok{};
}

Status readLens(SettingsReader& r, SimImagingSettings& s) {
  COLLIDE_ASSIGN_OR_RETURN(s.perspective,
                           saysSecond(r, "imaging.projection", "orthographic", "perspective"));
  const char* const lens_keys[] = {"imaging.focal_length_mm", "imaging.pixel_pitch_um",
                                   "imaging.working_distance_m", "imaging.principal_point_px",
                                   "imaging.distortion"};
  if (!s.perspective) {
    for (const char* k : lens_keys)
      if (r.table().has(k)) return r.invalid(k, "needs imaging.projection = \"perspective\"");
    return Ok{};
  }
  COLLIDE_ASSIGN_OR_RETURN(
      s.focal_length_mm, r.number("imaging.focal_length_mm", std::nullopt, {.gt = 0.0, .le = 1e4}));
  COLLIDE_ASSIGN_OR_RETURN(
      s.pixel_pitch_um, r.number("imaging.pixel_pitch_um", std::nullopt, {.gt = 0.0, .le = 1e3}));
  COLLIDE_ASSIGN_OR_RETURN(s.working_distance_m, r.number("imaging.working_distance_m",
                                                          std::nullopt, {.gt = 0.0, .le = 1e3}));
  if (r.table().has("imaging.principal_point_px")) {
    COLLIDE_ASSIGN_OR_RETURN(const std::vector<double> pp,
                             r.numbers("imaging.principal_point_px", 2));
    s.principal_px = Eigen::Vector2d(pp[0], pp[1]);
  }
  COLLIDE_ASSIGN_OR_RETURN(const std::vector<double> k,
                           r.numbers("imaging.distortion", 4, std::vector<double>{0, 0, 0, 0},
                                     {.ge = -10.0, .le = 10.0}));
  std::copy(k.begin(), k.end(), s.distortion.begin());
  return Ok{};
}

Status readSensor(SettingsReader& r, vision::Sensor& se, int& samples) {
  const Bounds unit{.ge = 0.0, .le = 1.0};
  COLLIDE_ASSIGN_OR_RETURN(se.vignetting_cos4, saysSecond(r, "imaging.vignetting", "none", "cos4"));
  COLLIDE_ASSIGN_OR_RETURN(se.vignetting_falloff,
                           r.number("imaging.vignetting_falloff", 0.0, unit));
  COLLIDE_ASSIGN_OR_RETURN(se.flicker_hz,
                           r.number("imaging.flicker_hz", 0.0, {.ge = 0.0, .le = 1e6}));
  COLLIDE_ASSIGN_OR_RETURN(se.flicker_amplitude, r.number("imaging.flicker_amplitude", 0.0, unit));
  COLLIDE_ASSIGN_OR_RETURN(se.prnu, r.number("imaging.prnu", 0.0, {.ge = 0.0, .le = 0.5}));
  COLLIDE_ASSIGN_OR_RETURN(se.dsnu, r.number("imaging.dsnu", 0.0, {.ge = 0.0, .le = 0.5}));
  COLLIDE_ASSIGN_OR_RETURN(se.hot_pixel_fraction,
                           r.number("imaging.hot_pixel_fraction", 0.0, unit));
  COLLIDE_ASSIGN_OR_RETURN(se.hot_pixel_level, r.number("imaging.hot_pixel_level", 0.5, unit));
  COLLIDE_ASSIGN_OR_RETURN(se.full_well_e,
                           r.number("imaging.full_well_e", 0.0, {.ge = 0.0, .le = 1e8}));
  COLLIDE_ASSIGN_OR_RETURN(se.read_noise_e,
                           r.number("imaging.read_noise_e", 0.0, {.ge = 0.0, .le = 1e6}));
  if (se.read_noise_e > 0 && se.full_well_e == 0)
    return r.invalid("imaging.read_noise_e", "needs imaging.full_well_e (electrons at full scale)");
  COLLIDE_ASSIGN_OR_RETURN(const std::int64_t bits,
                           r.integer("imaging.adc_bits", 0, {.ge = 0, .le = 16}));
  if (bits != 0 && bits != 8 && bits != 10 && bits != 12 && bits != 16)
    return r.invalid("imaging.adc_bits", "must be 8, 10, 12 or 16 (0: the format's)");
  se.adc_bits = static_cast<int>(bits);
  COLLIDE_ASSIGN_OR_RETURN(const std::int64_t spp,
                           r.integer("imaging.samples_per_pixel", 2, {.ge = 1, .le = 8}));
  samples = static_cast<int>(spp);
  return Ok{};
}

}  // namespace

Result<SimImagingSettings> SimImagingSettings::read(SettingsReader& r) {
  SimImagingSettings s;
  COLLIDE_RETURN_IF_ERROR(readLighting(r, s.imaging.lighting));
  COLLIDE_RETURN_IF_ERROR(readLens(r, s));
  COLLIDE_RETURN_IF_ERROR(readSensor(r, s.imaging.sensor, s.imaging.samples_per_pixel));
  if (s.imaging.sensor.vignetting_cos4 && !s.perspective)
    return r.invalid("imaging.vignetting", "cos4 needs imaging.projection = \"perspective\"");
  return s;
}

vision::Optics SimImagingSettings::optics(int width, int height, Eigen::Vector2d origin_px,
                                          double pixel_size_m) const {
  vision::Optics o;
  o.pixel_size_m = pixel_size_m;
  o.origin_u_px = origin_px.x();
  o.origin_v_px = origin_px.y();
  if (!perspective) return o;
  o.perspective = true;
  o.focal_px = focal_length_mm * 1e3 / pixel_pitch_um;
  const Eigen::Vector2d pp =
      principal_px.value_or(Eigen::Vector2d(0.5 * (width - 1), 0.5 * (height - 1)));
  o.principal_u_px = pp.x();
  o.principal_v_px = pp.y();
  // The world origin (on the collision plane) appears at origin_px: the
  // optical centre sits above the point the axis meets the plane.
  const double d = working_distance_m;
  o.centre_m =
      Vec3((pp.x() - origin_px.x()) * d / o.focal_px, (origin_px.y() - pp.y()) * d / o.focal_px, d);
  o.k1 = distortion[0];
  o.k2 = distortion[1];
  o.p1 = distortion[2];
  o.p2 = distortion[3];
  return o;
}

CameraSim::CameraSim(std::shared_ptr<SimWorld> world, CameraSimSettings settings,
                     std::string device)
    : Camera("camera \"" + device + "\""),
      world_(std::move(world)),
      settings_(settings),
      device_(std::move(device)) {
  if (settings_.silent_after_bursts >= 0)
    silence_ = SimSilence::forDevice(label(), settings_.silent_after_bursts);
  // A launch makes the rest of the burst known: wake the thread to render it.
  world_->onLaunch([weak = std::weak_ptr<Signal>(signal_)] {
    if (auto s = weak.lock()) {
      std::lock_guard lock(s->mutex);
      ++s->generation;
      s->cv.notify_all();
    }
  });
}

CameraSim::~CameraSim() {
  if (thread_.joinable()) {
    {
      std::lock_guard lock(signal_->mutex);
      signal_->stop = true;
      signal_->cv.notify_all();
    }
    thread_.join();
  }
}

CameraInfo CameraSim::info() const {
  return {"sim",
          device_,
          settings_.sensor_width,
          settings_.sensor_height,
          {vision::PixelFormat::Mono8, vision::PixelFormat::Mono12, vision::PixelFormat::Mono16},
          settings_.max_fps,
          settings_.max_gain_db};
}

namespace {

// What the simulated camera renders with for `config` (region, format,
// exposure, gain) and the profile's geometry and imaging.
Result<vision::RenderSettings> renderSettings(const CameraSimSettings& settings,
                                              const CameraConfig& config, const RigProfile& profile,
                                              const std::string& device) {
  vision::RenderSettings rs;
  rs.width = config.width;
  rs.height = config.height;
  rs.format = config.format;
  rs.exposure_s = config.exposure_us * 1e-6;
  // Gain scales the signal and the noise alike (analogue gain before the ADC).
  const double gain = std::pow(10.0, config.gain_db / 20.0);
  rs.sphere_level = std::min(1.0, rs.sphere_level * gain);
  rs.rim_level = std::min(1.0, rs.rim_level * gain);
  rs.dot_level = std::min(1.0, rs.dot_level * gain);
  rs.background_level = std::min(1.0, rs.background_level * gain);
  rs.noise_grey = settings.noise_grey * gain;
  rs.noise_seed = profile.simulation.seed;
  if (settings.imaging) {
    const GeometryProfile& g = profile.geometry;
    vision::Imaging im = settings.imaging->imaging;
    im.optics = settings.imaging->optics(config.width, config.height,
                                         {g.origin_u_px, g.origin_v_px}, g.pixel_size_m);
    im.sensor.gain = gain;
    if (im.sensor.adc_bits > vision::bitDepth(config.format))
      return fail("camera \"" + device +
                  "\": imaging.adc_bits = " + std::to_string(im.sensor.adc_bits) +
                  " does not fit " + vision::toString(config.format) + " pixels");
    rs.imaging = im;
  }
  return rs;
}

}  // namespace

Result<vision::RenderSettings> simulatedRenderSettings(const RigProfile& profile) {
  if (profile.camera.backend != "sim")
    return fail(profile.source + ": camera.backend is \"" + profile.camera.backend +
                "\", not \"sim\": only the simulated camera renders pictures");
  SettingsReader r = profile.camera.backendSettings();
  COLLIDE_ASSIGN_OR_RETURN(const CameraSimSettings settings, CameraSimSettings::read(r));
  return renderSettings(settings, profile.camera_config, profile, profile.camera.device);
}

Status CameraSim::onConfigure(const CameraConfig& config) {
  COLLIDE_ASSIGN_OR_RETURN(const vision::RenderSettings rs,
                           renderSettings(settings_, config, world_->profile(), device_));
  renderer_.emplace(rs);
  config_ = config;
  return Ok{};
}

Status CameraSim::onStart() {
  {
    std::lock_guard lock(signal_->mutex);
    signal_->stop = false;
  }
  thread_ = std::thread(&CameraSim::run, this);
  return Ok{};
}

Status CameraSim::onStop() {
  {
    std::lock_guard lock(signal_->mutex);
    signal_->stop = true;
    signal_->cv.notify_all();
  }
  if (thread_.joinable()) thread_.join();
  return Ok{};
}

void CameraSim::wake() {
  std::lock_guard lock(signal_->mutex);
  ++signal_->generation;
  signal_->cv.notify_all();
}

void CameraSim::onArm() {
  world_->beginBurst();
  wake();
}

void CameraSim::onTrigger(std::int64_t) {
  wake();
}

std::vector<vision::SphereView> CameraSim::sceneAt(const SimLaunch& launch,
                                                   std::int64_t t_ns) const {
  const RigProfile& p = world_->profile();
  const double px = p.geometry.pixel_size_m;
  const auto states = launch.at(t_ns);
  std::vector<vision::SphereView> views;
  for (int i = 0; i < 2; ++i) {
    if (!launch.visible(i, t_ns)) continue;
    const SphereState& s = states[i];
    vision::SphereView v;
    // World y is up, image v is down.
    v.centre_px = {p.geometry.origin_u_px + s.position_m.x() / px,
                   p.geometry.origin_v_px - s.position_m.y() / px};
    v.radius_px = 0.5 * p.spheres.diameter_m[i] / px;
    v.orientation = s.orientation;
    v.velocity_px_s = {s.velocity_m_s.x() / px, -s.velocity_m_s.y() / px};
    v.spin_rad_s = s.spin_rad_s;
    v.dots = &launch.dots[i];
    v.centre_m = s.position_m;
    v.radius_m = 0.5 * p.spheres.diameter_m[i];
    v.velocity_m_s = s.velocity_m_s;
    double margin = 2;
    const vision::Imaging* im = renderer_ && renderer_->settings().imaging
                                    ? &*renderer_->settings().imaging
                                    : nullptr;  // none, or not configured yet
    if (im != nullptr && im->optics.perspective) {
      // Through the lens: the centre's image and the scale at its depth; the
      // silhouette (an ellipse off-axis, bent by distortion) gets a margin.
      const double scale = im->optics.focal_px / (im->optics.centre_m.z() - s.position_m.z());
      v.centre_px = im->optics.project(s.position_m);
      v.radius_px = v.radius_m * scale;
      v.velocity_px_s = {s.velocity_m_s.x() * scale, -s.velocity_m_s.y() * scale};
      margin += 0.5 * v.radius_px;
      if (!v.centre_px.allFinite()) continue;
    }
    // Skip spheres wholly outside the picture, blur included.
    const double reach = v.radius_px + v.velocity_px_s.norm() * config_.exposure_us * 1e-6 + margin;
    if (v.centre_px.x() < -reach || v.centre_px.y() < -reach ||
        v.centre_px.x() > config_.width - 1 + reach || v.centre_px.y() > config_.height - 1 + reach)
      continue;
    views.push_back(v);
  }
  return views;
}

std::optional<vision::WallLine> wallInImage(const RigProfile& p) {
  if (!p.wall) return std::nullopt;
  // The plate's face where it crosses the collision plane z = 0 (where the
  // sphere's centre meets it), through the geometry's orthographic mapping
  // (world y up, image v down), or through the simulated lens when the
  // camera images in perspective: the line through the images of two of its
  // points 20 mm either side of wall.point_m.
  const double px = p.geometry.pixel_size_m;
  const Vec3& n = p.wall->normal;
  const Eigen::Vector2d n_img(n.x(), -n.y());
  if (!(n_img.norm() > 1e-9)) return std::nullopt;  // the face is the image plane itself
  if (auto lens = simulatedLens(p); lens && *lens) {
    Vec3 along = Vec3::UnitZ().cross(n);
    if (!(along.norm() > 1e-9)) return std::nullopt;
    along.normalize();
    Vec3 centre = p.wall->point_m;
    centre.z() = 0.0;
    const Eigen::Vector2d a = (*lens)->project(centre - 0.02 * along);
    const Eigen::Vector2d b = (*lens)->project(centre + 0.02 * along);
    vision::WallLine line;
    line.point_px = (*lens)->project(centre);
    Eigen::Vector2d normal(-(b - a).y(), (b - a).x());
    if (normal.dot(n_img) < 0) normal = -normal;
    line.normal = normal.normalized();
    return line;
  }
  vision::WallLine line;
  line.point_px = {p.geometry.origin_u_px + p.wall->point_m.x() / px,
                   p.geometry.origin_v_px - p.wall->point_m.y() / px};
  line.normal = n_img.normalized();
  return line;
}

vision::WallBend wallBendInImage(const RigProfile& p, const vision::WallLine& line) {
  vision::WallBend bend;
  const auto lens = simulatedLens(p);
  if (!p.wall || !lens || !*lens || !(*lens)->distorted()) return bend;
  const PinholeCamera& cam = **lens;
  Vec3 along = Vec3::UnitZ().cross(p.wall->normal);
  if (!(along.norm() > 1e-9)) return bend;
  along.normalize();
  Vec3 centre = p.wall->point_m;
  centre.z() = 0.0;
  const Eigen::Vector2d n = line.normal.normalized(), t(-n.y(), n.x());
  // The face's points every ~0.5 px of image, far enough either way to cross
  // any frame the profile can set, as (position along the line, offset).
  const double depth = cam.centre_m.z();
  const double metres_per_px = depth / cam.focal_px;
  const double reach_px = 1.2 * std::hypot(p.camera_config.width, p.camera_config.height);
  std::vector<std::pair<double, double>> curve;
  for (double k = -reach_px; k <= reach_px; k += 0.5) {
    const Eigen::Vector2d q = cam.project(centre + k * metres_per_px * along);
    if (!q.allFinite()) continue;
    curve.emplace_back((q - line.point_px).dot(t), (q - line.point_px).dot(n));
  }
  std::sort(curve.begin(), curve.end());
  if (curve.size() < 2) return bend;
  bend.first_px = std::ceil(curve.front().first);
  bend.step_px = 1.0;
  std::size_t j = 0;
  for (double s = bend.first_px; s <= curve.back().first; s += 1.0) {
    while (j + 2 < curve.size() && curve[j + 1].first < s) ++j;
    const auto& [s0, d0] = curve[j];
    const auto& [s1, d1] = curve[j + 1];
    const double f = s1 > s0 ? std::clamp((s - s0) / (s1 - s0), 0.0, 1.0) : 0.0;
    bend.offset_px.push_back((1 - f) * d0 + f * d1);
  }
  return bend;
}

vision::Frame CameraSim::renderFrame(std::int64_t exposure_start_ns, std::uint64_t sequence) const {
  return renderFrame(exposure_start_ns, sequence, 0);
}

vision::Frame CameraSim::renderFrame(std::int64_t exposure_start_ns, std::uint64_t noise_index,
                                     std::int64_t time_origin_ns) const {
  vision::Frame f;
  f.timestamp_ns = exposure_start_ns;
  const std::int64_t mid = exposure_start_ns + std::llround(config_.exposure_us * 500.0);
  const std::shared_ptr<const SimLaunch> launch = world_->currentLaunch();
  // The launch owns the dot patterns the views point at: keep it alive while rendering.
  const std::vector<vision::SphereView> views =
      launch ? sceneAt(*launch, mid) : std::vector<vision::SphereView>{};
  f.image = renderer_->render(views, noise_index, static_cast<double>(mid - time_origin_ns) * 1e-9);
  if (const auto wall = wallInImage(world_->profile())) {
    vision::WallLook look;
    look.thickness_px = wall_thickness_px_;
    look.level = world_->profile().wall_level;
    look.noise_grey = renderer_->settings().noise_grey;
    look.noise_seed = world_->profile().simulation.seed * 7919ULL + noise_index;
    vision::drawWall(f.image, vision::maxValue(config_.format), *wall, look,
                     wallBendInImage(world_->profile(), *wall));
  }
  return f;
}

// The camera's frame grid: frame `seq` starts exposing at t_start + seq *
// period. A frame starts at grid_origin + k period; k seeds its noise. The
// lamps' flicker counts time from time_origin (see alignToTrigger).
struct CameraSim::FrameGrid {
  std::int64_t period;
  std::int64_t t_start, grid_origin, time_origin = 0;
  std::uint64_t seq = 0;  // the camera's running frame counter
  std::uint64_t triggers = 0;

  FrameGrid(std::int64_t period_ns, std::int64_t now_ns)
      : period(period_ns), t_start(now_ns), grid_origin(now_ns) {}

  std::int64_t startOf(std::uint64_t k) const {
    return t_start + static_cast<std::int64_t>(k) * period;
  }
  // The first frame whose exposure starts at or after t.
  std::uint64_t firstFrom(std::int64_t t) const {
    return t <= t_start ? 0 : static_cast<std::uint64_t>((t - t_start + period - 1) / period);
  }
  std::uint64_t noiseIndex(std::int64_t start_ns) const {
    return static_cast<std::uint64_t>((start_ns - grid_origin) / period + (std::int64_t{1} << 40));
  }
  // The grid moved to `trigger` minus a phase drawn from the seed (draws per
  // trigger): the frames then fall where the seed says on the shot, whose
  // valves open at fixed delays from the trigger, however the host scheduled
  // the sequencer. Only while no frame of the burst's window has been exposed
  // (the sequencer triggers that far ahead): the next frame starts at the
  // first grid time at or after the one it would have had.
  void alignToTrigger(std::int64_t trigger, int pre_frames, std::uint64_t seed) {
    const std::int64_t next = startOf(seq);
    if (trigger - pre_frames * period < next) return;
    std::uint64_t state = seed ^ 0x3c6ef372fe94f82bULL ^ (++triggers * 0xd1b54a32d192ed03ULL);
    const double phase = vision::detail::uniform01(state);
    grid_origin = trigger - std::llround(phase * static_cast<double>(period));
    // Mains flicker at a phase of its own, also from the seed.
    time_origin = grid_origin - std::llround(vision::detail::uniform01(state) * 1e9);
    const std::int64_t d = next - grid_origin;
    const std::int64_t k = d >= 0 ? (d + period - 1) / period : -(-d / period);
    t_start = grid_origin + k * period - static_cast<std::int64_t>(seq) * period;
  }
};

// The burst being recorded, as the acquisition thread follows it.
struct CameraSim::BurstState {
  std::shared_ptr<BurstRecorder> current;
  std::int64_t post_delivered = 0;
  bool stalled = false;  // fault: the stream stopped for this burst
  // The current burst's trigger once aligned to (a plain value with a
  // sentinel: GCC 12 takes std::optional's compare for a read of an unset
  // value, a false -Wmaybe-uninitialized).
  static constexpr std::int64_t kNotAligned = std::numeric_limits<std::int64_t>::min();
  std::int64_t aligned_to = kNotAligned;
};

void CameraSim::followArming(FrameGrid& grid, BurstState& burst) {
  std::shared_ptr<BurstRecorder> armed = recorder();
  if (armed == burst.current) return;
  burst.current = armed;
  burst.post_delivered = 0;
  burst.aligned_to = BurstState::kNotAligned;
  // fault: a silent camera delivers nothing for this burst.
  burst.stalled = burst.current && silence_ && !silence_->answer(true);
  // Frames exposed while nothing was armed were never kept: resume from the
  // arming (not from now: on a loaded machine this thread may notice it late,
  // and the ring of a real camera fills from the arming on).
  if (burst.current) grid.seq = std::max(grid.seq, grid.firstFrom(burst.current->armedNs()));
}

std::optional<std::int64_t> CameraSim::recordStep(FrameGrid& grid, BurstState& burst) {
  constexpr std::int64_t kIdle = std::numeric_limits<std::int64_t>::max();
  if (!burst.current || burst.stalled) return kIdle;
  BurstRecorder& rec = *burst.current;
  const std::optional<std::int64_t> trigger = rec.triggerNs();
  if (trigger && *trigger != burst.aligned_to) {
    burst.aligned_to = *trigger;
    grid.alignToTrigger(*trigger, rec.layout().pre_trigger_frames,
                        world_->profile().simulation.seed);
  }
  const std::int64_t ts = grid.startOf(grid.seq);
  if (!rec.wants(ts)) {
    if (trigger && ts < *trigger) {
      // Far before the window: those frames would be overwritten anyway.
      const int pre = rec.layout().pre_trigger_frames;
      grid.seq = std::max(grid.seq + 1, grid.firstFrom(*trigger - (pre + 2) * grid.period));
      return std::nullopt;
    }
    return kIdle;  // complete or ended: idle until armed again
  }
  // A frame exists once exposed; without realtime it may be rendered earlier,
  // as soon as the world is certain up to its end.
  const std::int64_t ready = ts + std::llround(config_.exposure_us * 1000.0);
  if (monotonicNowNs() < ready && (settings_.realtime || world_->knownUntilNs() < ready))
    return ready;
  const bool post = trigger && ts >= *trigger;
  if (settings_.drop_every > 0 && (grid.seq + 1) % settings_.drop_every == 0) {
    ++grid.seq;  // lost in transport: a gap in the sequence
    return std::nullopt;
  }
  if (post && settings_.stop_after_frames >= 0 &&
      burst.post_delivered >= settings_.stop_after_frames) {
    burst.stalled = true;
    return std::nullopt;
  }
  vision::Frame frame = renderFrame(ts, grid.noiseIndex(ts), grid.time_origin);
  publishFrame(frame);
  rec.push(grid.seq, std::move(frame));
  if (post) ++burst.post_delivered;
  ++grid.seq;
  return std::nullopt;
}

std::int64_t CameraSim::previewStep(FrameGrid& grid, std::int64_t& next_preview_ns) {
  constexpr std::int64_t kPreviewPeriodNs = 40'000'000;  // idle live-view frames: 25 per second
  const std::int64_t now = monotonicNowNs();
  if (now >= next_preview_ns) {
    grid.seq = std::max(grid.seq, grid.firstFrom(now));
    const std::int64_t ts = grid.startOf(grid.seq);
    publishFrame(renderFrame(ts, grid.noiseIndex(ts), grid.time_origin));
    ++grid.seq;
    next_preview_ns = now + kPreviewPeriodNs;
  }
  return next_preview_ns;
}

void CameraSim::run() {
  FrameGrid grid(config_.framePeriodNs(), monotonicNowNs());
  BurstState burst;
  std::int64_t next_preview_ns = 0;
  constexpr std::int64_t kIdle = std::numeric_limits<std::int64_t>::max();
  for (;;) {
    std::uint64_t generation = 0;
    {
      std::lock_guard lock(signal_->mutex);
      if (signal_->stop) return;
      generation = signal_->generation;
    }
    followArming(grid, burst);
    const std::optional<std::int64_t> wait = recordStep(grid, burst);
    if (!wait) continue;  // a frame handled: look again at once
    std::int64_t sleep_until = *wait;
    // Nothing to record: render what the camera sees now, at a viewer's rate
    // (a real camera streams all the time; the simulator only on demand).
    if (liveView() && sleep_until == kIdle) sleep_until = previewStep(grid, next_preview_ns);
    std::unique_lock lock(signal_->mutex);
    const auto deadline =
        std::chrono::steady_clock::time_point(std::chrono::nanoseconds(sleep_until));
    auto woken = [&] { return signal_->stop || signal_->generation != generation; };
    if (sleep_until == kIdle)
      signal_->cv.wait(lock, woken);
    else
      signal_->cv.wait_until(lock, deadline, woken);
  }
}

Result<std::optional<PinholeCamera>> simulatedLens(const RigProfile& profile) {
  if (profile.camera.backend != "sim") return std::optional<PinholeCamera>();
  SettingsReader r = profile.camera.backendSettings();
  COLLIDE_ASSIGN_OR_RETURN(const CameraSimSettings settings, CameraSimSettings::read(r));
  if (!settings.imaging || !settings.imaging->perspective) return std::optional<PinholeCamera>();
  const GeometryProfile& g = profile.geometry;
  const vision::Optics o =
      settings.imaging->optics(profile.camera_config.width, profile.camera_config.height,
                               {g.origin_u_px, g.origin_v_px}, g.pixel_size_m);
  return std::optional<PinholeCamera>(o.pinhole());
}

namespace {

Result<std::unique_ptr<Camera>> makeSim(BackendContext& ctx) {
  SettingsReader r = ctx.device.backendSettings();
  COLLIDE_ASSIGN_OR_RETURN(const CameraSimSettings settings, CameraSimSettings::read(r));
  if (ctx.clock != monotonicClock())
    return fail("camera \"" + ctx.device.device +
                "\": the simulated camera runs on CLOCK_MONOTONIC; build its rig without "
                "RigHooks::clock");
  COLLIDE_ASSIGN_OR_RETURN(const std::shared_ptr<SimWorld> world, ctx.simWorld());
  if (settings.imaging && settings.imaging->perspective) {
    // The analysis turns pixels into metres with geometry.pixel_size_m: the
    // lens must give that scale at the collision plane.
    const double lens = settings.imaging->planePixelSizeM();
    const double geometry = world->profile().geometry.pixel_size_m;
    if (std::abs(lens / geometry - 1.0) > 0.01)
      return r.invalid("imaging.working_distance_m",
                       "the lens gives " + num(lens) +
                           " m per pixel at the collision plane (pixel_pitch_um x "
                           "working_distance_m / focal_length_mm) but geometry.pixel_size_m = " +
                           num(geometry) + ": make them agree within 1 %");
  }
  return std::unique_ptr<Camera>(std::make_unique<CameraSim>(world, settings, ctx.device.device));
}

const bool registered = BackendRegistry<Camera>::instance().add("sim", &makeSim);

}  // namespace

}  // namespace collide::hw
