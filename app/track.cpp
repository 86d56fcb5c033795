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

/// A video, decoded whole (OpenCV reads it in sequence).
Result<OpenedFootage> openVideo(const TrackOptions& o) {
  auto burst = vision::loadVideo(o.footage, o.fps);
  if (!burst) return burst.error();
  OpenedFootage out;
  out.fps = o.fps > 0 ? o.fps : burst->fps;
  out.width = burst->width();
  out.height = burst->height();
  out.note = burst->note;
  out.source.count = static_cast<std::int64_t>(burst->frames.size());
  out.source.max_value = vision::maxValue(burst->format);
  auto shared = std::make_shared<vision::Burst>(std::move(*burst));
  out.source.read = [shared](std::int64_t i) -> Result<vision::Frame> {
    return shared->frames[static_cast<std::size_t>(i)];
  };
  return out;
}

/// The scale from a rig profile: its camera's lens, else its pixel size; the
/// spheres' diameter from the profile unless given.
Status scaleFromRig(const TrackOptions& o, TrackResult& r) {
  auto profile = hw::loadRigProfile(o.rig);
  if (!profile) return profile.error();
  if (!(r.diameter_m > 0)) r.diameter_m = profile->spheres.diameter_m[0];
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
  r.diameter_m = o.diameter_mm * 1e-3;
  if (!o.rig.empty()) return scaleFromRig(o, r);
  std::vector<double> radii;
  for (const double rad : r.tracks.radius_px)
    if (std::isfinite(rad)) radii.push_back(rad);
  const double mean_r =
      radii.empty() ? 0 : std::accumulate(radii.begin(), radii.end(), 0.0) / radii.size();
  if (in.file_pixel_size_m > 0) {
    r.pixel_size_m = in.file_pixel_size_m;
    r.pixel_size_from = "file";
    if (r.diameter_m > 0 && mean_r > 0) {
      const double d_img = 2 * mean_r * r.pixel_size_m;
      if (std::abs(d_img / r.diameter_m - 1) > 0.05)
        r.notes.push_back("the spheres measure " + fmt("%.2f", d_img * 1e3) +
                          " mm across at the file's pixel size, but --diameter-mm is " +
                          fmt("%.2f", r.diameter_m * 1e3) +
                          ": the file's pixel size is used; check the file's calibration");
    }
    return Ok{};
  }
  if (!(r.diameter_m > 0))
    return fail(o.footage +
                ": no pixel size in the file: give the spheres' diameter (--diameter-mm) to "
                "scale pixels to metres");
  if (!(mean_r > 0))
    return fail(o.footage +
                ": no whole sphere outline to scale from (every outline is cut by "
                "the frame's edge or merged)");
  r.pixel_size_m = r.diameter_m / (2 * mean_r);
  r.pixel_size_from = "diameter";
  // The radii's scatter over frames (their median's error) and the
  // detector's systematic radius error, as in vision::AnalysisSettings.
  std::vector<double> all;
  for (const auto& f : r.tracks.frames)
    for (const auto& sp : f.spheres)
      if (sp.found && !sp.cut_by_border && !sp.touching) all.push_back(sp.radius_px);
  double var = 0;
  for (const double x : all) var += (x - mean_r) * (x - mean_r);
  const double sd_mean = all.size() > 1 ? std::sqrt(var / (all.size() - 1) / all.size()) : 0.0;
  constexpr double kRadiusSystematicPx = 0.1;
  r.pixel_size_sigma_m = r.pixel_size_m * std::hypot(sd_mean, kRadiusSystematicPx) / mean_r;
  if (radii.size() > 1) {
    const auto [lo, hi] = std::minmax_element(radii.begin(), radii.end());
    if (*hi / *lo > 1.05)
      r.notes.push_back("the spheres' radii differ (" + fmt("%.1f", *lo) + " to " +
                        fmt("%.1f", *hi) + " px); the scale takes their mean as --diameter-mm");
  }
  return Ok{};
}

/// Each sphere's centres as flight points (x right, y up, metres) and the
/// footage position of each point.
void fitSegments(TrackResult& r) {
  const double s = r.pixel_size_m;
  const std::int64_t index0 = r.tracks.frames.empty() ? 0 : r.tracks.frames.front().index;
  FreeFlightOptions fo;
  fo.noise_floor_m = 0.01 * s;
  for (int t = 0; t < r.tracks.spheres; ++t) {
    std::vector<FlightPoint> pts;
    std::vector<std::int64_t> frame_of;
    for (const auto& f : r.tracks.frames) {
      const vision::TrackedSphere& sp = f.spheres[t];
      if (!sp.found) continue;
      FlightPoint p;
      p.t_s = (f.index - index0) / r.fps;
      p.position_m = toWorld(r, sp.u_px, sp.v_px);
      p.sigma_m = std::max(sp.sigma_px, 1e-3) * s;
      p.usable = !sp.cut_by_border && !sp.touching && !sp.contact;
      p.contact = sp.contact;
      pts.push_back(p);
      frame_of.push_back(f.index);
    }
    SphereSegments out;
    auto segs = fitFreeFlightSegments(pts, fo);
    if (!segs) {
      r.notes.push_back("sphere " + std::to_string(t + 1) + ": " + segs.error().message);
    } else {
      for (const auto& seg : *segs) {
        out.first_frame.push_back(frame_of[seg.first]);
        out.last_frame.push_back(frame_of[seg.last]);
        int n = 0;
        for (Eigen::Index i = 0; i < seg.fit.axisFit(0).weights.size(); ++i)
          n += seg.fit.axisFit(0).weights[i] > 0;
        out.frames_fitted.push_back(n);
      }
      out.segments = std::move(*segs);
    }
    r.spheres.push_back(std::move(out));
  }
}

}  // namespace

Eigen::Vector2d toWorld(const TrackResult& r, double u_px, double v_px) {
  if (r.camera) return r.camera->sphereCentre(u_px, v_px, 0.5 * r.diameter_m).head<2>();
  return {u_px * r.pixel_size_m, -v_px * r.pixel_size_m};
}

Eigen::Vector2d toImage(const TrackResult& r, const Eigen::Vector2d& xy_m) {
  if (r.camera) return r.camera->project(Vec3(xy_m.x(), xy_m.y(), 0));
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
  if (in.file_pixel_size_m > 0 && o.diameter_mm > 0)
    ts.expected_radius_px = 0.5 * o.diameter_mm * 1e-3 / in.file_pixel_size_m;
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
      fr["position_m"] = pair(toWorld(r, s.u_px, s.v_px));
      if (s.cut_by_border) fr["cut_by_border"] = true;
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
      sj["acceleration_m_s2"] = pair(g.acceleration_m_s2);
      sj["acceleration_sigma_m_s2"] = pair(g.acceleration_sigma_m_s2);
      sj["residual_px_rms"] = number(g.residual_rms_m / r.pixel_size_m);
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
      std::snprintf(
          buf, sizeof buf, "%d,%lld,%lld,%.9g,%.4f,%.4f,%.4f,%.4f,%.9g,%.9g,%d,%d,%d,%d\n", t + 1,
          static_cast<long long>(f.index), static_cast<long long>(f.id), (f.index - index0) / r.fps,
          s.u_px, s.v_px, s.radius_px, s.sigma_px, toWorld(r, s.u_px, s.v_px).x(),
          toWorld(r, s.u_px, s.v_px).y(), s.cut_by_border, s.touching, s.contact, segment);
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
        const Estimate3 p = ss.segments[k].fit.positionAt_m((i - index0) / r.fps);
        const Eigen::Vector2d uv = toImage(r, p.value.head<2>());
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
