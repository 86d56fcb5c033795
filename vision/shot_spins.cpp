#include "vision/shot_spins.hpp"

#include <algorithm>
#include <limits>

#include "vision/spin_fit.hpp"

namespace collide::vision {

ShotSpins measureSpins(const Burst& burst, const std::vector<FrameData>& data,
                       const CollisionFits& fits, const std::array<double, 2>& r_med,
                       int max_value) {
  ShotSpins out;
  out.dots.resize(data.size());
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side) {
      const SideFit& sf = *fits.fit[s][side];
      std::vector<SpinFrame> sfr;
      for (const int k : sf.frames) {
        SphereMeasurement m = *trackAt(data[k], s);
        // Lift with the track's radius: steadier than one frame's.
        m.circle.radius = r_med[s];
        out.dots[k][s] = findDots(burst.frames[data[k].index].image, m, max_value);
        if (out.dots[k][s].dots.empty()) continue;
        SpinFrame f;
        f.t_s = data[k].t;
        for (const Dot& d : out.dots[k][s].dots) {
          f.dots.push_back(d.on_sphere);
          f.weights.push_back(d.weight);
        }
        f.centre_sigma = 1.2 * std::max(m.circle.sigma_u, m.circle.sigma_v) / r_med[s];
        sfr.push_back(std::move(f));
      }
      SideSpin& r = out.side[s][side];
      auto spin = fitSpin(sfr);
      if (spin) {
        r.spin = spin->spin_rad_s;
        r.cov = spin->covariance * (kSpinSigmaScale * kSpinSigmaScale);
        r.sigma = Vec3(kSpinSigmaScale * spin->sigma_rad_s);
      } else {
        // Unknown spin: zero, with a spread wide enough for any spin these
        // launches give, so beta and f carry the ignorance in their sigmas.
        r.spin = Vec3::Zero();
        r.cov = Eigen::Matrix3d::Identity() * (kUnknownSpinSigma * kUnknownSpinSigma);
        r.sigma = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
        r.unknown_reason = spin.error().message;
      }
    }
  return out;
}

}  // namespace collide::vision
