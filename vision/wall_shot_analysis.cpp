#include "vision/wall_shot_analysis.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>

#include "analysis/residual_structure.hpp"
#include "analysis/shot_inverse.hpp"
#include "analysis/shot_uncertainty.hpp"
#include "analysis/spin_prior.hpp"
#include "vision/dot_detector.hpp"
#include "vision/shot_fits.hpp"
#include "vision/shot_spins.hpp"
#include "vision/shot_tracking.hpp"
#include "vision/sphere_detector.hpp"
#include "vision/spin_fit.hpp"
#include "vision/wall_line.hpp"

namespace collide::vision {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Sample {
  std::size_t frame = 0;  // index into burst.frames
  double t_s = 0;
  Vec3 centre_m = Vec3::Zero();
  double sigma_m = 0;
  SphereMeasurement m;
};

}  // namespace

const SphereMeasurement* wallSphere(const FrameSpheres& found, double r_px) {
  const SphereMeasurement* best = nullptr;
  for (const SphereMeasurement& m : found.spheres) {
    if (r_px > 0 && std::abs(m.circle.radius - r_px) > 0.3 * r_px) continue;
    const bool better =
        !best || (r_px > 0 ? std::abs(m.circle.radius - r_px) < std::abs(best->circle.radius - r_px)
                           : m.circle.radius > best->circle.radius);
    if (better) best = &m;
  }
  return best;
}

namespace {

// The sphere in each good frame: the detection nearest the expected radius
// (within 30 %), outlines cut by the frame's edge left out.
std::vector<Sample> detectSphere(const Burst& burst, const WallAnalysisSettings& s, double px_m,
                                 bool& dark, std::vector<std::string>& notes) {
  // Through a lens the outline is fitted as the ellipse it is (fitOutline).
  SphereDetectorSettings ds;
  ds.camera = s.camera;
  const SphereDetector detector(ds);
  // Unknown scale (footage): any round blob, the largest in each frame.
  const double r_px = s.pixel_size_m > 0 ? 0.5 * s.diameter_m / s.pixel_size_m : 0.0;
  const int max_value = maxValue(burst.format);
  std::vector<Sample> out;
  int dark_frames = 0, cut = 0;
  for (std::size_t i = 0; i < burst.frames.size(); ++i) {
    const Frame& f = burst.frames[i];
    if (!f.good()) continue;
    const FrameSpheres found = detector.detect(f.image, max_value);
    const SphereMeasurement* best = wallSphere(found, r_px);
    if (!best) continue;
    if (best->cut_by_border) {
      ++cut;
      continue;
    }
    dark_frames += found.dark_spheres ? 1 : 0;
    Sample smp;
    smp.frame = i;
    smp.t_s = static_cast<double>(f.id) / s.fps;
    smp.centre_m = s.camera
                       ? s.camera->sphereCentre(best->circle.u, best->circle.v, 0.5 * s.diameter_m)
                       : Vec3((best->circle.u - s.origin_u_px) * px_m,
                              -(best->circle.v - s.origin_v_px) * px_m, 0.0);
    smp.centre_m.z() = 0.0;
    smp.sigma_m = std::max({best->circle.sigma_u, best->circle.sigma_v, 1e-3}) * px_m;
    smp.m = *best;
    out.push_back(smp);
  }
  dark = mostlyDark(dark_frames, static_cast<int>(out.size()));
  if (cut > 0)
    notes.push_back(std::to_string(cut) +
                    " frames with the sphere cut by the frame's edge left out");
  return out;
}

// The face line in the world: with a lens, two of its points taken onto the
// plane z = 0 (where the sphere's centre meets the face at contact).
Wall worldWall(const WallAnalysisSettings& s, double px, const WallLine& line,
               const Vec3& sphere_m) {
  Wall w;
  if (s.camera) {
    const Eigen::Vector2d along(-line.normal.y(), line.normal.x());
    const Eigen::Vector2d a = line.point_px - 50.0 * along.normalized();
    const Eigen::Vector2d b = line.point_px + 50.0 * along.normalized();
    const Vec3 pa = s.camera->onPlane(a.x(), a.y()), pb = s.camera->onPlane(b.x(), b.y());
    w.point_m = s.camera->onPlane(line.point_px.x(), line.point_px.y());
    const Vec3 d = pb - pa;
    w.normal = Vec3(-d.y(), d.x(), 0.0).normalized();
  } else {
    w.point_m = Vec3((line.point_px.x() - s.origin_u_px) * px,
                     -(line.point_px.y() - s.origin_v_px) * px, 0.0);
    w.normal = Vec3(line.normal.x(), -line.normal.y(), 0.0).normalized();
  }
  w.point_m.z() = 0.0;
  if ((sphere_m - w.point_m).dot(w.normal) < 0) w.normal = -w.normal;
  return w;
}

// The air's drag on the sphere, when there is air and the mass is known.
std::optional<AirDrag> wallDrag(const WallAnalysisSettings& s) {
  if (!(s.air_density_kg_m3 > 0) || !(s.mass_kg > 0)) return std::nullopt;
  return AirDrag{s.diameter_m, s.mass_kg, s.air_density_kg_m3};
}

// With the air's drag on the sphere (none in a vacuum; AnalysisSettings'
// air_density_kg_m3), as the two-sphere fits (vision/shot_fits.hpp).
Result<TrajectoryFit> fitSide(const std::vector<Sample>& samples, double t_ref_s,
                              const std::optional<AirDrag>& drag) {
  Eigen::VectorXd t(samples.size()), w(samples.size());
  Eigen::MatrixXd p(samples.size(), 2);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    t(i) = samples[i].t_s;
    p(i, 0) = samples[i].centre_m.x();
    p(i, 1) = samples[i].centre_m.y();
    w(i) = 1.0 / (samples[i].sigma_m * samples[i].sigma_m);
  }
  TrajectoryOptions o;
  o.fixed_acceleration_m_s2 = kGravity_m_s2;
  o.drag = drag;
  // Relative weights: the residuals set the scale (detector sigmas can be optimistic).
  return fitTrajectory(t, p, Weights::relative(w), t_ref_s, o);
}

