#include "vision/shot_spins.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "analysis/spin_prior.hpp"
#include "vision/frame_parallel.hpp"
#include "vision/shot_tracking.hpp"
#include "vision/spin_fit.hpp"

namespace collide::vision {

Vec3 liftThroughLens(const PinholeCamera& camera, const Vec3& centre_m, double radius_m,
                     double u_px, double v_px) {
  const Eigen::Vector2d xy = camera.normalised(u_px, v_px);
  const Vec3 d = Vec3(xy.x(), -xy.y(), -1.0).normalized();  // camera looks along -z
  const Vec3 oc = camera.centre_m - centre_m;
  const double b = oc.dot(d), disc = b * b - (oc.squaredNorm() - radius_m * radius_m);
  const double t = disc > 0 ? -b - std::sqrt(disc) : -b;
  return (camera.centre_m + t * d - centre_m).normalized();
}

void addLensSpinSystematic(Eigen::Matrix3d& cov, const Vec3& spin) {
  const double sys = kLensSpinRelativeSigma * spin.norm();
  cov(0, 0) += sys * sys;
  cov(1, 1) += sys * sys;
}

ShotSpins measureSpins(const Burst& burst, const std::vector<FrameData>& data,
                       const CollisionFits& fits, const std::array<double, 2>& r_med, int max_value,
                       double unknown_spin_sigma, const PixelScale* scale) {
  ShotSpins out;
  out.dots.resize(data.size());
  // A frame's sphere on its track's radius: steadier than one frame's.
  const auto onTrackRadius = [&](int k, int s) {
    SphereMeasurement m = *trackAt(data[k], s);
    m.circle.radius = r_med[s];
    return m;
  };
  // The dots of every sphere in every fitted frame first (frames in parallel).
  std::vector<std::pair<int, int>> wanted;  // (frame, sphere)
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side)
      for (const int k : fits.fit[s][side]->frames) wanted.emplace_back(k, s);
  std::sort(wanted.begin(), wanted.end());  // a frame on both sides is done once
  wanted.erase(std::unique(wanted.begin(), wanted.end()), wanted.end());
  forEachFrame(wanted.size(), [&](std::size_t i) {
    const auto [k, s] = wanted[i];
    out.dots[k][s] = findDots(burst.frames[data[k].index].image, onTrackRadius(k, s), max_value);
  });
  // Then each sphere's spin on each side: four independent fits, in parallel.
  const auto fitSide = [&](int s, int side) {
    const SideFit& sf = *fits.fit[s][side];
    std::vector<SpinFrame> sfr;
    for (const int k : sf.frames) {
      const SphereMeasurement m = onTrackRadius(k, s);
      if (out.dots[k][s].dots.empty()) continue;
      SpinFrame f;
      f.t_s = data[k].t;
      const bool lens = scale && scale->camera && scale->radius_m[s] > 0;
      // Dot centroids lie on a sphere of radius R cos(alpha) (alpha: the dots' angular radius).
      const double r_dots =
          lens ? scale->radius_m[s] * std::cos(out.dots[k][s].angular_radius_rad) : 0.0;
      // The centre at its depth (from the apparent size, when measured): a
      // sphere placed 3 mm too far from a camera 0.53 m away meets the rays
      // through its dots at the wrong points, and its spin comes out about
      // 0.5 % wrong (accuracy_bench, lab imaging: spin pulls of 9).
      const double z = scale && scale->depth_m[s] ? scale->depth_m[s](data[k].t) : 0.0;
      const Vec3 centre =
          lens ? scale->camera->sphereCentre(m.circle.u, m.circle.v, scale->radius_m[s], z)
               : Vec3::Zero();
      for (const Dot& d : out.dots[k][s].dots) {
        f.dots.push_back(lens ? liftThroughLens(*scale->camera, centre, r_dots, d.u_px, d.v_px)
                              : d.on_sphere);
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
      if (scale && scale->camera) addLensSpinSystematic(r.cov, r.spin);
      if (side == 0) {  // before the impact: the launcher's spin where the dots do not pin it
        const SpinWithPrior p = combineWithLaunchPrior(r.spin, r.cov, unknown_spin_sigma);
        r.spin = p.spin_rad_s;
        r.cov = p.cov;
        r.prior_directions = p.prior_directions;
      }
      r.sigma = r.cov.diagonal().cwiseSqrt();
    } else {
      // Unknown spin: zero, with the spread of the spins these launches give,
      // so beta, f and gamma carry the ignorance in their sigmas.
      r.spin = Vec3::Zero();
      r.cov = Eigen::Matrix3d::Identity() * (unknown_spin_sigma * unknown_spin_sigma);
      r.sigma = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
      r.unknown_reason = spin.error().message;
    }
  };
  forEachFrame(4,
               [&](std::size_t i) { fitSide(static_cast<int>(i / 2), static_cast<int>(i % 2)); });
  return out;
}

std::vector<std::string> poorlyMeasuredSpins(const ShotSpins& spins) {
  std::vector<std::string> notes;
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side) {
      const SideSpin& sp = spins.side[s][side];
      if (sp.unknown_reason || !(sp.sigma.maxCoeff() > kPoorlyMeasuredSpinSigma)) continue;
      notes.push_back("sphere " + std::to_string(s + 1) + ", " + (side == 0 ? "before" : "after") +
                      " the impact: the spin's sigma is " + fmt("%.0f", sp.sigma.maxCoeff()) +
                      " rad/s (above " + fmt("%.0f", kPoorlyMeasuredSpinSigma) +
                      " rad/s, no better known than an unmeasured spin): the dots were followed "
                      "too briefly or matched badly; beta and gamma rest on it");
    }
  return notes;
}

}  // namespace collide::vision
