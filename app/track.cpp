#include "app/track.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <numeric>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "app/footage_shot.hpp"
#include "hw/camera_sim.hpp"
#include "hw/rig_profile.hpp"
#include "vision/frame_io.hpp"
#include "vision/shot_fits.hpp"

namespace collide::app {

namespace {

namespace fs = std::filesystem;
using nlohmann::ordered_json;

std::string fmt(const char* spec, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, spec, v);
  return buf;
}

ordered_json number(double v) {
  return std::isfinite(v) ? ordered_json(v) : ordered_json(nullptr);
}

ordered_json pair(const Eigen::Vector2d& v) {
  return ordered_json::array({number(v.x()), number(v.y())});
}

Result<OpenedFootage> openCameraFile(const TrackOptions& o) {
  auto footage = vision::Footage::open(o.footage);
  if (!footage) return footage.error();
  const vision::FootageInfo& info = footage->info();
  OpenedFootage out;
  out.fps = o.fps > 0 ? o.fps : info.fps;
  if (!(out.fps > 0))
    return fail(o.footage + ": the file records no frame rate: give it with --fps");
  out.file_pixel_size_m = info.pixel_size_m;
  out.note = info.note;  // e.g. a save step the frame rate does not include
  out.width = info.width;
  out.height = info.height;
  const std::int64_t first_id = info.first_frame, last_id = info.first_frame + info.frame_count - 1;
  const std::int64_t a = o.range.first_id.value_or(first_id);
  const std::int64_t b = o.range.last_id.value_or(last_id);
  if (a < first_id || b > last_id || a > b)
    return fail(o.footage + ": --range " + std::to_string(a) + ":" + std::to_string(b) +
                " is not within the file's frames " + std::to_string(first_id) + " to " +
                std::to_string(last_id));
  const std::int64_t offset = a - first_id;
  out.source.count = b - a + 1;
  out.source.max_value = vision::maxValue(info.pixel_format);
  if (info.pixel_format == vision::PixelFormat::Mono16 && info.effective_bits > 0 &&
      info.effective_bits < 16)
    out.source.max_value = (1 << info.effective_bits) - 1;
  auto shared = std::make_shared<vision::Footage>(std::move(*footage));
  out.source.read = [shared, offset](std::int64_t i) { return shared->frame(offset + i); };
  return out;
}

/// A folder of frame files, decoded one at a time as they are tracked.
Result<OpenedFootage> openFolder(const TrackOptions& o) {
  auto folder = vision::listFrameFolder(o.footage);
  if (!folder) return folder.error();
  auto paths = std::make_shared<const std::vector<std::string>>(std::move(folder->paths));
  auto first = vision::readFrameImage(paths->front());
  if (!first) return first.error();
  OpenedFootage out;
  out.fps = o.fps;
  out.width = first->cols;
  out.height = first->rows;
  out.note = folder->note;
  out.source.count = static_cast<std::int64_t>(paths->size());
  // Full scale as loadFrameFolder sets it (16-bit data that never exceeds
  // 4095 is 12-bit), judged here from the first, middle and last frames.
  out.source.max_value = 255;
  if (first->depth() == CV_16U) {
    double highest = 0;
    for (const std::size_t k : {std::size_t{0}, paths->size() / 2, paths->size() - 1}) {
      auto img = k == 0 ? first : vision::readFrameImage((*paths)[k]);
      double lo = 0, hi = 0;
      if (img) cv::minMaxLoc(*img, &lo, &hi);
      highest = std::max(highest, hi);
    }
    out.source.max_value = highest <= 4095 ? 4095 : 65535;
  }
  auto first_image = std::make_shared<const cv::Mat>(std::move(*first));
  const double fps = o.fps;
  out.source.read = [paths, first_image, fps](std::int64_t i) -> Result<vision::Frame> {
    const std::string& path = (*paths)[static_cast<std::size_t>(i)];
    auto img = vision::readFrameImage(path);
    if (!img) return img.error();
    if (Status st = vision::checkSameFrame(*first_image, paths->front(), *img, path); !st)
      return st.error();
    vision::Frame f;
    f.id = i;
    f.timestamp_ns = std::llround(static_cast<double>(i) * 1e9 / fps);
    f.image = std::move(*img);
    return f;
  };
  return out;
}

/// A video, decoded one frame at a time as it is tracked (not held whole).
Result<OpenedFootage> openVideo(const TrackOptions& o) {
  auto video = vision::openVideoStream(o.footage, o.fps);
  if (!video) return video.error();
  OpenedFootage out;
  out.fps = video->fps;
  out.width = video->width;
  out.height = video->height;
  out.source.count = video->count;
  out.source.max_value = vision::maxValue(video->format);
  out.source.read = std::move(video->read);
  return out;
}

/// Gives each track its diameter (m) of `diameters`: all the same when they
/// are; else, with a pixel size (m) known, the one whose image is nearest the
/// track's median radius, or without one the largest to the largest image
/// (then one diameter per track is needed). diameter_m becomes track 1's.
Status assignDiameters(std::vector<double> diameters, double pixel_size_m, TrackResult& r) {
  std::erase_if(diameters, [](double d) { return !(d > 0); });
  if (diameters.empty()) return Ok{};
  const auto [lo, hi] = std::minmax_element(diameters.begin(), diameters.end());
  if (*hi == *lo) {
    r.diameter_m = diameters.front();
    return Ok{};
  }
  const std::vector<double>& radii = r.tracks.radius_px;
  r.sphere_diameter_m.assign(radii.size(), diameters.front());
  if (pixel_size_m > 0) {
    for (std::size_t t = 0; t < radii.size(); ++t)
      for (const double d : diameters)
        if (std::abs(0.5 * d / pixel_size_m - radii[t]) <
            std::abs(0.5 * r.sphere_diameter_m[t] / pixel_size_m - radii[t]))
          r.sphere_diameter_m[t] = d;
  } else {
    if (diameters.size() != radii.size())
      return fail(std::to_string(diameters.size()) + " diameters for " +
                  std::to_string(radii.size()) +
                  " spheres tracked: give one diameter for all, or one per sphere (--spheres to "
                  "say how many)");
    std::vector<std::size_t> order(radii.size());
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
      return !(radii[a] >= radii[b]);  // a NaN radius counts as the smallest
    });
    std::sort(diameters.begin(), diameters.end());
    for (std::size_t k = 0; k < order.size(); ++k) r.sphere_diameter_m[order[k]] = diameters[k];
  }
  r.diameter_m = r.sphere_diameter_m.front();
  return Ok{};
}

