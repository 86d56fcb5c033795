#include "app/calibrate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <regex>
#include <sstream>

#include "app/profile_edit.hpp"
#include "hw/camera_sim.hpp"
#include "vision/render.hpp"

namespace collide::app {
namespace fs = std::filesystem;

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string fmt(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

std::string exact(double v) {
  return fmt("%.10g", v);
}

std::string array(const std::vector<double>& v) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + exact(v[i]);
  return s + "]";
}

Result<cv::Mat> readPicture(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return fail(path + ": no such picture file; check the path");
  cv::Mat m = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (m.empty())
    return fail(path + ": not a picture OpenCV can read (PNG, TIFF, JPEG, BMP, PGM ...)");
  if (m.channels() == 3) cv::cvtColor(m, m, cv::COLOR_BGR2GRAY);
  if (m.channels() == 4) cv::cvtColor(m, m, cv::COLOR_BGRA2GRAY);
  if (m.depth() != CV_8U && m.depth() != CV_16U)
    return fail(path + ": 8- or 16-bit grey pictures only");
  return m;
}

}  // namespace

Result<cv::Size> parseBoardSize(const std::string& text) {
  std::smatch m;
  if (!std::regex_match(text, m, std::regex(R"(\s*(\d+)\s*[xX]\s*(\d+)\s*)")))
    return fail("--board " + text +
                ": give the inner corners (where four squares meet) as COLSxROWS, e.g. 9x6");
  const int cols = std::stoi(m[1]), rows = std::stoi(m[2]);
  if (cols < 3 || rows < 3 || cols > 100 || rows > 100)
    return fail("--board " + text + ": between 3 and 100 inner corners each way");
  return cv::Size(cols, rows);
}

Result<CalibrationRun> calibrateFromFiles(const CalibrationInput& in) {
  CalibrationRun run;
  run.board = in.board;
  run.names = in.images;
  if (!in.plane_image.empty()) {
    for (std::size_t i = 0; i < run.names.size(); ++i)
      if (fs::path(run.names[i]).lexically_normal() == fs::path(in.plane_image).lexically_normal())
        run.plane_index = static_cast<int>(i);
    if (run.plane_index < 0) {
      run.plane_index = static_cast<int>(run.names.size());
      run.names.push_back(in.plane_image);
    }
  }
  if (run.names.empty()) return fail("no pictures given: name the chessboard pictures");
  std::vector<cv::Mat> images;
  for (const auto& name : run.names) {
    auto m = readPicture(name);
    if (!m) return m.error();
    images.push_back(std::move(*m));
  }
  auto cal = vision::calibrateCamera(images, run.board, run.plane_index, run.names);
  if (!cal) return cal.error();
  run.calibration = std::move(*cal);
  return run;
}

std::string calibrationTable(const CalibrationRun& run, std::optional<double> pitch_um) {
  const vision::CameraCalibration& c = run.calibration;
  const vision::CalibrationSigma& s = c.sigma;
  const PinholeCamera& l = c.camera;
  std::ostringstream o;
  o << "Camera calibration from " << c.images_used << " of " << run.names.size()
    << " pictures: board " << run.board.inner_corners.width << " x "
    << run.board.inner_corners.height << " inner corners, " << fmt("%.4g", run.board.square_m * 1e3)
    << " mm squares; " << c.image_size.width << " x " << c.image_size.height << " px\n";
  for (const auto& n : c.notes) o << "  " << n << "\n";
  char line[200];
  const auto row = [&](const char* what, const std::string& value, const std::string& sigma,
                       const char* unit) {
    std::snprintf(line, sizeof line, "  %-34s %14s  %2s %-12s %s\n", what, value.c_str(),
                  sigma.empty() ? "" : "+-", sigma.c_str(), unit);
    o << line;
  };
  std::snprintf(line, sizeof line, "\n  %-34s %14s  %-15s %s\n", "quantity", "value",
                "std. uncertainty", "unit");
  o << line;
  row("focal length f", fmt("%.2f", l.focal_px), fmt("%.2f", s.focal_px), "px");
  if (pitch_um) {
    const std::string what = "focal length (" + fmt("%.4g", *pitch_um) + " um pixels)";
    row(what.c_str(), fmt("%.3f", l.focal_px * *pitch_um * 1e-3),
        fmt("%.3f", s.focal_px * *pitch_um * 1e-3), "mm");
  }
  row("principal point u", fmt("%.2f", l.principal_u_px), fmt("%.2f", s.principal_u_px), "px");
  row("principal point v", fmt("%.2f", l.principal_v_px), fmt("%.2f", s.principal_v_px), "px");
  row("radial distortion k1", fmt("%.5f", l.k1), fmt("%.5f", s.k1), "1");
  row(c.k2_fitted ? "radial distortion k2" : "radial distortion k2 (held)", fmt("%.5f", l.k2),
      fmt("%.5f", s.k2), "1");
  row("tangential distortion p1", fmt("%.6f", l.p1), fmt("%.6f", s.p1), "1");
  row("tangential distortion p2", fmt("%.6f", l.p2), fmt("%.6f", s.p2), "1");
  if (c.has_plane) {
    row("collision plane distance", fmt("%.5f", l.centre_m.z()), fmt("%.5f", s.plane_distance_m),
        "m");
    row("pixel scale at the collision plane", fmt("%.5e", c.plane_pixel_size_m),
        fmt("%.2e", s.plane_pixel_size_m), "m/px");
    row("plane picture's board tilt", fmt("%.2f", c.plane_tilt_deg), "", "deg");
  } else {
    o << "  (no --plane picture: the collision plane's distance and pixel scale are not "
         "measured)\n";
  }
  row("reprojection error (RMS)", fmt("%.3f", c.rms_px), "", "px");
  o << "\n  per picture: reprojection error (RMS), px\n";
  for (std::size_t i = 0; i < run.names.size(); ++i) {
    const double e = i < c.view_rms_px.size() ? c.view_rms_px[i] : std::nan("");
    o << "    " << (std::isnan(e) ? std::string("   left out") : fmt("%11.3f", e)) << "  "
      << run.names[i] << (static_cast<int>(i) == run.plane_index ? "  (collision plane)" : "")
      << "\n";
  }
  return o.str();
}