// Height of the fitted outline above the face, h(t) = (r(t) - P) . n - R, as
// a quadratic in (t - t_ref); the root wanted: the first one after the data
// start where h falls (kBefore), or the last one before the data end where it
// rises (kAfter).
std::optional<double> faceInstant(const TrajectoryFit& fit, const Wall& wall, double radius_m,
                                  bool before) {
  double h[3];
  for (int k = 0; k < 3; ++k)
    h[k] = fit.coefficients(0)(k) * wall.normal.x() + fit.coefficients(1)(k) * wall.normal.y();
  h[0] -= wall.point_m.dot(wall.normal) + radius_m;
  std::vector<double> roots;
  if (std::abs(h[2]) < 1e-15) {
    if (h[1] != 0) roots.push_back(-h[0] / h[1]);
  } else {
    const double disc = h[1] * h[1] - 4 * h[2] * h[0];
    if (disc < 0) return std::nullopt;
    const double q = -0.5 * (h[1] + std::copysign(std::sqrt(disc), h[1]));
    roots.push_back(q / h[2]);
    if (q != 0) roots.push_back(h[0] / q);
  }
  std::optional<double> best;
  for (const double r : roots) {
    const double slope = h[1] + 2 * h[2] * r;
    const double t = fit.tRef_s() + r;
    if (before && slope < 0 && t >= fit.tFirst_s() && (!best || t < *best)) best = t;
    if (!before && slope > 0 && t <= fit.tLast_s() && (!best || t > *best)) best = t;
  }
  return best;
}

// One side refitted with its centres at the depth an out-of-plane velocity
// vz gives, z = vz (t - t_contact_s) (the centre meets the face on the plane
// z = 0): the fit, the instant it meets (before) or leaves the face, and its
// velocity then.
struct DepthRefit {
  TrajectoryFit fit;
  double t_face_s = 0;
  Vec3 velocity = Vec3::Zero();
};
std::optional<DepthRefit> refitAtDepth(const std::vector<Sample>& side, bool before,
                                       const PinholeCamera& camera, double radius_m,
                                       double t_contact_s, double vz, const Wall& wall,
                                       const std::optional<AirDrag>& drag) {
  std::vector<Sample> moved = side;
  for (Sample& smp : moved) {
    smp.centre_m =
        camera.sphereCentre(smp.m.circle.u, smp.m.circle.v, radius_m, vz * (smp.t_s - t_contact_s));
    smp.centre_m.z() = 0.0;  // projected onto the plane, as detectSphere leaves them
  }
  auto fit = fitSide(moved, before ? moved.back().t_s : moved.front().t_s, drag);
  if (!fit) return std::nullopt;
  const auto t_face = faceInstant(*fit, wall, radius_m, before);
  if (!t_face) return std::nullopt;
  DepthRefit out{*fit, *t_face, fit->velocityAt_m_s(*t_face).value};
  return out;
}