/// The scale from a rig profile: its camera's lens, else its pixel size; the
/// spheres' diameters (m) `given`, else the profile's.
Status scaleFromRig(const TrackOptions& o, const std::vector<double>& given, TrackResult& r) {
  auto profile = hw::loadRigProfile(o.rig);
  if (!profile) return profile.error();
  const auto& own = profile->spheres.diameter_m;
  if (Status st = assignDiameters(given.empty() ? std::vector<double>{own[0], own[1]} : given,
                                  profile->geometry.pixel_size_m, r);
      !st)
    return st.error();
  r.radius_systematic_px = profile->analysis.radius_systematic_px;
  r.pixel_size_m = profile->geometry.pixel_size_m;
  r.pixel_size_from = "profile";
  // A camera calibrated with chessboard pictures ([camera.calibration])
  // first, else a simulated camera's lens (as app::analysisSettingsFor).
  if (profile->camera_calibration) {
    r.camera = profile->camera_calibration->lens(profile->geometry);
    r.pixel_size_from = "camera";
    if (!(r.pixel_size_m > 0)) return fail(o.rig + ": the profile gives no geometry.pixel_size_m");
    if (!(r.diameter_m > 0)) return fail(o.rig + ": the profile gives no sphere diameter");
    return Ok{};
  }
  auto lens = hw::simulatedLens(*profile);
  if (!lens) return fail(o.rig + ": " + lens.error().message);
  if (*lens) {
    r.camera = **lens;
    r.pixel_size_from = "camera";
  }
  if (!(r.pixel_size_m > 0)) return fail(o.rig + ": the profile gives no geometry.pixel_size_m");
  if (!(r.diameter_m > 0)) return fail(o.rig + ": the profile gives no sphere diameter");
  return Ok{};
}

