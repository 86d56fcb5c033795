#pragma once
// One, two or three spheres followed through any footage (`collide track`):
// the spheres of every frame (SphereDetector, front-lit or backlit), each
// sphere's identity kept from frame to frame by the nearest constant-velocity
// prediction (a joint assignment, so two spheres passing close by do not swap),
// and the frames where two spheres touch or nearly touch (contacts) marked.
// Frames are read in order through a callback, a few per core at a time (at
// most SphereTrackSettings::batch_bytes of pixels), so a long camera file
// is never held in memory; each batch is detected on every core the process
// may use (vision/frame_parallel.hpp).
//
// Limits: spheres that overlap in the image (one passing in front of the
// other) merge into one blob; those frames are marked touching and identity
// is carried through them by prediction only, so two spheres that overlap
// while changing velocity may swap. Sphere 1 is the leftmost in the first
// frame that shows all of them apart.
//
// Image coordinates: u right, v down, origin at the top-left pixel's centre.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "analysis/result.hpp"
#include "vision/frame.hpp"
#include "vision/sphere_detector.hpp"

namespace collide::vision {

/// The footage to track: `count` frames, read by position 0..count-1.
struct FrameSource {
  std::int64_t count = 0;
  int max_value = 255;  ///< full scale of the pixel format
  std::function<Result<Frame>(std::int64_t index)> read;
};

struct SphereTrackSettings {
  int spheres = 0;                  ///< 1, 2 or 3; 0: the most frequent number of spheres per frame
  SphereDetectorSettings detector;  ///< polarity, radius bounds
  /// Expected radius, px, when the scale is known (0: any round blob is a
  /// sphere); blobs more than 30 % off are not.
  double expected_radius_px = 0;
  /// Two spheres whose outlines are closer than this (px), or than their
  /// relative displacement in one frame, are in contact in that frame.
  double contact_margin_px = 1.0;
  /// Frames read ahead of detection: 8 per core, fewer when they would hold
  /// more pixel bytes than this (one per core at least).
  std::size_t batch_bytes = std::size_t{256} << 20;
};

/// One sphere in one frame.
struct TrackedSphere {
  bool found = false;
  double u_px = 0, v_px = 0, radius_px = 0;
  double sigma_px = 0;         ///< standard uncertainty of the centre, per axis
  double radius_sigma_px = 0;  ///< standard uncertainty of the radius
  bool cut_by_border = false;
  /// Whole, but edge profiles were lost to the border (SphereMeasurement::
  /// border_profiles): the centre may carry the edge model's bias.
  bool near_border = false;
  bool touching = false;  ///< its blob merged with another
  bool contact = false;   ///< within the contact margin of another sphere
};

struct TrackFrame {
  std::int64_t index = 0;              ///< position in the footage
  std::int64_t id = 0;                 ///< the frame's id (trigger-relative for camera files)
  std::vector<TrackedSphere> spheres;  ///< one per tracked sphere
  int blobs = 0;                       ///< round blobs the detector found
};

struct SphereTracks {
  int spheres = 0;
  std::vector<TrackFrame> frames;  ///< the frames read (bad ones left out)
  std::vector<double> radius_px;   ///< median radius per sphere (outlines not cut)
  std::int64_t seed_index = 0;     ///< the frame where identities were set
  bool dark_spheres = false;       ///< measured as silhouettes (backlit) in most frames
  int frames_unreadable = 0;
  std::vector<std::string> notes;
};

/// Reads every frame, detects, tracks. Errors (saying what to do): no frame
/// could be read; no sphere in any frame (with the detector's reason and the
/// polarity used); a sphere count outside 1..3; never `spheres` spheres apart
/// in one frame.
Result<SphereTracks> trackFootageSpheres(const FrameSource& source,
                                         const SphereTrackSettings& settings,
                                         const std::function<void(int, int)>& progress = {});

}  // namespace collide::vision
