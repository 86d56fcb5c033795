#include "vision/shot_fits.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "analysis/contact.hpp"
#include "analysis/residual_structure.hpp"
#include "analysis/shot_uncertainty.hpp"

namespace collide::vision {

double dotBiasPx(double radius_px, double blur_px, bool dark) {
  if (dark) return kDarkDotBiasPx2 / radius_px;
  return 0.22 / radius_px * std::max(blur_px, 0.5) / 1.9;
}

double smearPx(const TrajectoryFit& fit, double exposure_s, double pixel_m) {
  return fit.velocityAt_m_s(fit.tRef_s()).value.norm() * exposure_s / pixel_m;
}

double dotBias_m(const TrajectoryFit& fit, double radius_px, double pixel_m, double exposure_s,
                 bool dark) {
  return dotBiasPx(radius_px, smearPx(fit, exposure_s, pixel_m), dark) * pixel_m;
}

double dotDriftSigma_m_s(const TrajectoryFit& fit, double radius_px, double pixel_m,
                         double exposure_s, bool dark) {
  const double span = fit.tLast_s() - fit.tFirst_s();
  return span > 0 ? dotBias_m(fit, radius_px, pixel_m, exposure_s, dark) / span : 0.0;
}

double centreDriftSigma_m_s(const TrajectoryFit& fit, double dots_m_s, bool through_lens,
                            double radius_systematic_px, double pixel_m) {
  const double span = fit.tLast_s() - fit.tFirst_s();
  const double lamp =
      through_lens && span > 0 ? std::max(0.0, radius_systematic_px) * pixel_m / span : 0.0;
  return std::hypot(dots_m_s, lamp);
}

Result<SideFit> fitSide(const std::vector<FrameData>& data, std::vector<int> frames, int sphere,
                        const PixelScale& sc, const FreeFlight& flight, double t_ref) {
  for (int round = 0; round < 2; ++round) {
    const int n = static_cast<int>(frames.size());
    Eigen::VectorXd t(n), w(n);
    Eigen::MatrixXd pos(n, 2);
    for (int i = 0; i < n; ++i) {
      const FrameData& f = data[frames[i]];
      const SphereMeasurement& m = *trackAt(f, sphere);
      t[i] = f.t;
      pos.row(i) = sc.world(m.circle, sphere, f.t).transpose();
      const double sig = std::max({m.circle.sigma_u, m.circle.sigma_v, 1e-4});
      w[i] = 1.0 / (sig * sig);
    }
    TrajectoryOptions opt;
    if (flight.fix_gravity) {
      opt.fixed_acceleration_m_s2 = flight.gravity;
      opt.drag = flight.drag[sphere];
    }
    auto fit = fitTrajectory(t, pos, Weights::relative(w), t_ref, opt);
    if (!fit) return fit.error();
    if (round == 1 || n <= 4) return SideFit{*fit, frames, residualInflation(*fit)};
    // Normalised residuals; drop gross outliers (a mis-measured frame).
    std::vector<double> z(n);
    for (int i = 0; i < n; ++i) {
      double r2 = 0;
      for (int k = 0; k < 2; ++k) {
        const double r = fit->axisFit(k).residuals[i];
        r2 += r * r;
      }
      z[i] = std::sqrt(r2 * w[i]);
    }
    const double med = median(z);
    std::vector<int> keep;
    for (int i = 0; i < n; ++i)
      if (z[i] <= std::max(5.0 * med / 1.1774, 1e-12)) keep.push_back(frames[i]);
    if (keep.size() == frames.size() || keep.size() < 4)
      return SideFit{*fit, frames, residualInflation(*fit)};
    frames = keep;
  }
  return fail("unreachable");
}

Status kinkInstant(CollisionFits& fits, double contact_m, double contact_sigma_m) {
  // Each sphere's meeting instant and its variance, where its velocity changed.
  double sum = 0, weights = 0;
  for (int s = 0; s < 2; ++s) {
    const TrajectoryFit &pre = fits.fit[s][0]->fit, &post = fits.fit[s][1]->fit;
    const double t = kinkTime(nominalTrack(pre), nominalTrack(post), fits.t_split);
    const Vec3 dv = pre.velocityAt_m_s(t).value - post.velocityAt_m_s(t).value;
    const double dv_norm = dv.head<2>().norm();
    if (!(dv_norm > 0)) continue;
    const Eigen::Vector2d dir = dv.head<2>() / dv_norm;
    const auto along = [&](const Vec3& sigma) {
      return dir.cwiseProduct(sigma.head<2>()).squaredNorm();
    };
    const double dv_var = along(pre.velocityAt_m_s(t).sigma) + along(post.velocityAt_m_s(t).sigma);
    const double pos_var = along(pre.positionAt_m(t).sigma) + along(post.positionAt_m(t).sigma);
    if (!(dv_norm > 5 * std::sqrt(dv_var)) || !(pos_var > 0)) continue;
    const double w = dv_norm * dv_norm / pos_var;  // 1 / the instant's variance
    sum += w * t, weights += w;
  }
  if (!(weights > 0))
    return fail("neither sphere's velocity changed beyond 5 of its sigmas: the spheres missed");
  const double t = sum / weights;
  // At that instant, how far beyond the contact distance each side's fits are.
  double shortfall = 0;
  for (int side = 0; side < 2; ++side) {
    const Estimate3 a = fits.fit[0][side]->fit.positionAt_m(t);
    const Estimate3 b = fits.fit[1][side]->fit.positionAt_m(t);
    const Eigen::Vector2d r = (a.value - b.value).head<2>();
    const Eigen::Vector2d dir = r.normalized();
    const double var = dir.cwiseProduct(a.sigma.head<2>()).squaredNorm() +
                       dir.cwiseProduct(b.sigma.head<2>()).squaredNorm() +
                       contact_sigma_m * contact_sigma_m;
    const double beyond = r.norm() - contact_m;
    if (beyond > 4 * std::sqrt(var))
      return fail(std::string("where the spheres' tracks bend, their ") +
                  (side == 0 ? "pre" : "post") + "-impact fits are " + fmt("%.0f", 1e6 * beyond) +
                  " um further apart than the contact distance, " +
                  fmt("%.1f", beyond / std::sqrt(var)) + " times its uncertainty");
    shortfall = std::max(shortfall, beyond);
  }
  fits.t_before = fits.t_after = t;
  fits.sigma_before = fits.sigma_after = 1 / std::sqrt(weights);
  fits.contact_reached = false;
  fits.shortfall_m = shortfall;
  return Ok{};
}

Status findInstants(CollisionFits& fits, double contact_m, double contact_sigma_m) {
  const auto cb =
      collisionInstant(fits.fit[0][0]->fit, fits.fit[1][0]->fit, contact_m, CollisionSide::kBefore);
  const auto ca =
      collisionInstant(fits.fit[0][1]->fit, fits.fit[1][1]->fit, contact_m, CollisionSide::kAfter);
  if (!cb || !ca) {
    const std::string why = cb ? ca.error().message : cb.error().message;
    CollisionFits kinked = fits;
    if (Status st = kinkInstant(kinked, contact_m, contact_sigma_m); !st)
      return fail(why +
                  "; nor do the tracks bend where the spheres could touch: " + st.error().message);
    fits = std::move(kinked);
    return Ok{};
  }
  fits.t_before = cb->t_s, fits.sigma_before = cb->sigma_s;
  fits.t_after = ca->t_s, fits.sigma_after = ca->sigma_s;
  fits.contact_reached = true;
  fits.shortfall_m = 0;
  return Ok{};
}

Result<CollisionFits> fitCollision(const std::vector<FrameData>& data, const PixelScale& sc,
                                   double contact, double contact_sigma_m, const FreeFlight& flight,
                                   double exposure_s, double frame_dt) {
  // The closest approach splits the tracks.
  int k_min = -1;
  double d_min = 1e300;
  for (int k = 0; k < static_cast<int>(data.size()); ++k) {
    const SphereMeasurement *a = trackAt(data[k], 0), *b = trackAt(data[k], 1);
    if (!a || !b) continue;
    const double d = std::hypot(a->circle.u - b->circle.u, a->circle.v - b->circle.v);
    if (d < d_min) d_min = d, k_min = k;
  }
  const auto sideFrames = [&](int sphere, int side, int k_split, bool include_split) {
    std::vector<int> v;
    for (int k = 0; k < static_cast<int>(data.size()); ++k) {
      if (!trackAt(data[k], sphere)) continue;
      const bool before = k < k_split || (include_split && side == 0 && k == k_split);
      const bool after = k > k_split || (include_split && side == 1 && k == k_split);
      if ((side == 0 && before) || (side == 1 && after)) v.push_back(k);
    }
    return v;
  };
  CollisionFits out;
  out.t_split = data[k_min].t;
  int include = -1;  // side that gets the closest frame (-1: neither)
  for (int pass = 0; pass < 2; ++pass) {
    for (int s = 0; s < 2; ++s)
      for (int side = 0; side < 2; ++side) {
        const std::vector<int> fr = sideFrames(s, side, k_min, include == side);
        if (fr.size() < 3)
          return fail("sphere " + std::to_string(s + 1) + " is seen in " +
                      std::to_string(fr.size()) + " frame(s) " + (side == 0 ? "before" : "after") +
                      " the collision; a track needs at least 3 (is the collision in the burst?)");
        auto f = fitSide(data, fr, s, sc, flight, out.t_split);
        if (!f)
          return fail("sphere " + std::to_string(s + 1) + ", " + (side == 0 ? "before" : "after") +
                      " the collision: " + f.error().message);
        out.fit[s][side] = std::move(f).value();
      }
    if (Status st = findInstants(out, contact, contact_sigma_m); !st)
      return fail("no collision found: " + st.error().message + " (closest approach " +
                  fmt("%.1f", d_min) + " px between centres, contact at " +
                  fmt("%.1f", contact / sc.px) + " px)");
    if (pass == 1) break;
    // The closest frame joins the side it was exposed on, unless its exposure
    // straddles the impact (then it shows a mix of both motions).
    const double tc = 0.5 * (out.t_before + out.t_after);
    const double half_exp = 0.5 * exposure_s;
    if (out.t_split + half_exp < tc - 0.02 * frame_dt)
      include = 0;
    else if (out.t_split - half_exp > tc + 0.02 * frame_dt)
      include = 1;
    else
      break;
  }
  if (!(out.t_before > data.front().t - 5 * frame_dt) ||
      !(out.t_after < data.back().t + 5 * frame_dt))
    return fail("the collision instant lies outside the burst: no collision recorded");
  return out;
}

std::optional<std::array<double, 2>> fallAlongGravity(const std::vector<FrameData>& data,
                                                      const CollisionFits& fits,
                                                      const PixelScale& sc,
                                                      const Eigen::Vector2d& gdir) {
  double sum = 0, wsum = 0;
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side) {
      const SideFit& sf = *fits.fit[s][side];
      if (sf.frames.size() < 6) continue;
      TrajectoryOptions free;
      Eigen::VectorXd t(sf.frames.size());
      Eigen::MatrixXd p(sf.frames.size(), 2);
      for (std::size_t i = 0; i < sf.frames.size(); ++i) {
        const SphereMeasurement& m = *trackAt(data[sf.frames[i]], s);
        t[i] = data[sf.frames[i]].t;
        p.row(i) = sc.world(m.circle, s, t[i]).transpose();
      }
      auto ff = fitTrajectory(t, p, Weights::equal(), fits.t_split, free);
      if (!ff) continue;
      const Estimate3 a = ff->acceleration_m_s2();
      // Along gravity: world (x, y) = image (u, -v).
      const double along = a.value.x() * gdir.x() - a.value.y() * gdir.y();
      const double sa = std::hypot(a.sigma.x(), a.sigma.y());
      if (!(sa > 0) || !std::isfinite(sa)) continue;
      sum += along / (sa * sa);
      wsum += 1 / (sa * sa);
    }
  if (!(wsum > 0)) return std::nullopt;
  return std::array<double, 2>{sum / wsum, 1 / std::sqrt(wsum)};
}

}  // namespace collide::vision