/// The scale: the camera file's own calibration, else the diameter over the
/// spheres' measured size.
Status chooseScale(const TrackOptions& o, const OpenedFootage& in, TrackResult& r) {
  std::vector<double> given;
  for (const double mm : o.diameters_mm) given.push_back(mm * 1e-3);
  if (!o.rig.empty()) return scaleFromRig(o, given, r);
  if (auto st = assignDiameters(given, in.file_pixel_size_m, r); !st)
    return fail(o.footage + ": --diameter-mm: " + st.error().message);
  // Each track's median radius against its own diameter.
  std::vector<int> whole;  // tracks with a measured radius
  for (int t = 0; t < static_cast<int>(r.tracks.radius_px.size()); ++t)
    if (std::isfinite(r.tracks.radius_px[t]) && r.tracks.radius_px[t] > 0) whole.push_back(t);
  if (in.file_pixel_size_m > 0) {
    r.pixel_size_m = in.file_pixel_size_m;
    r.pixel_size_from = "file";
    for (const int t : whole) {
      const double d_img = 2 * r.tracks.radius_px[t] * r.pixel_size_m, d = r.diameterOf(t);
      if (d > 0 && std::abs(d_img / d - 1) > 0.05)
        r.notes.push_back(
            "sphere " + std::to_string(t + 1) + " measures " + fmt("%.2f", d_img * 1e3) +
            " mm across at the file's pixel size, but --diameter-mm is " + fmt("%.2f", d * 1e3) +
            ": the file's pixel size is used; check the file's calibration");
    }
    return Ok{};
  }
  if (!(r.diameter_m > 0))
    return fail(o.footage +
                ": no pixel size in the file: give the spheres' diameter (--diameter-mm) to "
                "scale pixels to metres");
  if (whole.empty())
    return fail(o.footage +
                ": no whole sphere outline to scale from (every outline is cut by "
                "the frame's edge or merged)");
  // The mean of the tracks' scales; its uncertainty from the radii's scatter
  // over frames (each radius relative to its track's median) and the
  // detector's systematic radius error, as in vision::AnalysisSettings.
  double scale_sum = 0, mean_r = 0;
  for (const int t : whole) {
    scale_sum += r.diameterOf(t) / (2 * r.tracks.radius_px[t]);
    mean_r += r.tracks.radius_px[t] / whole.size();
  }
  r.pixel_size_m = scale_sum / whole.size();
  r.pixel_size_from = "diameter";
  std::vector<double> rel;
  for (const auto& f : r.tracks.frames)
    for (const int t : whole) {
      const auto& sp = f.spheres[t];
      if (sp.found && !sp.cut_by_border && !sp.touching)
        rel.push_back(sp.radius_px / r.tracks.radius_px[t]);
    }
  double m = 0, var = 0;
  for (const double x : rel) m += x / rel.size();
  for (const double x : rel) var += (x - m) * (x - m);
  const double sd_mean_rel = rel.size() > 1 ? std::sqrt(var / (rel.size() - 1) / rel.size()) : 0.0;
  constexpr double kRadiusSystematicPx = 0.1;
  r.pixel_size_sigma_m = r.pixel_size_m * std::hypot(sd_mean_rel, kRadiusSystematicPx / mean_r);
  if (r.sphere_diameter_m.empty() && whole.size() > 1) {
    double lo = INFINITY, hi = 0;
    for (const int t : whole)
      lo = std::min(lo, r.tracks.radius_px[t]), hi = std::max(hi, r.tracks.radius_px[t]);
    if (hi / lo > 1.05)
      r.notes.push_back("the spheres' radii differ (" + fmt("%.1f", lo) + " to " + fmt("%.1f", hi) +
                        " px) but one diameter was given: the scale takes it for all; give one "
                        "per sphere if they differ (--diameter-mm 25.4,19.05)");
  }
  return Ok{};
}