// How a side's in-plane velocity at the face moves with its out-of-plane
// velocity v_z under a lens (dv/dv_z, to first order about vz): a centre x
// from the optical axis placed on the wrong plane moves x dv_z / Z0 too fast
// or too slow, and the track bends. Zero without a lens or when a refit fails.
Eigen::Vector2d depthCoupling(const std::vector<Sample>& side, bool before,
                              const std::optional<PinholeCamera>& camera, double radius_m,
                              double t_contact_s, double vz, const Wall& wall,
                              const std::optional<AirDrag>& drag) {
  constexpr double kDvz = 0.01;  // m/s
  if (!camera) return Eigen::Vector2d::Zero();
  const auto lo = refitAtDepth(side, before, *camera, radius_m, t_contact_s, vz - kDvz, wall, drag);
  const auto hi = refitAtDepth(side, before, *camera, radius_m, t_contact_s, vz + kDvz, wall, drag);
  if (!lo || !hi) return Eigen::Vector2d::Zero();
  return (hi->velocity - lo->velocity).head<2>() / (2 * kDvz);
}

struct SpinSide {
  bool known = false;
  Vec3 spin = Vec3::Zero();
  /// Unknown: the launchers' spin spread squared per axis (spinOf sets it).
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  std::string why;
};

// `camera`: the dots lifted through the lens onto the sphere at its centre
// (as the two-sphere analysis does, vision/shot_spins.hpp); none: orthographic.
SpinSide spinOf(const Burst& burst, const std::vector<Sample>& side, double r_med_px,
                const std::optional<PinholeCamera>& camera, double radius_m,
                double unknown_spin_sigma, const std::function<double(double)>& depth_m = {}) {
  const int max_value = maxValue(burst.format);
  std::vector<SpinFrame> frames;
  for (const Sample& smp : side) {
    SphereMeasurement m = smp.m;
    m.circle.radius = r_med_px;
    const DotFrame dots = findDots(burst.frames[smp.frame].image, m, max_value);
    if (dots.dots.empty()) continue;
    SpinFrame f;
    f.t_s = smp.t_s;
    // Dot centroids lie on a sphere of radius R cos(alpha) (alpha: their angular radius).
    const double r_dots = radius_m * std::cos(dots.angular_radius_rad);
    const Vec3 centre = camera ? camera->sphereCentre(m.circle.u, m.circle.v, radius_m,
                                                      depth_m ? depth_m(smp.t_s) : 0.0)
                               : Vec3::Zero();
    for (const Dot& d : dots.dots) {
      f.dots.push_back(camera ? liftThroughLens(*camera, centre, r_dots, d.u_px, d.v_px)
                              : d.on_sphere);
      f.weights.push_back(d.weight);
    }
    f.centre_sigma = 1.2 * std::max(m.circle.sigma_u, m.circle.sigma_v) / r_med_px;
    frames.push_back(std::move(f));
  }
  SpinSide out;
  out.cov = Eigen::Matrix3d::Identity() * (unknown_spin_sigma * unknown_spin_sigma);
  auto spin = fitSpin(frames);
  if (!spin) {
    out.why = spin.error().message;
    return out;
  }
  out.known = true;
  out.spin = spin->spin_rad_s;
  out.cov = spin->covariance * (kSpinSigmaScale * kSpinSigmaScale);
  if (camera) addLensSpinSystematic(out.cov, out.spin);
  return out;
}

double stddev(const std::vector<double>& x) {
  std::vector<double> v;
  for (double a : x)
    if (std::isfinite(a)) v.push_back(a);
  if (v.size() < 2) return kNaN;
  double mean = 0;
  for (double a : v) mean += a;
  mean /= v.size();
  double ss = 0;
  for (double a : v) ss += (a - mean) * (a - mean);
  return std::sqrt(ss / (v.size() - 1));
}

// How the fits depend on the out-of-plane velocities (under a lens; zero
// without): each side's in-plane velocity at the face moves by
// dv_dvz (v_z - vz_used) to first order, its centres being taken at the depth
// v_z (t - t_contact) (see analyzeWallBurst). Before the impact v_z is the
// prior's (vz_used 0); after it, the spins' when both are known, else the
// same as before.
struct WallDepthCoupling {
  Eigen::Vector2d dv_dvz_before = Eigen::Vector2d::Zero();
  Eigen::Vector2d dv_dvz = Eigen::Vector2d::Zero();  ///< after the impact
  double vz_used = 0;                                ///< after the impact
};