nlohmann::json calibrationJson(const CalibrationRun& run, std::optional<double> pitch_um) {
  const vision::CameraCalibration& c = run.calibration;
  const vision::CalibrationSigma& s = c.sigma;
  const PinholeCamera& l = c.camera;
  nlohmann::json j;
  j["image_px"] = {c.image_size.width, c.image_size.height};
  j["board"] = {{"inner_corners", {run.board.inner_corners.width, run.board.inner_corners.height}},
                {"square_m", run.board.square_m}};
  j["focal_px"] = l.focal_px;
  j["focal_px_sigma"] = s.focal_px;
  if (pitch_um) {
    j["pixel_pitch_um"] = *pitch_um;
    j["focal_length_mm"] = l.focal_px * *pitch_um * 1e-3;
    j["focal_length_mm_sigma"] = s.focal_px * *pitch_um * 1e-3;
  }
  j["principal_px"] = {l.principal_u_px, l.principal_v_px};
  j["principal_px_sigma"] = {s.principal_u_px, s.principal_v_px};
  j["distortion"] = {l.k1, l.k2, l.p1, l.p2};
  j["distortion_sigma"] = {s.k1, s.k2, s.p1, s.p2};
  j["distortion_model"] = "opencv k1 k2 p1 p2 (k3 = 0)";
  if (c.has_plane) {
    j["plane_distance_m"] = l.centre_m.z();
    j["plane_distance_m_sigma"] = s.plane_distance_m;
    j["plane_pixel_size_m"] = c.plane_pixel_size_m;
    j["plane_pixel_size_m_sigma"] = s.plane_pixel_size_m;
    j["plane_tilt_deg"] = c.plane_tilt_deg;
  }
  j["rms_px"] = c.rms_px;
  j["views_used"] = c.images_used;
  nlohmann::json pictures = nlohmann::json::array();
  for (std::size_t i = 0; i < run.names.size(); ++i) {
    const double e = c.view_rms_px[i];
    pictures.push_back({{"file", run.names[i]},
                        {"used", !std::isnan(e)},
                        {"plane", static_cast<int>(i) == run.plane_index},
                        {"rms_px", std::isnan(e) ? nlohmann::json(nullptr) : nlohmann::json(e)}});
  }
  j["pictures"] = pictures;
  j["notes"] = c.notes;
  return j;
}