double frameTime(const TrackResult& r, std::int64_t index) {
  const std::int64_t index0 = r.tracks.frames.empty() ? 0 : r.tracks.frames.front().index;
  return (index - index0) / r.fps;
}

/// Sphere t's centres as flight points (x right, y up, metres), each at the
/// depth `depth` gives it, and the footage position of each point.
std::vector<FlightPoint> flightPoints(const TrackResult& r, int t, const SphereSegments& depth,
                                      std::vector<std::int64_t>& frame_of) {
  std::vector<FlightPoint> pts;
  frame_of.clear();
  for (const auto& f : r.tracks.frames) {
    const vision::TrackedSphere& sp = f.spheres[t];
    if (!sp.found) continue;
    FlightPoint p;
    p.t_s = frameTime(r, f.index);
    p.position_m = toWorld(r, t, sp.u_px, sp.v_px, depth.depthAt(f.index, p.t_s));
    p.sigma_m = std::max(sp.sigma_px, 1e-3) * r.pixel_size_m;
    p.usable = !sp.cut_by_border && !sp.near_border && !sp.touching && !sp.contact;
    p.contact = sp.contact;
    pts.push_back(p);
    frame_of.push_back(f.index);
  }
  return pts;
}

/// Sphere t's depth over frames first..last (footage positions) from its
/// whole outlines' radii against what the lens gives it on the plane z = 0;
/// none with fewer than 3 (the reason in `why`).
std::optional<DepthMotion> segmentDepth(const TrackResult& r, int t, std::int64_t first,
                                        std::int64_t last, std::string& why) {
  const double radius_m = 0.5 * r.diameterOf(t);
  std::vector<double> ts, rad, sr, r0;
  for (const auto& f : r.tracks.frames) {
    const vision::TrackedSphere& sp = f.spheres[t];
    if (f.index < first || f.index > last || !sp.found || sp.cut_by_border || sp.near_border ||
        sp.touching || sp.contact)
      continue;
    const double plane = planeRadiusPx(*r.camera, sp.u_px, sp.v_px, radius_m);
    if (!std::isfinite(plane)) continue;
    ts.push_back(frameTime(r, f.index));
    rad.push_back(sp.radius_px);
    sr.push_back(std::max(sp.radius_sigma_px, 1e-3));
    r0.push_back(plane);
  }
  const auto vec = [](const std::vector<double>& v) {
    return Eigen::Map<const Eigen::VectorXd>(v.data(), Eigen::Index(v.size())).eval();
  };
  auto dm = fitDepthMotion(vec(ts), vec(rad), vec(sr), vec(r0), r.camera->centre_m.z(),
                           frameTime(r, first));
  if (!dm) {
    why = dm.error().message;
    return std::nullopt;
  }
  return *dm;
}

/// How long the centres' wander stays correlated, in frames: about the time
/// a dot takes to cross the limb. On dotted silhouettes of
/// config/sim-backlit.toml the velocity pulls' RMS was 0.82 / 0.87 / 0.95 /
/// 1.03 for 3 / 4 / 5 / 6 frames on seeds 1-20, and 0.81 for 5 on seeds
/// 21-40 (docs/benchmarks.md, "Tracking").
constexpr double kWanderFrames = 5.0;

