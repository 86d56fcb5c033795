#pragma once
// One sphere's track cut into free-flight segments, each fitted with constant
// acceleration (a quadratic in time per axis, analysis/trajectory.hpp): what
// `collide track` reports. A segment ends where the track cannot be measured
// (a contact with another sphere, an outline cut by the frame's edge, frames
// missing) or where the next position leaves the segment's own extrapolation
// by more than break_sigmas of its uncertainty (an abrupt change of velocity:
// a bounce off a wall or the floor). Boundaries between two segments of one
// run are then moved by up to two samples to where the two fits' summed
// chi-square is least, so a bounce close to a frame's instant (whose first
// sample barely leaves the old parabola) is split where it happened.
// SI units: seconds, metres; x right, y up.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "analysis/result.hpp"
#include "analysis/trajectory.hpp"

namespace collide {

/// One measured centre of the track.
struct FlightPoint {
  double t_s = 0;
  Eigen::Vector2d position_m = Eigen::Vector2d::Zero();  ///< x right, y up
  double sigma_m = 0;  ///< standard uncertainty per axis (relative weights; > 0)
  /// False: seen but not free-flight evidence (touching another sphere, cut
  /// by the frame's edge): not fitted, and it ends a segment.
  bool usable = true;
  bool contact = false;  ///< in contact with another sphere (ends a segment as "contact")
};

struct FreeFlightOptions {
  int min_samples = 5;        ///< fewer usable samples make no segment (3 parameters + 2 dof)
  double break_sigmas = 5.0;  ///< a residual beyond this many sigmas ends a segment
  /// Position noise never taken below this in the break test, m (the detector's
  /// own sigmas can be optimistic); 0: no floor.
  double noise_floor_m = 0.0;
  /// A time step longer than this many median frame intervals ends a segment.
  double max_gap_frames = 3.5;
  /// A slow wander of the centres about their true places, which the fit
  /// absorbs into its curve (dots crossing the limb as the sphere turns):
  /// its RMS, m, and the time over which it stays correlated, s
  /// (wanderSigma, analysis/residual_structure.hpp). It is added to the
  /// segments' velocity and acceleration sigmas and to what the break test
  /// allows the next centre to miss the extrapolation by; 0: none.
  double centre_wander_m = 0.0;
  double centre_wander_time_s = 0.0;
};

/// One fitted free-flight stretch.
struct FreeFlightSegment {
  int first = 0, last = 0;  ///< indices into the points, both included
  TrajectoryFit fit;        ///< t_ref = the first sample's time
  /// At the first sample's time, with standard uncertainties from the fit's
  /// covariance scaled by its residuals (chi^2/dof) and by their correlation
  /// from frame to frame (residualInflation, analysis/residual_structure.hpp),
  /// and the centres' wander (FreeFlightOptions::centre_wander_m) added.
  Eigen::Vector2d velocity_m_s = Eigen::Vector2d::Zero();
  Eigen::Vector2d velocity_sigma_m_s = Eigen::Vector2d::Zero();
  /// At the last sample's time (for a segment that ends at a contact, the
  /// velocity just before it), with sigmas made as velocity_sigma_m_s's.
  Eigen::Vector2d end_velocity_m_s = Eigen::Vector2d::Zero();
  Eigen::Vector2d end_velocity_sigma_m_s = Eigen::Vector2d::Zero();
  Eigen::Vector2d acceleration_m_s2 = Eigen::Vector2d::Zero();
  Eigen::Vector2d acceleration_sigma_m_s2 = Eigen::Vector2d::Zero();
  /// sqrt of the mean squared residual over both axes and all samples, m.
  double residual_rms_m = 0;
  /// What ends it: "end" (the track's last point), "contact", "unusable"
  /// (points not fitted: cut by the edge or merged), "gap" (points missing),
  /// "velocity_change" (a residual break: a bounce or a push).
  std::string ends_at;
};

/// Segments of one track (points in time order). Points between segments
/// that are too few to fit are left out. Errors: points not in increasing
/// time order, a non-finite value, a usable point's sigma not > 0, options out
/// of range (min_samples < 4, break_sigmas <= 0).
Result<std::vector<FreeFlightSegment>> fitFreeFlightSegments(const std::vector<FlightPoint>& points,
                                                             const FreeFlightOptions& options = {});

}  // namespace collide