// The in-plane velocities' uncertainties at contact, m/s: the fits' own per
// axis (residual inflation included), and the dots' drift (the same on both
// axes), drawn anti-correlated between the two sides (drawDriftPair).
struct WallVelocitySigmas {
  Eigen::Vector2d fit_before = Eigen::Vector2d::Zero(), fit_after = Eigen::Vector2d::Zero();
  double drift_before = 0, drift_after = 0;
  Vec3 before() const { return total(fit_before, drift_before); }
  Vec3 after() const { return total(fit_after, drift_after); }
  static Vec3 total(const Eigen::Vector2d& fit, double drift) {
    return Vec3(std::hypot(fit.x(), drift), std::hypot(fit.y(), drift), 0.0);
  }
};

// Monte Carlo: velocities from the fits' per-axis sigmas and the dots' drift
// at contact, spins from their covariances, the face turned and shifted by its
// sigmas; the post-impact velocity follows the v_z each draw's spins give
// (`depth`). Returns the spread of the post-impact v_z over the draws (m/s).
double propagate(WallShotAnalysis& a, double px_m, int draws, double z_sigma_m_s,
                 const SpinSide& sb, const SpinSide& sa, const WallVelocitySigmas& vs_in,
                 const WallDepthCoupling& depth) {
  std::mt19937_64 rng(12345);
  std::normal_distribution<double> unit(0.0, 1.0);
  const Eigen::Matrix3d Lb = sb.cov.llt().matrixL(), La = sa.cov.llt().matrixL();
  const bool spins_known = sb.known && sa.known;
  std::vector<double> e, beta, gamma, f, vn, vs, bi, spin_minus_impulse, vz_after;
  for (int k = 0; k < draws; ++k) {
    Sphere b = a.sphere_before, af = a.sphere_after;
    for (int ax = 0; ax < 2; ++ax) {
      const auto drift = drawDriftPair(vs_in.drift_before, vs_in.drift_after, rng);
      b.velocity_m_s(ax) += vs_in.fit_before(ax) * unit(rng) + drift[0];
      af.velocity_m_s(ax) += vs_in.fit_after(ax) * unit(rng) + drift[1];
    }
    // The unseen z velocity before the impact; after it, the same shift
    // (recomputed from the spins below when both are known).
    const double dz = z_sigma_m_s * unit(rng);
    b.velocity_m_s.z() += dz;
    b.velocity_m_s.head<2>() += depth.dv_dvz_before * dz;
    af.velocity_m_s.z() += dz;
    if (!spins_known) af.velocity_m_s.head<2>() += depth.dv_dvz * dz;
    b.spin_rad_s += Lb * Vec3(unit(rng), unit(rng), unit(rng));
    af.spin_rad_s += La * Vec3(unit(rng), unit(rng), unit(rng));
    Wall w = a.wall;
    w.point_m += a.wall_offset_sigma_px * px_m * unit(rng) * w.normal;
    const double th = a.wall_angle_sigma_rad * unit(rng);
    w.normal = Vec3(std::cos(th) * w.normal.x() - std::sin(th) * w.normal.y(),
                    std::sin(th) * w.normal.x() + std::cos(th) * w.normal.y(), 0.0);
    if (spins_known) {
      if (auto vz = wallOutOfPlaneVelocity(b, af, w)) {
        af.velocity_m_s.head<2>() += depth.dv_dvz * (*vz - depth.vz_used);
        af.velocity_m_s.z() = *vz;
      }
    }
    vz_after.push_back(af.velocity_m_s.z());
    auto m = measureWallCollision(b, af, w);
    if (!m) continue;
    e.push_back(m->e);
    beta.push_back(m->beta);
    gamma.push_back(m->before.gamma_rad);
    f.push_back(m->f);
    vn.push_back(m->before.v_n_m_s);
    vs.push_back(m->before.v_s_m_s);
    bi.push_back(m->beta_from_impulse);
    spin_minus_impulse.push_back(m->beta - m->beta_from_impulse);
  }
  a.e_sigma = stddev(e);
  a.beta_sigma = stddev(beta);
  a.gamma_sigma_rad = stddev(gamma);
  a.f_sigma = stddev(f);
  a.vn_sigma_m_s = stddev(vn);
  a.vs_sigma_m_s = stddev(vs);
  a.beta_from_impulse_sigma = stddev(bi);
  a.beta_spin_minus_impulse_sigma = stddev(spin_minus_impulse);
  return stddev(vz_after);
}

// ---- the stages of analyzeWallBurst -----------------------------------------