/// Fits sphere t's segments with its centres at `depth`'s depths. The
/// centres' slow wander as the dots cross the limb (vision::dotBiasPx; its
/// sharp-sphere value, 0.5 px of blur, where the footage gives no exposure)
/// is in the segments' sigmas: the free quadratic takes it into its curve,
/// so the residuals do not show it.
Result<SphereSegments> segmentsAtDepth(const TrackResult& r, int t, const SphereSegments& depth) {
  FreeFlightOptions fo;
  fo.noise_floor_m = 0.01 * r.pixel_size_m;
  const double radius_px = r.tracks.radius_px[t];
  if (radius_px > 0 && std::isfinite(radius_px))
    fo.centre_wander_m = vision::dotBiasPx(radius_px, 0.5, r.tracks.dark_spheres) * r.pixel_size_m;
  fo.centre_wander_time_s = kWanderFrames / r.fps;
  std::vector<std::int64_t> frame_of;
  const std::vector<FlightPoint> pts = flightPoints(r, t, depth, frame_of);
  auto segs = fitFreeFlightSegments(pts, fo);
  if (!segs) return segs.error();
  SphereSegments out;
  for (const auto& seg : *segs) {
    out.first_frame.push_back(frame_of[seg.first]);
    out.last_frame.push_back(frame_of[seg.last]);
    int n = 0;
    for (Eigen::Index i = 0; i < seg.fit.axisFit(0).weights.size(); ++i)
      n += seg.fit.axisFit(0).weights[i] > 0;
    out.frames_fitted.push_back(n);
  }
  out.segments = std::move(*segs);
  out.depth.assign(out.segments.size(), std::nullopt);
  return out;
}

/// A segment's depth sigmas made whole (completeDepthSigmas), and what an
/// error of its depth line does to the centres placed on it, added to the
/// segment's own sigmas: a centre x from the optical axis moving at v, put
/// dz + v_z t off its depth, moves by x (dz + v_z t) / Z0, so the velocity at
/// the first frame by (v dz + x v_z) / Z0, at the last (time T on) by
/// (v (dz + v_z T) + x(T) v_z) / Z0 (dz's and v_z's errors taken as
/// independent), and the acceleration by 2 v v_z / Z0.
void addDepthUncertainty(const TrackResult& r, int t, SphereSegments& s, std::size_t k) {
  if (!s.depth[k]) return;
  DepthMotion& d = *s.depth[k];
  FreeFlightSegment& g = s.segments[k];
  const double z0 = r.camera->centre_m.z();
  completeDepthSigmas(d, z0, r.tracks.radius_px[t], g.fit.tLast_s() - g.fit.tFirst_s(),
                      r.radius_systematic_px);
  const Estimate3 x = g.fit.positionAt_m(g.fit.tRef_s());
  const Estimate3 x_end = g.fit.positionAt_m(g.fit.tLast_s());
  const double span = g.fit.tLast_s() - g.fit.tRef_s();
  const double dz_end_sigma = std::hypot(d.dz0_sigma_m, span * d.vz_sigma_m_s);
  for (int a = 0; a < 2; ++a) {
    const double off = x.value[a] - r.camera->centre_m[a], v = g.velocity_m_s[a];
    g.velocity_sigma_m_s[a] = std::hypot(g.velocity_sigma_m_s[a],
                                         std::hypot(v * d.dz0_sigma_m, off * d.vz_sigma_m_s) / z0);
    const double off_end = x_end.value[a] - r.camera->centre_m[a], v_end = g.end_velocity_m_s[a];
    g.end_velocity_sigma_m_s[a] =
        std::hypot(g.end_velocity_sigma_m_s[a],
                   std::hypot(v_end * dz_end_sigma, off_end * d.vz_sigma_m_s) / z0);
    g.acceleration_sigma_m_s2[a] =
        std::hypot(g.acceleration_sigma_m_s2[a], 2 * v * d.vz_sigma_m_s / z0);
  }
}

/// Each sphere's free-flight segments. Through a lens, twice: the segments
/// at the plane z = 0 give each one's frames, whose radii give its depth
/// line; the centres are then placed at those depths and fitted again (a
/// sphere drifting towards the camera at 3 % of its speed would otherwise
/// show an acceleration of about 2 v v_z / Z0: 0.03 m/s^2 at 0.5 m/s from
/// 0.5 m, 0.11 m/s^2 at 1 m/s).
void fitSegments(TrackResult& r) {
  for (int t = 0; t < r.tracks.spheres; ++t) {
    const std::string name = "sphere " + std::to_string(t + 1) + ": ";
    auto fitted = segmentsAtDepth(r, t, SphereSegments{});
    if (!fitted) {
      r.notes.push_back(name + fitted.error().message);
      r.spheres.emplace_back();
      continue;
    }
    std::string why;
    const auto measureDepths = [&](SphereSegments& s) {
      for (std::size_t k = 0; k < s.segments.size(); ++k)
        s.depth[k] = segmentDepth(r, t, s.first_frame[k], s.last_frame[k], why);
    };
    if (r.camera) {
      measureDepths(*fitted);
      if (auto again = segmentsAtDepth(r, t, *fitted)) {
        fitted = std::move(again);
        measureDepths(*fitted);
      }
      for (std::size_t k = 0; k < fitted->segments.size(); ++k)
        addDepthUncertainty(r, t, *fitted, k);
      if (!why.empty()) r.notes.push_back(name + "no depth from the apparent size: " + why);
    }
    r.spheres.push_back(std::move(*fitted));
  }
}

}  // namespace

