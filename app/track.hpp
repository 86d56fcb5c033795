#pragma once
// `collide track FOOTAGE`: one to three spheres followed through any footage
// (a folder of images, a video, a Photron/Phantom/pco file), each sphere's
// free-flight segments between contacts fitted with constant acceleration,
// written as JSON, CSV and a picture (docs/results-format.md, "Tracks").
//
// Axes: image u right, v down (pixels, origin at the top-left pixel's
// centre); physical x right, y up (metres): x = u s, y = -v s for pixel size s.
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "analysis/camera_model.hpp"
#include "analysis/depth_from_size.hpp"
#include "analysis/free_flight_segments.hpp"
#include "analysis/result.hpp"
#include "vision/footage.hpp"
#include "vision/sphere_tracks.hpp"

namespace collide::app {

struct TrackOptions {
  std::string footage;  ///< folder of images, video file, or camera file
  double fps = 0;       ///< > 0 replaces the file's frame rate (required for a folder)
  /// The spheres' diameter, mm: one for all, or one per sphere (matched to
  /// the tracks by size); empty: unknown (the rig profile's, with rig).
  std::vector<double> diameters_mm;
  /// A rig profile: its camera's lens (the simulated camera's perspective
  /// lens) or, without one, its geometry.pixel_size_m, and its spheres' diameter.
  std::string rig;
  vision::FootageRange range;  ///< camera files only
  int spheres = 0;             ///< 1..3; 0 automatic
  vision::SphereDetectorSettings::Polarity polarity =
      vision::SphereDetectorSettings::Polarity::Auto;
};

/// One sphere's free-flight segments, with frame positions for their ends.
struct SphereSegments {
  std::vector<FreeFlightSegment> segments;
  std::vector<std::int64_t> first_frame, last_frame;  ///< footage positions, per segment
  std::vector<int> frames_fitted;                     ///< per segment
  /// Per segment, through a lens (TrackResult::camera): the sphere's depth
  /// from its apparent size, a straight line dz(t) = dz0 + v_z (t - t0) from
  /// the segment's first frame (m, towards the camera); none without a lens
  /// or with fewer than 3 whole outlines. The segment's x, y are fitted with
  /// each centre placed at this depth, so a drift towards or away from the
  /// camera does not show as an acceleration.
  std::vector<std::optional<DepthMotion>> depth;
  /// The depth (m) at footage position `index`, time `t_s`: that of the
  /// segment holding the frame, 0 in none or without a depth.
  double depthAt(std::int64_t index, double t_s) const;
};

struct TrackResult {
  std::string footage;
  double fps = 0;
  double pixel_size_m = 0;
  /// Standard uncertainty of the scale, m: from the diameter, the spread of
  /// the measured radii and the detector's systematic radius error (0.1 px);
  /// 0 for the file's own calibration (taken as exact). Every velocity and
  /// acceleration shares its relative error (not in their own sigmas).
  double pixel_size_sigma_m = 0;
  std::string pixel_size_from;  ///< "camera", "profile", "file" or "diameter"
  /// The lens centres go through (pixel_size_from "camera"): each silhouette's
  /// centre back to its sphere's centre on the plane z = 0, distortion removed.
  /// None: x = u s, y = -v s.
  std::optional<PinholeCamera> camera;
  double diameter_m = 0;  ///< 0 if not given; sphere 1's when they differ
  /// Per tracked sphere, m, when the diameters given differ (--diameter-mm
  /// with one per sphere, or a rig profile's two): with a pixel size known
  /// (the profile's, the file's), each the one whose image is nearest the
  /// sphere's measured radius; else the largest to the largest image. Empty:
  /// diameter_m for all.
  std::vector<double> sphere_diameter_m;
  double diameterOf(int sphere) const {
    return sphere < static_cast<int>(sphere_diameter_m.size()) ? sphere_diameter_m[sphere]
                                                               : diameter_m;
  }
  /// How much the detector's radius bias may change along a track, px: the
  /// rig profile's [analysis] radius_systematic_px (0.1 without one). It
  /// bounds what the apparent size tells of the depth (SphereSegments::depth).
  double radius_systematic_px = 0.1;
  int width = 0, height = 0;
  vision::SphereTracks tracks;
  std::vector<SphereSegments> spheres;  ///< one per tracked sphere
  std::vector<std::string> notes;
};

/// The footage opened for reading frame by frame, with its frame rate.
struct OpenedFootage {
  vision::FrameSource source;
  double fps = 0;
  double file_pixel_size_m = 0;  ///< the camera file's own calibration, 0 if none
  int width = 0, height = 0;
  std::string note;
};

/// Errors: missing path, unreadable file, no frame rate (give --fps), a bad range.
Result<OpenedFootage> openFootage(const TrackOptions& options);

/// Tracks, scales and fits. Errors: those of trackFootageSpheres (named with
/// the file), no scale (neither the file's pixel size nor --diameter-mm).
Result<TrackResult> trackFootage(const TrackOptions& options, const OpenedFootage& footage,
                                 const std::function<void(int, int)>& progress = {});

/// Image (u, v) px of sphere `sphere`'s centre -> physical (x, y) m, and
/// back; through a lens the centre lies `depth_m` in front of the plane z = 0.
Eigen::Vector2d toWorld(const TrackResult& r, int sphere, double u_px, double v_px,
                        double depth_m = 0);
Eigen::Vector2d toImage(const TrackResult& r, const Eigen::Vector2d& xy_m, double depth_m = 0);

std::string trackToJson(const TrackResult& r);  ///< schema collide.track/1
std::string trackToCsv(const TrackResult& r);   ///< one row per sphere per frame
/// The tracks, the fitted segments and each sphere's number over the seed
/// frame, as an 8-bit colour PNG. Errors: the frame cannot be read or the file written.
Status writeTrackPng(const TrackResult& r, const OpenedFootage& footage, const std::string& path);

}  // namespace collide::app