// The settings the analysis cannot start without.
Status checkSettings(const WallAnalysisSettings& s) {
  if (!(s.pixel_size_m >= 0)) return fail("pixel_size_m: must be >= 0 (0: from the sphere)");
  if (!(s.fps > 0)) return fail("fps: the frame rate must be > 0");
  if (!(s.diameter_m > 0) || !(s.mass_kg > 0))
    return fail("diameter_m and mass_kg: must be > 0 (the sphere's)");
  if (s.wall_line && !(s.wall_line->normal.norm() > 0))
    return fail("wall line: the two points must differ (give --wall-line u1,v1,u2,v2)");
  return Ok{};
}

// The sphere in each frame, at the scale the analysis works in: the
// settings' pixel size or, without one (footage), the sphere's median radius
// against its diameter. Sets a.pixel_size_m; `dark`: a backlit silhouette.
Result<std::vector<Sample>> detectAtScale(const Burst& burst, const WallAnalysisSettings& s,
                                          bool& dark, WallShotAnalysis& a) {
  double px_m = s.pixel_size_m;
  if (!(px_m > 0)) {
    std::vector<Sample> raw = detectSphere(burst, s, 1.0, dark, a.notes);
    std::vector<double> r;
    for (const Sample& smp : raw) r.push_back(smp.m.circle.radius);
    if (r.empty()) return fail("no sphere found in any frame: check the polarity and lighting");
    std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
    px_m = s.diameter_m / (2.0 * r[r.size() / 2]);
    a.notes.clear();
  }
  a.pixel_size_m = px_m;
  std::vector<Sample> samples = detectSphere(burst, s, px_m, dark, a.notes);
  if (samples.size() < 8)
    return fail("the sphere was found in only " + std::to_string(samples.size()) +
                " frames (8 needed): check the diameter, pixel size and lighting");
  return samples;
}

// The face: the line given, or the one found in the frames (near the given
// one, which is flagged when the frames put it elsewhere), then in the world.
Status placeWall(const Burst& burst, const WallAnalysisSettings& s,
                 const std::vector<Sample>& samples, WallShotAnalysis& a) {
  if (s.wall_line && !s.refine_wall_line) {
    a.wall_line = *s.wall_line;
    a.wall_angle_sigma_rad = s.wall_angle_sigma_rad;
    a.wall_offset_sigma_px = s.wall_offset_sigma_px;
  } else {
    auto found = findWallLine(
        burst, s.wall_line, Eigen::Vector2d(samples.front().m.circle.u, samples.front().m.circle.v),
        s.camera ? &*s.camera : nullptr);
    if (!found) return fail("wall: " + found.error().message);
    a.wall_line = found->line;
    a.wall_found_in_image = true;
    a.wall_angle_sigma_rad = found->angle_sigma_rad;
    a.wall_offset_sigma_px = found->offset_sigma_px;
    if (s.wall_line) {
      const double moved =
          std::abs(s.wall_line->distancePx(found->line.point_px.x(), found->line.point_px.y()) /
                   s.wall_line->normal.norm());
      if (moved > 2.0) {
        a.quality_flags.push_back("wall_line_moved");
        a.notes.push_back("the wall's edge in the frames lies " + std::to_string(moved) +
                          " px from the line given: check the profile's [wall] or --wall-line");
      }
    }
  }
  a.wall = worldWall(s, a.pixel_size_m, a.wall_line, samples.front().centre_m);
  return Ok{};
}

// The flight on each side of the impact: its samples, its fit, and the
// instant its outline meets the face (contact before, separation after).
struct WallSides {
  std::vector<Sample> before, after;
  TrajectoryFit fit_before, fit_after;
  double t_contact_s = 0, t_separation_s = 0;
};