double SphereSegments::depthAt(std::int64_t index, double t_s) const {
  for (std::size_t k = 0; k < segments.size(); ++k)
    if (index >= first_frame[k] && index <= last_frame[k] && k < depth.size() && depth[k])
      return depth[k]->dz0_m + depth[k]->vz_m_s * (t_s - segments[k].fit.tRef_s());
  return 0.0;
}

Eigen::Vector2d toWorld(const TrackResult& r, int sphere, double u_px, double v_px,
                        double depth_m) {
  if (r.camera)
    return r.camera->sphereCentre(u_px, v_px, 0.5 * r.diameterOf(sphere), depth_m).head<2>();
  return {u_px * r.pixel_size_m, -v_px * r.pixel_size_m};
}

Eigen::Vector2d toImage(const TrackResult& r, const Eigen::Vector2d& xy_m, double depth_m) {
  if (r.camera) return r.camera->project(Vec3(xy_m.x(), xy_m.y(), depth_m));
  return {xy_m.x() / r.pixel_size_m, -xy_m.y() / r.pixel_size_m};
}

Result<OpenedFootage> openFootage(const TrackOptions& o) {
  const bool has_range = o.range.first_id.has_value() || o.range.last_id.has_value();
  auto kind = footageKind(o.footage, has_range, o.fps > 0);
  if (!kind) return kind.error();
  switch (*kind) {
    case FootageKind::CameraFile: return openCameraFile(o);
    case FootageKind::Folder: return openFolder(o);
    case FootageKind::Video: return openVideo(o);
  }
  return fail(o.footage + ": unknown kind of footage");
}

Result<TrackResult> trackFootage(const TrackOptions& o, const OpenedFootage& in,
                                 const std::function<void(int, int)>& progress) {
  TrackResult r;
  r.footage = o.footage;
  r.fps = in.fps;
  r.width = in.width;
  r.height = in.height;
  vision::SphereTrackSettings ts;
  ts.spheres = o.spheres;
  ts.detector.polarity = o.polarity;
  if (in.file_pixel_size_m > 0 && o.diameters_mm.size() == 1 && o.diameters_mm[0] > 0)
    ts.expected_radius_px = 0.5 * o.diameters_mm[0] * 1e-3 / in.file_pixel_size_m;
  auto tracks = vision::trackFootageSpheres(in.source, ts, progress);
  if (!tracks) return fail(o.footage + ": " + tracks.error().message);
  r.tracks = std::move(*tracks);
  if (auto st = chooseScale(o, in, r); !st) return st.error();
  fitSegments(r);
  r.notes.insert(r.notes.begin(), r.tracks.notes.begin(), r.tracks.notes.end());
  if (!in.note.empty()) r.notes.push_back(in.note);
  return r;
}