Result<std::string> profileWithCalibration(const std::string& text, const std::string& source,
                                           const CalibrationRun& run) {
  const vision::CameraCalibration& c = run.calibration;
  const vision::CalibrationSigma& s = c.sigma;
  const PinholeCamera& l = c.camera;
  std::vector<std::pair<std::string, std::string>> e = {
      // std::string("["): GCC 12 warns falsely (-Wrestrict) on a literal put
      // before a temporary string.
      {"image_px", std::string("[") + std::to_string(c.image_size.width) + ", " +
                       std::to_string(c.image_size.height) + "]"},
      {"focal_px", exact(l.focal_px)},
      {"focal_px_sigma", exact(s.focal_px)},
      {"principal_px", array({l.principal_u_px, l.principal_v_px})},
      {"principal_px_sigma", array({s.principal_u_px, s.principal_v_px})},
      {"distortion", array({l.k1, l.k2, l.p1, l.p2})},
      {"distortion_sigma", array({s.k1, s.k2, s.p1, s.p2})}};
  if (c.has_plane) {
    e.push_back({"plane_distance_m", exact(l.centre_m.z())});
    e.push_back({"plane_distance_m_sigma", exact(s.plane_distance_m)});
    e.push_back({"plane_pixel_size_m", exact(c.plane_pixel_size_m)});
    e.push_back({"plane_pixel_size_m_sigma", exact(s.plane_pixel_size_m)});
  }
  e.push_back({"rms_px", exact(c.rms_px)});
  e.push_back({"views", std::to_string(c.images_used)});
  auto edited = setProfileTable(text, "camera.calibration", e);
  if (!edited) return edited.error();
  auto parsed = hw::parseRigProfile(*edited, source + " (with [camera.calibration])");
  if (!parsed) return fail("the calibration does not fit this profile: " + parsed.error().message);
  return *edited;
}

std::optional<double> profilePixelPitchUm(const hw::RigProfile& profile) {
  if (profile.camera.backend != "sim") return std::nullopt;
  hw::SettingsReader r = profile.camera.backendSettings();
  auto settings = hw::CameraSimSettings::read(r);
  if (!settings || !settings->imaging || !settings->imaging->perspective) return std::nullopt;
  return settings->imaging->pixel_pitch_um;
}

namespace {

// One board pose: tilts about the world x and y axes (deg), the board centre
// shifted in the plane by a fraction of the field, and towards the camera (m).
struct TargetPose {
  double about_x_deg, about_y_deg, shift_u, shift_v, towards_camera_m;
};

const std::vector<TargetPose> kPoses = {{40, 0, 0, 0, 0},
                                        {-40, 0, 0, 0, 0},
                                        {0, 40, 0, 0, 0},
                                        {0, -40, 0, 0, 0},
                                        {28, 28, 0, 0, 0.02},
                                        {-28, 28, 0, 0, -0.02},
                                        {28, -28, 0, 0, -0.02},
                                        {-28, -28, 0, 0, 0.02},
                                        {-20, 20, 0.08, 0.08, -0.03},
                                        {-20, -20, -0.08, 0.08, -0.03},
                                        {20, 20, 0.08, -0.08, -0.03},
                                        {20, -20, -0.08, -0.08, -0.03},
                                        {10, 35, 0.05, 0, 0.01},
                                        {35, -10, 0, 0.05, 0.01},
                                        {-35, 10, 0, -0.05, -0.01},
                                        {-10, -35, -0.05, 0, 0.01}};

vision::ChessboardTarget placeBoard(const vision::ChessboardSpec& b, const Vec3& centre,
                                    double about_x_deg, double about_y_deg) {
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(about_y_deg * kPi / 180, Vec3::UnitY()) *
                             Eigen::AngleAxisd(about_x_deg * kPi / 180, Vec3::UnitX()))
                                .toRotationMatrix();
  vision::ChessboardTarget t;
  t.inner_cols = b.inner_corners.width;
  t.inner_rows = b.inner_corners.height;
  t.square_m = b.square_m;
  t.x_axis = R * Vec3::UnitX();
  t.y_axis = R * -Vec3::UnitY();
  t.origin_m = centre - 0.5 * (t.inner_cols - 1) * b.square_m * t.x_axis -
               0.5 * (t.inner_rows - 1) * b.square_m * t.y_axis;
  return t;
}

// Whether the whole board, margin included, appears inside the picture (two
// pixels in from the border).
bool inView(const vision::ChessboardTarget& t, const PinholeCamera& lens, int width, int height) {
  const double a0 = -1.6, a1 = t.inner_cols + 0.6, c0 = -1.6, c1 = t.inner_rows + 0.6;
  for (int k = 0; k <= 8; ++k) {  // along each edge of the margin
    const double f = k / 8.0;
    for (const auto& [a, c] :
         {std::pair{a0 + f * (a1 - a0), c0}, std::pair{a0 + f * (a1 - a0), c1},
          std::pair{a0, c0 + f * (c1 - c0)}, std::pair{a1, c0 + f * (c1 - c0)}}) {
      const Eigen::Vector2d uv =
          lens.project(t.origin_m + (a * t.x_axis + c * t.y_axis) * t.square_m);
      if (!(uv.x() >= 2 && uv.x() <= width - 3 && uv.y() >= 2 && uv.y() <= height - 3))
        return false;
    }
  }
  return true;
}