// The samples split at the one nearest the face, which joins the side whose
// extrapolation it agrees with; each side fitted, and where it meets the face.
Result<WallSides> fitSides(const std::vector<Sample>& samples, double R,
                           const std::optional<AirDrag>& drag, WallShotAnalysis& a) {
  std::size_t k = 0;
  for (std::size_t i = 0; i < samples.size(); ++i)
    if ((samples[i].centre_m - a.wall.point_m).dot(a.wall.normal) <
        (samples[k].centre_m - a.wall.point_m).dot(a.wall.normal))
      k = i;
  std::vector<Sample> before(samples.begin(), samples.begin() + k);
  std::vector<Sample> after(samples.begin() + k + 1, samples.end());
  if (before.size() < 4 || after.size() < 4)
    return fail("only " + std::to_string(before.size()) + " frames before and " +
                std::to_string(after.size()) +
                " after the impact show the sphere (4 needed on each side): does the burst "
                "hold the impact, and is the wall line right?");
  auto fb = fitSide(before, before.back().t_s, drag);
  auto fa = fitSide(after, after.front().t_s, drag);
  if (!fb) return fail("pre-impact fit: " + fb.error().message);
  if (!fa) return fail("post-impact fit: " + fa.error().message);
  const Sample& n = samples[k];
  const double db = (fb->positionAt_m(n.t_s).value - n.centre_m).head<2>().norm();
  const double da = (fa->positionAt_m(n.t_s).value - n.centre_m).head<2>().norm();
  if (db <= da) {
    before.push_back(n);
    fb = fitSide(before, n.t_s, drag);
  } else {
    after.insert(after.begin(), n);
    fa = fitSide(after, n.t_s, drag);
  }
  if (!fb || !fa) return fail("refit with the frame nearest the wall failed");
  a.frames_used_before = static_cast<int>(before.size());
  a.frames_used_after = static_cast<int>(after.size());
  if (before.size() < 5) a.quality_flags.push_back("few_frames_before");
  if (after.size() < 5) a.quality_flags.push_back("few_frames_after");
  const auto tc = faceInstant(*fb, a.wall, R, true);
  const auto ts = faceInstant(*fa, a.wall, R, false);
  if (!tc || !ts)
    return fail(
        "the fitted flight never reaches the wall line one radius from it: check the "
        "wall line and the pixel size");
  a.t_contact_s = *tc;
  a.t_separation_s = *ts;
  a.before = *fb;
  a.after = *fa;
  return WallSides{std::move(before), std::move(after), std::move(*fb), std::move(*fa), *tc, *ts};
}

// The spins on each side, from the dots: on a backlit sphere too, as the
// two-sphere analysis does (room light on its face shows them); a bare
// silhouette shows none, and the reason says so.
struct WallSpins {
  SpinSide before, after;
  double r_med_px = 0;  // the sphere's median radius over the frames
};

WallSpins measureSpins(const Burst& burst, const WallAnalysisSettings& s,
                       const std::vector<Sample>& samples, const WallSides& sides, double R,
                       bool dark, WallShotAnalysis& a) {
  WallSpins w;
  std::vector<double> radii;
  for (const Sample& smp : samples) radii.push_back(smp.m.circle.radius);
  std::nth_element(radii.begin(), radii.begin() + radii.size() / 2, radii.end());
  w.r_med_px = radii[radii.size() / 2];
  w.before = spinOf(burst, sides.before, w.r_med_px, s.camera, R, s.unknown_spin_sigma_rad_s);
  w.after = spinOf(burst, sides.after, w.r_med_px, s.camera, R, s.unknown_spin_sigma_rad_s);
  if (w.before.known) {  // the launcher's spin where the dots do not pin it (as measureSpins)
    const SpinWithPrior p =
        combineWithLaunchPrior(w.before.spin, w.before.cov, s.unknown_spin_sigma_rad_s);
    w.before.spin = p.spin_rad_s;
    w.before.cov = p.cov;
    a.spin_before_prior_directions = p.prior_directions;
    if (p.prior_directions > 0)
      a.notes.push_back("before the impact the dots pin " + std::to_string(p.prior_directions) +
                        " of the spin's 3 directions less well than the launchers' spread "
                        "(launch_spin_rad_s " +
                        fmt("%.1f", s.unknown_spin_sigma_rad_s) +
                        " rad/s), which was combined with them there");
  }
  for (SpinSide* side : {&w.before, &w.after})
    if (dark && !side->known) side->why = "backlit, no dots seen on the silhouette: " + side->why;
  const SpinSide &sb = w.before, &sa = w.after;
  a.spin_before_known = sb.known;
  a.spin_after_known = sa.known;
  a.spin_sigma_before = sb.known ? Vec3(sb.cov.diagonal().cwiseSqrt()) : Vec3::Constant(kNaN);
  a.spin_sigma_after = sa.known ? Vec3(sa.cov.diagonal().cwiseSqrt()) : Vec3::Constant(kNaN);
  if (!sb.known) {
    a.quality_flags.push_back("no_spin_before");
    a.notes.push_back("spin before the impact unknown (" + sb.why + "): beta and f not measured");
  }
  if (!sa.known) {
    a.quality_flags.push_back("no_spin_after");
    a.notes.push_back("spin after the impact unknown (" + sa.why + "): beta not measured");
  }
  return w;
}