std::string trackToJson(const TrackResult& r) {
  ordered_json j;
  j["schema"] = "collide.track/1";
  j["footage"] = r.footage;
  j["fps"] = r.fps;
  j["pixel_size_m"] = r.pixel_size_m;
  j["pixel_size_sigma_m"] = r.pixel_size_sigma_m;
  j["pixel_size_from"] = r.pixel_size_from;
  j["diameter_m"] = r.diameter_m > 0 ? ordered_json(r.diameter_m) : ordered_json(nullptr);
  j["image_size_px"] = {r.width, r.height};
  j["backlit"] = r.tracks.dark_spheres;
  j["seed_frame"] = r.tracks.seed_index;
  const std::int64_t index0 = r.tracks.frames.empty() ? 0 : r.tracks.frames.front().index;
  ordered_json spheres = ordered_json::array();
  for (int t = 0; t < r.tracks.spheres; ++t) {
    ordered_json sp;
    sp["radius_px"] = number(r.tracks.radius_px[t]);
    sp["diameter_m"] = r.diameterOf(t) > 0 ? ordered_json(r.diameterOf(t)) : ordered_json(nullptr);
    ordered_json frames = ordered_json::array();
    for (const auto& f : r.tracks.frames) {
      const vision::TrackedSphere& s = f.spheres[t];
      if (!s.found) continue;
      ordered_json fr;
      fr["index"] = f.index;
      fr["id"] = f.id;
      fr["t_s"] = (f.index - index0) / r.fps;
      fr["centre_px"] = {s.u_px, s.v_px};
      fr["radius_px"] = s.radius_px;
      fr["sigma_px"] = s.sigma_px;
      fr["position_m"] =
          pair(toWorld(r, t, s.u_px, s.v_px, r.spheres[t].depthAt(f.index, frameTime(r, f.index))));
      if (s.cut_by_border) fr["cut_by_border"] = true;
      if (s.near_border) fr["near_border"] = true;
      if (s.touching) fr["touching"] = true;
      if (s.contact) fr["contact"] = true;
      frames.push_back(std::move(fr));
    }
    sp["frames"] = std::move(frames);
    ordered_json segs = ordered_json::array();
    const SphereSegments& ss = r.spheres[t];
    for (std::size_t k = 0; k < ss.segments.size(); ++k) {
      const FreeFlightSegment& g = ss.segments[k];
      ordered_json sj;
      sj["first_frame"] = ss.first_frame[k];
      sj["last_frame"] = ss.last_frame[k];
      sj["frames_fitted"] = ss.frames_fitted[k];
      sj["velocity_m_s"] = pair(g.velocity_m_s);
      sj["velocity_sigma_m_s"] = pair(g.velocity_sigma_m_s);
      sj["end_velocity_m_s"] = pair(g.end_velocity_m_s);
      sj["end_velocity_sigma_m_s"] = pair(g.end_velocity_sigma_m_s);
      sj["acceleration_m_s2"] = pair(g.acceleration_m_s2);
      sj["acceleration_sigma_m_s2"] = pair(g.acceleration_sigma_m_s2);
      sj["residual_px_rms"] = number(g.residual_rms_m / r.pixel_size_m);
      const std::optional<DepthMotion>& dz = ss.depth[k];
      sj["depth_m"] = dz ? number(dz->dz0_m) : ordered_json(nullptr);
      sj["depth_sigma_m"] = dz ? number(dz->dz0_sigma_m) : ordered_json(nullptr);
      sj["velocity_z_m_s"] = dz ? number(dz->vz_m_s) : ordered_json(nullptr);
      sj["velocity_z_sigma_m_s"] = dz ? number(dz->vz_sigma_m_s) : ordered_json(nullptr);
      sj["ends_at"] = g.ends_at;
      segs.push_back(std::move(sj));
    }
    sp["segments"] = std::move(segs);
    spheres.push_back(std::move(sp));
  }
  j["spheres"] = std::move(spheres);
  j["notes"] = r.notes;
  return j.dump(2);
}

