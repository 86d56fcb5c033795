#pragma once
// The centre offset each track carries, measured from a campaign's own shots
// (the rig profile's [analysis] centre_offset_px, docs/imaging.md).
//
// A sphere's measured centres can sit a little off its true centre for a
// whole track (the dots' pull on a shaded limb, the limb itself, motion
// blur): an offset the trajectory fit's scatter does not show, which moves
// where the track is at the collision. Each sphere's pre- and post-impact
// tracks meet where it was struck (its kink, analysis/contact.hpp kinkTime),
// and one impulse strikes both spheres at once, so the two kinks fall at the
// same instant whatever the contact distance, the contact's duration or a
// radius bias. Their gap, against the spread the analysis drew for it (with
// the offsets it assumed), measures what the tracks carry beyond those: a
// shot's gap of variance sigma^2 + k^2 s for a further offset variance s per
// axis and track (k^2 from the spheres' velocity changes). Pure maths.
#include <cstdint>
#include <limits>
#include <vector>

#include "analysis/result.hpp"

namespace collide {

/// One shot's kinks, as its analysis states them.
struct KinkGap {
  double gap_s = std::numeric_limits<double>::quiet_NaN();  ///< sphere 1's kink - sphere 2's, s
  /// Its standard deviation over the analysis' draws (every source, the
  /// offsets it assumed included), s.
  double sigma_s = std::numeric_limits<double>::quiet_NaN();
  /// How much its variance grows per px^2 of a further offset per track and
  /// axis, s^2/px^2 (ShotUncertainty::kink_gap_var_per_offset_var times the
  /// pixel size squared).
  double var_per_px2 = std::numeric_limits<double>::quiet_NaN();
  bool usable() const;  ///< all three finite, sigma and var_per_px2 > 0
};

/// What the gaps imply.
struct TrackOffsetExcess {
  /// The further offset variance per track and axis, px^2, that makes the
  /// gaps' squared pulls' median that of a chi-square of one degree of
  /// freedom (0.455): robust to a few shots whose kinks err for another
  /// reason. Negative: the analysis drew more than the gaps show (down to
  /// what the shots' own spreads allow).
  double excess_px2 = 0;
  double sigma_px2 = 0;  ///< its standard error: the shots resampled (bootstrap)
  /// The gaps' pulls (gap / sigma) RMS as the analysis drew them.
  double pull_rms = 0;
  int shots = 0;  ///< shots used
  /// The offset, px: excess_px2's square root, with its sign.
  double excessPx() const;
  /// The offset per track that would have made the analysis draw what the
  /// gaps show, given the one it drew (`stated_px`, e.g. the profile's
  /// centre_offset_px): sqrt(max(0, stated^2 + excess)).
  double suggestedPx(double stated_px) const;
};

/// Errors: fewer than 5 usable gaps (KinkGap::usable); `resamples` below 0.
Result<TrackOffsetExcess> trackOffsetFromKinkGaps(const std::vector<KinkGap>& gaps,
                                                  int resamples = 200, std::uint64_t seed = 1);

}  // namespace collide