// The sphere at contact (before) and at separation (after), and the
// out-of-plane velocity the impact gave, which the image does not show, from
// the spin change (appendix B; needs both spins). Under a lens that v_z moves
// the sphere off the plane z = 0 after the impact, and a centre taken on the
// wrong plane moves too fast or too slow by dz / Z0 (2 mm at 0.53 m: 0.4 %),
// its dots meet their rays at the wrong points: the post-impact centres and
// dots are taken again at their depth, refitted, and v_z found again from the
// spins. Returns how an error of each side's v_z moves its in-plane velocity.
WallDepthCoupling kinematicsAtTheFace(const Burst& burst, const WallAnalysisSettings& s,
                                      WallSides& sides, WallSpins& spins, double R,
                                      WallShotAnalysis& a) {
  const double tc = sides.t_contact_s;
  Sphere& b = a.sphere_before;
  b.mass_kg = s.mass_kg;
  b.diameter_m = s.diameter_m;
  b.position_m = sides.fit_before.positionAt_m(tc).value;
  b.velocity_m_s = sides.fit_before.velocityAt_m_s(tc).value;
  b.spin_rad_s = spins.before.spin;
  a.sphere_after = b;
  a.sphere_after.velocity_m_s = sides.fit_after.velocityAt_m_s(sides.t_separation_s).value;
  a.sphere_after.spin_rad_s = spins.after.spin;
  // Under a lens the unseen v_z before the impact (the prior's) moves the
  // pre-impact velocity, and the post-impact one while the spins do not
  // give their own v_z (then taken about that v_z, below).
  WallDepthCoupling coupling;
  const std::optional<AirDrag> drag = wallDrag(s);
  coupling.dv_dvz_before = depthCoupling(sides.before, true, s.camera, R, tc, 0.0, a.wall, drag);
  bool after_at_depth = false;  // the post-impact centres at the spins' v_z
  std::optional<double> vz;
  if (spins.before.known && spins.after.known)
    if (auto found = wallOutOfPlaneVelocity(b, a.sphere_after, a.wall)) vz = *found;
  if (vz) {
    a.sphere_after.velocity_m_s.z() = *vz;
    if (s.camera) {
      const auto depth = [vz = *vz, t0 = tc](double t) { return vz * (t - t0); };
      if (SpinSide at_depth = spinOf(burst, sides.after, spins.r_med_px, s.camera, R,
                                     s.unknown_spin_sigma_rad_s, depth);
          at_depth.known) {
        spins.after = at_depth;
        a.sphere_after.spin_rad_s = spins.after.spin;
        a.spin_sigma_after = Vec3(spins.after.cov.diagonal().cwiseSqrt());
      }
      if (auto refit = refitAtDepth(sides.after, false, *s.camera, R, tc, *vz, a.wall, drag)) {
        // How much the spins' error in v_z moves the post-impact velocity
        // (propagate()).
        coupling.dv_dvz = depthCoupling(sides.after, false, s.camera, R, tc, *vz, a.wall, drag);
        coupling.vz_used = *vz;
        after_at_depth = true;
        a.after = refit->fit;
        a.t_separation_s = refit->t_face_s;
        a.sphere_after.velocity_m_s = refit->velocity;
        sides.t_separation_s = refit->t_face_s;
        sides.fit_after = std::move(refit->fit);
        if (auto vz2 = wallOutOfPlaneVelocity(b, a.sphere_after, a.wall))
          a.sphere_after.velocity_m_s.z() = *vz2;
      }
    }
  }
  // Otherwise the post-impact centres stay on the plane z = 0, and the
  // coupling is taken about v_z = 0 (the prior's, as before the impact).
  if (!after_at_depth)
    coupling.dv_dvz = depthCoupling(sides.after, false, s.camera, R, tc, 0.0, a.wall, drag);
  return coupling;
}