std::string trackToCsv(const TrackResult& r) {
  std::ostringstream out;
  out << "sphere,index,id,t_s,u_px,v_px,radius_px,sigma_px,x_m,y_m,cut_by_border,touching,"
         "contact,segment\n";
  const std::int64_t index0 = r.tracks.frames.empty() ? 0 : r.tracks.frames.front().index;
  char buf[512];
  for (int t = 0; t < r.tracks.spheres; ++t) {
    const SphereSegments& ss = r.spheres[t];
    for (const auto& f : r.tracks.frames) {
      const vision::TrackedSphere& s = f.spheres[t];
      if (!s.found) continue;
      int segment = 0;  // 1-based; 0: in no segment
      for (std::size_t k = 0; k < ss.segments.size(); ++k)
        if (f.index >= ss.first_frame[k] && f.index <= ss.last_frame[k]) segment = k + 1;
      const double t_s = (f.index - index0) / r.fps;
      const Eigen::Vector2d xy = toWorld(r, t, s.u_px, s.v_px, ss.depthAt(f.index, t_s));
      std::snprintf(
          buf, sizeof buf, "%d,%lld,%lld,%.9g,%.4f,%.4f,%.4f,%.4f,%.9g,%.9g,%d,%d,%d,%d\n", t + 1,
          static_cast<long long>(f.index), static_cast<long long>(f.id), t_s, s.u_px, s.v_px,
          s.radius_px, s.sigma_px, xy.x(), xy.y(), s.cut_by_border, s.touching, s.contact, segment);
      out << buf;
    }
  }
  return out.str();
}

Status writeTrackPng(const TrackResult& r, const OpenedFootage& in, const std::string& path) {
  auto frame = in.source.read(r.tracks.seed_index);
  if (!frame || frame->image.empty())
    return fail(r.footage + ": frame " + std::to_string(r.tracks.seed_index) +
                " could not be read again for the picture");
  cv::Mat grey;
  frame->image.convertTo(grey, CV_8U, 255.0 / std::max(1, in.source.max_value));
  cv::Mat img;
  cv::cvtColor(grey, img, cv::COLOR_GRAY2BGR);
  const cv::Scalar colours[] = {{40, 40, 255}, {255, 160, 40}, {60, 200, 60}};
  const std::int64_t index0 = r.tracks.frames.empty() ? 0 : r.tracks.frames.front().index;
  for (int t = 0; t < r.tracks.spheres; ++t) {
    const cv::Scalar c = colours[t % 3];
    std::vector<cv::Point> centres;
    for (const auto& f : r.tracks.frames)
      if (f.spheres[t].found)
        centres.emplace_back(cvRound(f.spheres[t].u_px), cvRound(f.spheres[t].v_px));
    for (const auto& p : centres) cv::circle(img, p, 1, c, cv::FILLED);
    // The fitted parabolas, from the metres back to pixels.
    const SphereSegments& ss = r.spheres[t];
    for (std::size_t k = 0; k < ss.segments.size(); ++k) {
      std::vector<cv::Point> curve;
      for (std::int64_t i = ss.first_frame[k]; i <= ss.last_frame[k]; ++i) {
        const double t_s = (i - index0) / r.fps;
        const Estimate3 p = ss.segments[k].fit.positionAt_m(t_s);
        const Eigen::Vector2d uv = toImage(r, p.value.head<2>(), ss.depthAt(i, t_s));
        curve.emplace_back(cvRound(uv.x()), cvRound(uv.y()));
      }
      cv::polylines(img, curve, false, c, 1, cv::LINE_AA);
      if (!curve.empty()) cv::circle(img, curve.front(), 4, c, 1, cv::LINE_AA);  // segment start
    }
    for (const auto& f : r.tracks.frames)
      if (f.index == r.tracks.seed_index && f.spheres[t].found) {
        const auto& s = f.spheres[t];
        cv::circle(img, {cvRound(s.u_px), cvRound(s.v_px)}, cvRound(s.radius_px), c, 1,
                   cv::LINE_AA);
        cv::putText(img, std::to_string(t + 1),
                    {cvRound(s.u_px + 0.8 * s.radius_px), cvRound(s.v_px - 0.8 * s.radius_px)},
                    cv::FONT_HERSHEY_SIMPLEX, 0.6, c, 2);
      }
  }
  std::vector<std::uint8_t> png;
  if (!cv::imencode(".png", img, png)) return fail(path + ": the picture could not be encoded");
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
  out.close();
  if (!out)
    return fail(path + ": cannot write the picture (check the folder exists and is writable)");
  return Ok{};
}

}  // namespace collide::app
