#pragma once
// Image stages of analyzeBurst (vision/shot_analysis.hpp) before any fit:
// the burst's good frames and clock, spheres detected in every frame, which
// blobs are this shot's spheres, and the two tracks (docs/SPEC.md step 1).
#include <array>
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "analysis/result.hpp"
#include "vision/frame.hpp"
#include "vision/sphere_detector.hpp"

namespace collide::vision {

/// One analysed (good) frame.
struct FrameData {
  std::size_t index = 0;  ///< in burst.frames
  double t = 0;           ///< s, from the first analysed frame
  FrameSpheres found;
  std::vector<int> candidates;          ///< indices into found.spheres of sphere-like blobs
  std::array<int, 2> assigned{-1, -1};  ///< found.spheres index per track
};

/// The sphere of `track` (0: sphere 1, 1: sphere 2) in frame f, or null.
inline const SphereMeasurement* trackAt(const FrameData& f, int track) {
  return f.assigned[track] >= 0 ? &f.found.spheres[f.assigned[track]] : nullptr;
}

double median(std::vector<double> v);  ///< NaN when empty

/// The good frames of a burst on one clock.
struct BurstFrames {
  std::vector<std::size_t> good;  ///< indices of the good frames in burst.frames
  std::vector<FrameData> data;    ///< one per good frame, times set
  double frame_dt = 0;            ///< s between consecutive frame ids
  int max_value = 0;              ///< full scale of the pixel format
};

/// Checks the frames (one size and pixel type, 8/16-bit mono, matching the
/// burst's format) and sets their times: the timestamps when they increase,
/// else the ids over the frame rate (fps > 0 overrides the burst's).
Result<BurstFrames> prepareFrames(const Burst& burst, double fps);

/// Detect stage: the spheres in every frame. Radius bounds from the pixel size
/// when known (0: none); polarity as SphereDetectorSettings. Returns the
/// number of saturated frames.
int detectSpheres(
    const Burst& burst, std::vector<FrameData>& data, const std::array<double, 2>& diameter_m,
    double pixel_size_m, int max_value, const std::function<void(int, int)>& progress,
    SphereDetectorSettings::Polarity polarity = SphereDetectorSettings::Polarity::Auto,
    const std::optional<PinholeCamera>& camera = std::nullopt);

/// Which blobs are spheres: the expected radius of each (one, or two for two
/// sizes), checked against a given pixel size; every blob within 15 % of it
/// becomes a candidate; slivers of another size cut by the border are noted
/// in their frame; other blobs are judged by trackSpheres.
struct SphereBlobs {
  std::array<double, 2> r_expect_px{0, 0};
  int third_blobs = 0;  ///< sphere-like blobs that are not this shot's
};
Result<SphereBlobs> selectSphereBlobs(std::vector<FrameData>& data,
                                      const std::array<double, 2>& diameter_m, double pixel_size_m);

/// Track stage: seeds at the first frame with two separate spheres (the left
/// one is sphere 1), whole outlines preferred to ones cut by the border, and
/// assigns candidates to the two tracks walking both ways (nearest to the
/// constant-velocity prediction, gate half a radius; the velocity from whole
/// outlines while the track has recent ones). Counts the blobs left off both
/// tracks into blobs.third_blobs, but for slivers cut by the border and blobs
/// centred on a tracked sphere (a second reading of it), which are noted.
Status trackSpheres(std::vector<FrameData>& data, SphereBlobs& blobs,
                    const std::array<double, 2>& diameter_m);

/// Outlines cut by the frame's border, measured again with the radius held
/// (SphereDetector::measureWithRadius) at what the same track's whole outlines
/// give there: a line against time through the radii of its 40 whole frames
/// nearest in time (under perspective the size follows the depth; through a
/// lens each radius less its off-axis stretch, PinholeCamera::outlineShape),
/// whose standard error enters the centre's sigmas. On the arc
/// left in view a free radius and the centre trade off along the cut; a cut
/// sphere's post-impact track otherwise bends with its radius' noise (lab
/// imaging, accuracy_bench: a collision instant 146 us late, e off by 0.04).
/// Settings as detectSpheres; a track without a whole outline, or a frame
/// whose arc gives too few edge points, keeps its free fit. Returns how many
/// outlines were measured again.
int remeasureCutOutlines(const Burst& burst, std::vector<FrameData>& data,
                         const std::array<double, 2>& diameter_m, double pixel_size_m,
                         int max_value, SphereDetectorSettings::Polarity polarity,
                         const std::optional<PinholeCamera>& camera);

/// Median radius of each track, px (frames cut by the border left out when
/// any remain).
std::array<double, 2> trackRadii(const std::vector<FrameData>& data);

std::string fmt(const char* spec, double v);  ///< snprintf of one number

}  // namespace collide::vision