// The uncertainties: the velocities' (the fits', as the two-sphere analysis:
// residuals correlated from frame to frame, lag-1 inflation; the dots' slow
// pull on the outline and, under a lens, the lamp's, vision/shot_fits.hpp,
// shared where the tracks meet at the face) and, through propagate(), e,
// beta, gamma and f's.
void addSigmas(const Burst& burst, const WallAnalysisSettings& s, const WallSides& sides,
               const WallSpins& spins, const WallDepthCoupling& coupling, bool dark,
               WallShotAnalysis& a) {
  const double px_m = a.pixel_size_m;
  const auto fitSigma = [&](const TrajectoryFit& f, double t) -> Eigen::Vector2d {
    return f.velocityAt_m_s(t).sigma.head<2>() * std::sqrt(residualInflation(f));
  };
  const auto driftSigma = [&](const TrajectoryFit& f) {
    const double dots =
        spins.before.known || spins.after.known
            ? dotDriftSigma_m_s(f, spins.r_med_px, px_m, burst.exposure_us * 1e-6, dark)
            : 0.0;
    return centreDriftSigma_m_s(f, dots, s.camera.has_value(), s.radius_systematic_px, px_m);
  };
  WallVelocitySigmas vsig;
  vsig.fit_before = fitSigma(sides.fit_before, sides.t_contact_s);
  vsig.fit_after = fitSigma(sides.fit_after, sides.t_separation_s);
  vsig.drift_before = driftSigma(sides.fit_before), vsig.drift_after = driftSigma(sides.fit_after);
  const double vz_sigma = s.out_of_plane_speed_fraction * a.sphere_before.velocity_m_s.norm();
  const Vec3 fit_sigma_before = vsig.before(), fit_sigma_after = vsig.after();
  const double vz_after_sigma =
      propagate(a, px_m, s.monte_carlo_draws, vz_sigma, spins.before, spins.after, vsig, coupling);
  // Reported: the fits' sigmas and what the v_z uncertainty adds through the lens.
  a.velocity_sigma_before = fit_sigma_before;
  a.velocity_sigma_after = fit_sigma_after;
  for (int ax = 0; ax < 2; ++ax) {
    a.velocity_sigma_before(ax) =
        std::hypot(fit_sigma_before(ax), coupling.dv_dvz_before(ax) * vz_sigma);
    a.velocity_sigma_after(ax) =
        std::hypot(fit_sigma_after(ax), coupling.dv_dvz(ax) * vz_after_sigma);
  }
  a.velocity_sigma_before.z() = vz_sigma;
  a.velocity_sigma_after.z() = vz_after_sigma;
}

// A spin not measured gives no beta or f: reported as unavailable, not
// guessed. Then the angular momentum about the contact point (nothing
// compared without beta).
void checkTheSpins(const WallSpins& spins, WallShotAnalysis& a) {
  if (!spins.before.known || !spins.after.known) {
    a.measured.beta = kNaN;
    a.beta_sigma = kNaN;
  }
  if (!spins.before.known) a.measured.beta_from_impulse = kNaN;
  if (auto why = spinImpulseDisagreement(a.measured.beta, a.measured.beta_from_impulse,
                                         a.beta_spin_minus_impulse_sigma)) {
    a.quality_flags.push_back("spin_impulse_disagree");
    a.notes.push_back(*why);
  }
  // The spins' beta and the impulse's as one estimate (betaSpinWeight).
  a.beta_from_spins = a.measured.beta;
  a.beta_from_spins_sigma = a.beta_sigma;
  if (!std::isfinite(a.measured.beta) || !std::isfinite(a.measured.beta_from_impulse)) return;
  const double vs = a.beta_sigma * a.beta_sigma,
               vi = a.beta_from_impulse_sigma * a.beta_from_impulse_sigma,
               vd = a.beta_spin_minus_impulse_sigma * a.beta_spin_minus_impulse_sigma;
  const double w = betaSpinWeight(vs, vi, vd);
  a.beta_spin_weight = w;
  a.measured.beta = w * a.measured.beta + (1 - w) * a.measured.beta_from_impulse;
  a.beta_sigma = combinedBetaSigma(vs, vi, vd, w);
}

}  // namespace

Result<WallShotAnalysis> analyzeWallBurst(const Burst& burst, const WallAnalysisSettings& s) {
  if (Status ok = checkSettings(s); !ok) return ok.error();
  WallShotAnalysis a;
  bool dark = false;
  auto samples = detectAtScale(burst, s, dark, a);
  if (!samples) return samples.error();
  if (Status ok = placeWall(burst, s, *samples, a); !ok) return ok.error();
  const double R = 0.5 * s.diameter_m;
  auto sides = fitSides(*samples, R, wallDrag(s), a);
  if (!sides) return sides.error();
  WallSpins spins = measureSpins(burst, s, *samples, *sides, R, dark, a);
  const WallDepthCoupling coupling = kinematicsAtTheFace(burst, s, *sides, spins, R, a);
  auto m = measureWallCollision(a.sphere_before, a.sphere_after, a.wall);
  if (!m) return fail("wall inverse: " + m.error().message);
  a.measured = *m;
  addSigmas(burst, s, *sides, spins, coupling, dark, a);
  checkTheSpins(spins, a);
  return a;
}

}  // namespace collide::vision