Status writePicture(const std::string& path, const cv::Mat& image) {
  try {
    if (cv::imwrite(path, image)) return Ok{};
  } catch (const cv::Exception& e) {
    return fail(path + ": cannot write the picture: " + e.what());
  }
  return fail(path + ": cannot write the picture; check the folder's permissions and free space");
}

}  // namespace

Result<TargetViews> renderCalibrationTargets(const hw::RigProfile& profile, const std::string& dir,
                                             vision::ChessboardSpec board, int views) {
  auto rs = hw::simulatedRenderSettings(profile);
  if (!rs) return rs.error();
  if (!rs->imaging || !rs->imaging->optics.perspective)
    return fail(profile.source +
                ": the simulated camera has no perspective lens ([camera.imaging] projection = "
                "\"perspective\"): there is nothing to calibrate");
  if (views < vision::kMinCalibrationViews || views > static_cast<int>(kPoses.size()))
    return fail("--views " + std::to_string(views) + ": between " +
                std::to_string(vision::kMinCalibrationViews) + " and " +
                std::to_string(kPoses.size()));
  // A sensor integrates the light over each pixel's area: 8 x 8 rays a pixel
  // approximate that for the board's straight edges (2 x 2, enough for
  // spheres, biases the corners coherently: f by 0.7 % on 8 mm boards in
  // sim-lab, 2 sigma; docs/benchmarks.md).
  rs->imaging->samples_per_pixel = std::max(rs->imaging->samples_per_pixel, 8);
  const PinholeCamera lens = rs->imaging->optics.pinhole();
  const int w = rs->width, h = rs->height;
  // The field at the collision plane, m.
  const Vec3 c0 = lens.onPlane(0, 0), c1 = lens.onPlane(w - 1, h - 1);
  const double field_w = std::abs(c1.x() - c0.x()), field_h = std::abs(c1.y() - c0.y());
  const Vec3 middle = lens.onPlane(0.5 * (w - 1), 0.5 * (h - 1));
  if (!(board.square_m > 0)) {
    const double s = 0.72 * std::min(field_w / (board.inner_corners.width + 2.2),
                                     field_h / (board.inner_corners.height + 2.2));
    board.square_m = std::max(1e-4, std::floor(s * 2e4) / 2e4);  // whole 0.05 mm
  }
  TargetViews out;
  out.board = board;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return fail(dir + ": cannot create the folder: " + ec.message());
  vision::Renderer renderer(*rs);
  const vision::ChessboardTarget plane = placeBoard(board, Vec3(middle.x(), middle.y(), 0), 0, 0);
  if (!inView(plane, lens, w, h))
    return fail("a " + std::to_string(board.inner_corners.width) + " x " +
                std::to_string(board.inner_corners.height) + " board of " +
                fmt("%.4g", board.square_m * 1e3) +
                " mm squares does not fit the field at the collision plane (" +
                fmt("%.4g", field_w * 1e3) + " x " + fmt("%.4g", field_h * 1e3) +
                " mm): give a smaller --square-mm");
  out.plane = (fs::path(dir) / "plane.png").string();
  if (Status s = writePicture(out.plane, renderer.renderChessboard(plane, 0)); !s) return s.error();
  for (int i = 0; i < views; ++i) {
    const TargetPose& p = kPoses[i];
    // Tilt and shift less until the whole board is in view.
    vision::ChessboardTarget t;
    for (double k = 1.0;; k *= 0.85) {
      const Vec3 centre(middle.x() + k * p.shift_u * field_w, middle.y() - k * p.shift_v * field_h,
                        p.towards_camera_m);
      t = placeBoard(board, centre, k * p.about_x_deg, k * p.about_y_deg);
      if (inView(t, lens, w, h) || k < 0.2) break;
    }
    char name[32];
    std::snprintf(name, sizeof name, "view-%02d.png", i + 1);
    out.views.push_back((fs::path(dir) / name).string());
    if (Status s = writePicture(out.views.back(), renderer.renderChessboard(t, i + 1)); !s)
      return s.error();
  }
  return out;
}

}  // namespace collide::app
