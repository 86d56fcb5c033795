// analyzeBurst drives the stages:
//   frames, clock, detect, track    vision/shot_tracking.hpp
//   trajectory fits, both instants  vision/shot_fits.hpp
//   dots and spins                  vision/shot_spins.hpp
//   contact instant                 analysis/contact.hpp
//   Walton's inverse (with n_z)     analysis/shot_inverse.hpp
//   Monte-Carlo uncertainty         analysis/shot_uncertainty.hpp
//   v_z from the apparent size      analysis/depth_from_size.hpp
// and then sets the quality flags (below).
#include "vision/shot_analysis.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "analysis/depth_from_size.hpp"
#include "analysis/error_model.hpp"
#include "analysis/residual_structure.hpp"
#include "analysis/shot_uncertainty.hpp"
#include "vision/shot_fits.hpp"
#include "vision/shot_spins.hpp"
#include "vision/shot_tracking.hpp"

namespace collide::vision {
namespace {

constexpr double kG = 9.80665;

void addFlag(ShotAnalysis& a, const std::string& f) {
  if (std::find(a.quality_flags.begin(), a.quality_flags.end(), f) == a.quality_flags.end())
    a.quality_flags.push_back(f);
}

// Pixel size: given (and checked against the track radii) or from the radii.
Result<double> pixelSize(const AnalysisSettings& set, const std::array<double, 2>& r_med) {
  const std::array<double, 2>& diam = set.diameter_m;
  double px = set.pixel_size_m;
  if (px > 0) {
    for (int s = 0; s < 2; ++s) {
      const double d_img = 2 * r_med[s] * px;
      if (std::abs(d_img / diam[s] - 1) > 0.05)
        return fail("sphere " + std::to_string(s + 1) + " measures " + fmt("%.2f", 2 * r_med[s]) +
                    " px across, which at a pixel size of " + fmt("%.5g", px * 1e3) + " mm is " +
                    fmt("%.2f", d_img * 1e3) + " mm, but its diameter is given as " +
                    fmt("%.2f", diam[s] * 1e3) +
                    " mm: check the diameter (--diameter-mm) or the pixel size");
    }
  } else {
    const double ratio = diam[1] / diam[0];
    if (std::abs((r_med[1] / r_med[0]) / ratio - 1) > 0.05)
      return fail("the spheres measure " + fmt("%.2f", 2 * r_med[0]) + " and " +
                  fmt("%.2f", 2 * r_med[1]) + " px across, but the diameters given are " +
                  fmt("%.3g", diam[0] * 1e3) + " and " + fmt("%.3g", diam[1] * 1e3) +
                  " mm: check --diameter-mm and --diameter2-mm");
    px = 0.5 * (diam[0] / (2 * r_med[0]) + diam[1] / (2 * r_med[1]));
  }
  return px;
}

using DepthFits = std::array<std::array<std::optional<DepthMotion>, 2>, 2>;

// The line of centres' z part at the instant t_c from the two spheres'
// depths: (z_1 - z_2) / D, each side's fits weighted by their variance.
std::optional<Measured> lineOfCentresZFromSize(const DepthFits& depth, double t_split, double t_c,
                                               double contact_m) {
  double w_sum = 0, wz_sum = 0;
  for (int side = 0; side < 2; ++side) {
    if (!depth[0][side] || !depth[1][side]) continue;
    const DepthMotion &a = *depth[0][side], &b = *depth[1][side];
    const double dt = t_c - t_split;
    const double dz = (a.dz0_m + a.vz_m_s * dt) - (b.dz0_m + b.vz_m_s * dt);
    const double sa = depthResidualScale(a), sb = depthResidualScale(b);
    const double var = std::pow(sa * a.dz0_sigma_m, 2) + std::pow(sa * a.vz_sigma_m_s * dt, 2) +
                       std::pow(sb * b.dz0_sigma_m, 2) + std::pow(sb * b.vz_sigma_m_s * dt, 2);
    if (!(var > 0)) continue;
    w_sum += 1 / var;
    wz_sum += dz / var;
  }
  if (!(w_sum > 0)) return std::nullopt;
  return Measured{wz_sum / w_sum / contact_m, 1 / std::sqrt(w_sum) / contact_m};
}

// What the apparent sizes tell the Monte Carlo. A radius bias that changes
// by radius_systematic_px over a track (the lit part of the limb seen from a
// changing angle) moves v_z by Z0 sigma_r / (r T); the two spheres' biases
// may differ by as much, which moves the line of centres' z part by
// Z0 sigma_r / (r D). The measured v_z before impact replaces the prior
// out_of_plane_speed_fraction, the size-measured n_z the prior
// line_of_centres_z_sigma; the depths' uncertainties (position on the wrong
// plane: v dz / Z0, x dv_z / Z0 from the optical axis, and the track's
// bending, below) move each fit's velocity along those directions
// (ShotModel::depth), the rate error together with v_z's.
void useDepths(ShotModel& model, const DepthFits& depth, const std::optional<Measured>& nz_size,
               const CollisionFits& fits, const AnalysisSettings& set,
               const std::array<double, 2>& r_med) {
  const double z0 = set.camera_distance_m > 0 ? set.camera_distance_m
                                              : (set.camera ? set.camera->centre_m.z() : 0);
  if (!(z0 > 0)) return;
  const double sys_px = std::max(0.0, set.radius_systematic_px);
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side) {
      const auto& d = depth[s][side];
      if (!d) continue;
      const TrajectoryFit& f = fits.fit[s][side]->fit;
      const double sc = depthResidualScale(*d), s_vz = d->vz_sigma_m_s;
      if (side == 0) {
        // Combined with the prior N(0, (fraction x speed)^2) the rig's alignment gives.
        const double sp = model.vz_fraction * f.velocityAt_m_s(f.tRef_s()).value.norm();
        const double w = sp > 0 ? sp * sp / (sp * sp + s_vz * s_vz) : 0.0;
        model.vz_before[s] = std::array<double, 2>{w * d->vz_m_s, std::sqrt(w) * s_vz};
        model.vz_before_shared[s] = w * s_vz;  // the depth fit's own rate error, weighted
      }
      Eigen::Vector2d x(f.coefficients(0)[0], f.coefficients(1)[0]);
      Eigen::Vector2d v(f.coefficients(0)[1], f.coefficients(1)[1]);
      if (set.camera) x -= set.camera->centre_m.head<2>();
      // A centre on the wrong plane is off by -x (t) dz (t) / Z0 (z towards
      // the camera), with x (t) = x + v tau and dz (t) = dz + dv_z tau about
      // the fit's reference instant: a velocity error -(x dv_z + v dz) / Z0,
      // and a tau^2 term -v dv_z / Z0 that a fit with gravity fixed takes into
      // its velocity as -v dv_z (tau_first + tau_last) / Z0 (the slope of tau^2
      // over the track): the track bends.
      const double bend = f.tFirst_s() + f.tLast_s() - 2 * f.tRef_s();
      model.depth[s][side].per_rate = -(x + v * bend) * s_vz / z0;
      model.depth[s][side].per_offset = -v * sc * d->dz0_sigma_m / z0;
    }
  if (nz_size) {
    const double r = 0.5 * (r_med[0] + r_med[1]);
    // Combined with the prior N(0, line_of_centres_z_sigma^2) of the rig's alignment.
    const double sm = std::hypot(nz_size->sigma, z0 * sys_px / (r * model.contact));
    const double sp = std::max(model.nz_sigma, 1e-6), w = sp * sp / (sp * sp + sm * sm);
    model.nz_mean = w * nz_size->value;
    model.nz_sigma = std::sqrt(w) * sm;
  }
}

// Each depth fit's v_z sigma made whole: its residual scale, and a radius
// bias that changes by radius_systematic_px over the track (the lit part of
// the limb seen from a changing angle: Z0 sigma_r / (r T)); then the four v_z
// held to momentum conservation along z (analysis/depth_from_size.hpp).
void completeDepths(DepthFits& depth, const CollisionFits& fits, const AnalysisSettings& set,
                    const std::array<double, 2>& r_med, const std::array<double, 2>& mass) {
  const double z0 = set.camera_distance_m > 0 ? set.camera_distance_m
                                              : (set.camera ? set.camera->centre_m.z() : 0);
  if (!(z0 > 0)) return;
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side) {
      auto& d = depth[s][side];
      if (!d) continue;
      const TrajectoryFit& f = fits.fit[s][side]->fit;
      completeDepthSigmas(*d, z0, r_med[s], f.tLast_s() - f.tFirst_s(), set.radius_systematic_px);
    }
  if (!depth[0][0] || !depth[0][1] || !depth[1][0] || !depth[1][1]) return;
  std::array<double, 4> vz, sigma;
  for (int i = 0; i < 4; ++i) {
    vz[i] = depth[i / 2][i % 2]->vz_m_s;
    sigma[i] = depth[i / 2][i % 2]->vz_sigma_m_s;
  }
  conserveMomentumZ(vz, sigma, mass);
  for (int i = 0; i < 4; ++i) {
    depth[i / 2][i % 2]->vz_m_s = vz[i];
    depth[i / 2][i % 2]->vz_sigma_m_s = sigma[i];
  }
}

double massOf(const AnalysisSettings& set, int s) {
  const double d = set.diameter_m[s];
  return set.mass_kg[s] > 0 ? set.mass_kg[s] : 1000.0 * std::numbers::pi / 6 * d * d * d;
}

// |v_n| before and after: the fits' relative velocity along the centres'
// separation at their own contact instants, m/s (0 where undefined).
std::array<double, 2> normalSpeedsAtInstants(const CollisionFits& fits) {
  std::array<double, 2> vn{0, 0};
  for (int side = 0; side < 2; ++side) {
    const double t = side == 0 ? fits.t_before : fits.t_after;
    const PlaneTrack a = nominalTrack(fits.fit[0][side]->fit);
    const PlaneTrack b = nominalTrack(fits.fit[1][side]->fit);
    const Eigen::Vector2d dr = a.pos(t) - b.pos(t), dv = a.vel(t) - b.vel(t);
    if (dr.norm() > 0) vn[side] = std::abs(dr.dot(dv)) / dr.norm();
  }
  return vn;
}

// Collision instant: where the pre- and the post-impact fits are one contact
// distance apart, and where each sphere's two fits meet, weighed by
// generalised least squares (analysis/shot_uncertainty.hpp, instantWeights),
// at the instant the first two give by their uncertainties (with the
// contact distance's, which moves them in opposite directions). Each
// sphere's position at contact from both its fits (contactPositionWeights).
void useInstants(ShotModel& in, const CollisionFits& fits) {
  in.contact_reached = fits.contact_reached;
  const std::array<double, 2> vn = normalSpeedsAtInstants(fits);
  in.w_before =
      beforeInstantWeight(fits.sigma_before, fits.sigma_after, in.contact_sigma, vn[0], vn[1]);
  in.t_before = fits.t_before;
  in.t_after = fits.t_after;
  const double t_c = in.w_before * in.t_before + (1 - in.w_before) * in.t_after;
  const InstantWeights w = instantWeights(in, t_c);
  in.w_before = w.before;
  in.w_kink = w.kink;
  in.w_position_before = contactPositionWeights(in, t_c);
}

// The contact distance's standard uncertainty (m): the profile's
// contact_distance_sigma_px at the shot's pixel size.
double contactSigma_m(const AnalysisSettings& set, double px) {
  return std::max(0.0, set.contact_distance_sigma_px) * px;
}

// The centre offset per track that motion blur adds to sphere s (px, per
// axis; AnalysisSettings::blur_offset_*): from its faster track's smear.
double blurOffsetPx(const AnalysisSettings& set, const CollisionFits& fits, int s,
                    double exposure_s, double px) {
  if (!(set.blur_offset_per_px2 > 0) || !(exposure_s > 0) || !(px > 0)) return 0.0;
  double smear = 0;
  for (int side = 0; side < 2; ++side)
    smear = std::max(smear, smearPx(fits.fit[s][side]->fit, exposure_s, px));
  const double beyond = std::max(0.0, smear - set.blur_offset_onset_px);
  return set.blur_offset_per_px2 * beyond * beyond;
}

// The Monte Carlo's inputs: fits, their inflation and systematics, spins, the priors.
ShotModel shotModel(const AnalysisSettings& set, const CollisionFits& fits, const ShotSpins& spins,
                    const std::array<double, 2>& r_med, double px, double exposure_s, bool dark) {
  ShotModel in;
  const std::array<double, 2>& diam = set.diameter_m;
  in.contact = 0.5 * (diam[0] + diam[1]);
  in.contact_sigma = contactSigma_m(set, px);
  in.nz_sigma = set.line_of_centres_z_sigma;
  in.vz_fraction = std::max(0.0, set.out_of_plane_speed_fraction);
  in.diameter = diam;
  for (int s = 0; s < 2; ++s) in.mass[s] = massOf(set, s);
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side) {
      const SideFit& sf = *fits.fit[s][side];
      in.fit[s][side] = &sf.fit;
      in.inflation[s][side] = sf.inflation;
      in.spin[s][side] = spins.side[s][side].spin;
      in.spin_cov[s][side] = spins.side[s][side].cov;
    }
  // The dots' slow pull on the outline and, under a lens, the lamp's
  // (vision/shot_fits.hpp); each track's centre offset: the dots' and the
  // profile's centre_offset_px.
  for (int s = 0; s < 2; ++s) {
    const auto& sides = spins.side[s];
    const bool dots_seen = !(sides[0].unknown_reason && sides[1].unknown_reason);
    for (int side = 0; side < 2; ++side) {
      const TrajectoryFit& f = fits.fit[s][side]->fit;
      double dots = 0;
      if (dots_seen) {
        const double bias_m = dotBias_m(f, r_med[s], px, exposure_s, dark);
        const double span = f.tLast_s() - f.tFirst_s();
        dots = span > 0 ? bias_m / span : 0.0;
        in.offset[s] = std::max(in.offset[s], bias_m);
      }
      in.drift[s][side] =
          centreDriftSigma_m_s(f, dots, set.camera.has_value(), set.radius_systematic_px, px);
    }
    const double profile_px =
        std::hypot(std::max(0.0, set.centre_offset_px), blurOffsetPx(set, fits, s, exposure_s, px));
    in.offset[s] = std::hypot(in.offset[s], profile_px * px);
  }
  useInstants(in, fits);
  return in;
}

// What the two collision instants may differ by without anything being wrong
// (analysis/contact.hpp): the fits' errors and the centres' systematic drifts
// (the Monte Carlo's spread of the difference, residual inflation included),
// the contact distance's uncertainty (the detector's radius error, which
// moves the two instants apart by dd (1/|v_n| + 1/|v_n'|)), and a contact of
// finite duration (the post-impact instant later by up to it).
InstantAgreement instantAgreement(const CollisionFits& fits, const ShotUncertainty& u,
                                  const AnalysisSettings& set, double pixel_m) {
  const double vb = fits.sigma_before * fits.sigma_before, va = fits.sigma_after * fits.sigma_after;
  const double sd_ba = u.dt_ba.sigma();
  InstantAgreementModel am;
  am.fit_sigma_s = std::isfinite(sd_ba) ? sd_ba : std::sqrt(vb + va);
  am.contact_distance_sigma_m = 2 * std::max(0.0, set.radius_systematic_px) * pixel_m;
  const WaltonMeasurement& m = u.nominal.inverse.m;
  am.vn_before_m_s = std::abs(m.before.v_n_m_s);
  am.vn_after_m_s = std::abs(m.after.v_n_m_s);
  am.contact_duration_s = set.contact_duration_s;
  return compareInstants(fits.t_before, fits.t_after, am);
}

void fillKinematics(ShotAnalysis& out, const ShotUncertainty& u, const CollisionFits& fits,
                    const ShotSpins& spins, double vz_fraction, const InstantAgreement& ag) {
  const ShotDraw& nominal = u.nominal;
  const WaltonMeasurement& m = nominal.inverse.m;
  CollisionProperties& c = out.collision;
  c.e = {m.e, u.e.sigma()};
  c.beta_from_spins = {m.beta, u.beta.sigma()};
  c.beta_from_impulse = {m.beta_from_impulse, u.beta_from_impulse.sigma()};
  // The two as one estimate (betaSpinWeight): where the spins after the
  // impact are poorly measured, beta rests on the impulse.
  const double w = betaSpinWeight(u);
  c.beta_spin_weight = w;
  c.beta = {w < 1 ? w * m.beta + (1 - w) * m.beta_from_impulse : m.beta, combinedBetaSigma(u, w)};
  c.f = {m.f, u.f.sigma()};
  c.gamma_deg = {m.before.gamma_rad * 180 / std::numbers::pi, u.gamma_deg.sigma()};
  c.vn_m_s = {m.before.v_n_m_s, u.vn.sigma()};
  c.vs_m_s = {m.before.v_s_m_s, u.vs.sigma()};
  c.vs_after_m_s = {nominal.inverse.vs_after, u.vs_after.sigma()};
  // The two instants' disagreement beyond what they may differ by (more than
  // one sigma of it outside the allowed band) is an error of one of them that
  // nothing here explains; the combined instant, between the two, may be off
  // by about half of it: added to t_c's sigma.
  const double unexplained_s = std::max(0.0, ag.outside_s - ag.sigma_s);
  c.t_collision_s = {nominal.t_c, std::hypot(u.t_c.sigma(), 0.5 * unexplained_s)};
  c.line_of_centres_z = {nominal.inverse.n_z, u.n_z.sigma()};
  c.kinetic_energy_change_J = {nominal.inverse.kinetic_energy_change_J,
                               u.kinetic_energy_change.sigma()};
  c.t_collision_before_s = fits.t_before;
  c.t_collision_after_s = fits.t_after;
  for (int s = 0; s < 2; ++s) {
    SphereKinematics& kin = out.sphere[s];
    for (int side = 0; side < 2; ++side) {
      const SideSpin& sp = spins.side[s][side];
      (side == 0 ? kin.spin_before_rad_s : kin.spin_after_rad_s) = {sp.spin, sp.sigma};
      (side == 0 ? kin.frames_before : kin.frames_after) =
          static_cast<int>(fits.fit[s][side]->frames.size());
      out.trajectory[s][side] = fits.fit[s][side]->fit;
    }
    kin.spin_before_prior_directions = spins.side[s][0].prior_directions;
    kin.velocity_before_m_s.value = nominal.v_before[s];
    kin.velocity_after_m_s.value = nominal.v_after[s];
    for (int k = 0; k < 3; ++k) {
      kin.velocity_before_m_s.sigma[k] = u.v_before[s][k].sigma();
      kin.velocity_after_m_s.sigma[k] = u.v_after[s][k].sigma();
    }
    // In the image plane by assumption, within out_of_plane_speed_fraction of the speed.
    kin.velocity_before_m_s.sigma.z() = vz_fraction * nominal.v_before[s].norm();
  }
}

void fillFrames(ShotAnalysis& out, const Burst& burst, const std::vector<FrameData>& data,
                const ShotSpins& spins) {
  out.frames.resize(data.size());
  for (std::size_t k = 0; k < data.size(); ++k) {
    FrameDetections& fd = out.frames[k];
    const Frame& fr = burst.frames[data[k].index];
    fd.frame_id = fr.id;
    fd.t_s = data[k].t;
    fd.notes = data[k].found.notes;
    if (data[k].found.saturated) fd.notes.push_back("saturated");
    for (int s = 0; s < 2; ++s) {
      const SphereMeasurement* m = trackAt(data[k], s);
      if (!m) continue;
      SphereDetection det;
      det.u_px = m->circle.u;
      det.v_px = m->circle.v;
      det.radius_px = m->circle.radius;
      det.sigma_px = std::max(m->circle.sigma_u, m->circle.sigma_v);
      det.cut_by_border = m->cut_by_border;
      det.touching = m->touching;
      fd.sphere[s] = det;
      for (const Dot& d : spins.dots[k][s].dots)
        fd.dots[s].push_back({d.u_px, d.v_px, d.on_sphere});
    }
  }
}

// A track's apparent radii (px), their sigmas and times, with the radius
// the lens gives a sphere in the collision plane at each frame's place (px):
// outlines cut by the border or merged with the other sphere's are left out
// (their radii are not the sphere's). With the lens known, each frame's
// radius is compared with what the lens makes of the sphere at that place on
// the collision plane (off-axis growth, distortion); without it, with the
// sphere's radius over the pixel size.
struct TrackRadii {
  std::vector<double> t, r, sr, r0;
};
TrackRadii trackRadiiOf(const std::vector<FrameData>& data, const SideFit& fit, int s,
                        const AnalysisSettings& set, const PixelScale& scale) {
  TrackRadii tr;
  const double radius_m = 0.5 * set.diameter_m[s];
  for (const int k : fit.frames) {
    const SphereMeasurement& m = *trackAt(data[k], s);
    if (m.cut_by_border || m.touching) continue;
    const double plane_r = set.camera ? planeRadiusPx(*set.camera, m.circle.u, m.circle.v, radius_m)
                                      : radius_m / scale.px;
    if (!std::isfinite(plane_r)) continue;
    tr.t.push_back(data[k].t);
    tr.r.push_back(m.circle.radius);
    tr.sr.push_back(std::max(m.circle.sigma_radius, 1e-3));
    tr.r0.push_back(plane_r);
  }
  return tr;
}

// Each track's depth (towards the camera) from its apparent radius, when the
// camera's distance is known (trackRadiiOf's frames).
DepthFits measureDepthMotion(std::vector<std::string>* notes, const std::vector<FrameData>& data,
                             const CollisionFits& fits, const AnalysisSettings& set,
                             const PixelScale& scale) {
  DepthFits depth;
  const double distance = set.camera_distance_m > 0 ? set.camera_distance_m
                                                    : (set.camera ? set.camera->centre_m.z() : 0);
  if (!(distance > 0)) return depth;
  const auto vec = [](const std::vector<double>& v) {
    return Eigen::Map<const Eigen::VectorXd>(v.data(), Eigen::Index(v.size())).eval();
  };
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side) {
      const TrackRadii tr = trackRadiiOf(data, *fits.fit[s][side], s, set, scale);
      if (tr.t.size() < 3) continue;
      auto dm =
          fitDepthMotion(vec(tr.t), vec(tr.r), vec(tr.sr), vec(tr.r0), distance, fits.t_split);
      if (!dm) {
        if (notes)
          notes->push_back("sphere " + std::to_string(s + 1) +
                           ": no velocity from the apparent size: " + dm.error().message);
        continue;
      }
      depth[s][side] = *dm;
    }
  return depth;
}

// How much the outlines' radii scatter from frame to frame in this footage,
// px: the robust spread of each track's radii (less the lens' radius at each
// place) about a straight line in time (a steady drift in depth), pooled over
// the tracks of at least 5 frames; NaN with none.
double radiusScatterPx(const std::vector<FrameData>& data, const CollisionFits& fits,
                       const AnalysisSettings& set, const PixelScale& scale) {
  std::vector<double> pooled;
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side) {
      const TrackRadii tr = trackRadiiOf(data, *fits.fit[s][side], s, set, scale);
      const std::size_t n = tr.t.size();
      if (n < 5) continue;
      double mt = 0, my = 0;
      for (std::size_t i = 0; i < n; ++i) mt += tr.t[i], my += tr.r[i] - tr.r0[i];
      mt /= n, my /= n;
      double stt = 0, sty = 0;
      for (std::size_t i = 0; i < n; ++i)
        stt += (tr.t[i] - mt) * (tr.t[i] - mt), sty += (tr.t[i] - mt) * (tr.r[i] - tr.r0[i] - my);
      const double slope = stt > 0 ? sty / stt : 0.0;
      const double dof = std::sqrt(static_cast<double>(n) / (n - 2));  // two parameters fitted
      for (std::size_t i = 0; i < n; ++i)
        pooled.push_back(dof * std::abs(tr.r[i] - tr.r0[i] - my - slope * (tr.t[i] - mt)));
    }
  return 1.4826 * median(std::move(pooled));  // NaN with none
}

// The radius bias' change along a track this shot is analysed with: the rig
// profile's radius_systematic_px, or, where this footage's outlines scatter
// more from frame to frame, kRadiusSystematicPerScatter times that scatter.
// Noise that hides the edge from frame to frame also biases it, and that
// bias changes as the track crosses the field: against the truth
// (accuracy_bench --detector-bias, 20 shots each) the change along a track
// beyond the frames' scatter was 0.66-0.71 times the scatter the analysis
// measures on a 4000 e- sensor (0.21 px, outlines scattering by 0.32 px,
// where the profile said 0.05) and on an 8-bit ADC, 0.4-0.8 times it on eight
// other imagings. Blur and lenses bias the edge without scattering it
// (1.3-2.0 times on a 400 us exposure, a grey backdrop, a strong lens):
// there only the profile's measured value covers it. Says so in a note when
// it raises the profile's value.
constexpr double kRadiusSystematicPerScatter = 0.75;
AnalysisSettings withRadiusScatter(const AnalysisSettings& set, const std::vector<FrameData>& data,
                                   const CollisionFits& fits, const PixelScale& scale,
                                   ShotAnalysis& out) {
  AnalysisSettings shot = set;
  const double scatter = radiusScatterPx(data, fits, set, scale);
  out.radius_scatter_px = scatter;
  const double floor = std::max(0.0, set.radius_systematic_px);
  if (std::isfinite(scatter) && kRadiusSystematicPerScatter * scatter > floor) {
    shot.radius_systematic_px = kRadiusSystematicPerScatter * scatter;
    out.notes.push_back("the outlines' radii scatter by " + fmt("%.3f", scatter) +
                        " px from frame to frame, so their bias is taken to change by up to " +
                        fmt("%.3f", shot.radius_systematic_px) +
                        " px along a track (the profile's radius_systematic_px says " +
                        fmt("%.3f", floor) + "): the sigmas carry it");
  }
  out.radius_systematic_px = shot.radius_systematic_px;
  return shot;
}

// Each sphere's post-impact depth line held to the v_z after the impact the
// inverse found from the impulse (appendix B: v_z before plus dP_z / m, from
// the spin changes and the line of centres; its spread over the draws), where
// both of the sphere's lines were measured. The size alone gets it wrong where
// the lit part of the limb changes along the track (accuracy_bench lab:
// 0.19 m/s for a true 0.11, and the in-plane velocity 0.6 % off with it).
// False when no line changed.
bool holdDepthsToImpulse(DepthFits& depth, const ShotUncertainty& u, double t_split) {
  bool any = false;
  for (int s = 0; s < 2; ++s) {
    if (!depth[s][0] || !depth[s][1]) continue;
    const double vz = u.nominal.v_after[s].z(), sigma = u.v_after[s][2].sigma();
    if (!std::isfinite(vz) || !(sigma > 0)) continue;
    holdDepthToImpulse(*depth[s][1], *depth[s][0], vz, sigma, u.nominal.t_c, t_split);
    any = true;
  }
  return any;
}

// Each sphere's depth over time for the lens' back-projection: the
// pre-impact depth line before t_split, the post-impact one after (either
// when only one was measured). False when no sphere has one.
bool setDepths(PixelScale& scale, const DepthFits& depth, double t_split) {
  bool any = false;
  for (int s = 0; s < 2; ++s) {
    const std::optional<DepthMotion> before = depth[s][0] ? depth[s][0] : depth[s][1];
    const std::optional<DepthMotion> after = depth[s][1] ? depth[s][1] : depth[s][0];
    if (!before) continue;
    any = true;
    scale.depth_m[s] = [b = *before, a = *after, t_split](double t) {
      const DepthMotion& d = t < t_split ? b : a;
      return d.dz0_m + d.vz_m_s * (t - t_split);
    };
  }
  return any;
}

// What the flags are computed from, besides the result itself.
struct FlagInputs {
  const AnalysisSettings* settings = nullptr;
  const Burst* burst = nullptr;
  const BurstFrames* frames = nullptr;
  const CollisionFits* fits = nullptr;
  const ShotUncertainty* u = nullptr;
  const InstantAgreement* instants = nullptr;  ///< the two collision instants judged
  std::array<double, 2> r_med{0, 0};
  PixelScale scale;
  Eigen::Vector2d gdir{0, 1};
  double contact = 0;
  int saturated = 0, third_blobs = 0;
};

// The two instants disagree beyond what the measurement and the model allow
// (instantAgreement).
void flagInstants(ShotAnalysis& out, const FlagInputs& q) {
  const InstantAgreement& ag = *q.instants;
  if (!ag.disagree) return;
  addFlag(out, "collision_instant_disagree");
  out.notes.push_back(
      "the post-impact fits put the contact " + fmt("%+.1f", ag.difference_s * 1e6) +
      " us after the pre-impact ones, outside 0 to " +
      fmt("%.0f", q.settings->contact_duration_s * 1e6) + " us (the contact's duration) by " +
      fmt("%.1f", ag.excess_sigmas) + " sigma of " + fmt("%.1f", ag.sigma_s * 1e6) + " us");
}

// Angular momentum about the contact point (spinImpulseDisagreement): a
// spin or velocity is wrong (a dot taken for another, a track through the
// wrong blob). Where a spin was not measured beta is NaN
// (withoutUnmeasuredSpins), and nothing is compared.
void flagSpinImpulse(ShotAnalysis& out, const FlagInputs& q) {
  const CollisionProperties& c = out.collision;
  const auto why = spinImpulseDisagreement(c.beta_from_spins.value, c.beta_from_impulse.value,
                                           q.u->beta_spin_minus_impulse.sigma());
  if (!why) return;
  addFlag(out, "spin_impulse_disagree");
  out.notes.push_back(*why);
}

// A spin not measured gives no beta: reported unavailable (NaN, null in the
// JSON), never guessed from the 0 +- 50 rad/s the Monte Carlo draws it from
// (issue 13: a silhouette shows no spin), as the wall analysis does. gamma,
// v_s and f, which the spins before only shift, keep that prior's width.
void withoutUnmeasuredSpins(CollisionProperties& c, const ShotSpins& spins) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  bool before = true, after = true;
  for (int s = 0; s < 2; ++s) {
    before = before && !spins.side[s][0].unknown_reason;
    after = after && !spins.side[s][1].unknown_reason;
  }
  if (!before || !after) c.beta = c.beta_from_spins = {kNaN, kNaN};
  if (!after) c.vs_after_m_s = {kNaN, kNaN};
  if (!before) c.beta_from_impulse = {kNaN, kNaN};
}

// Values physics forbids, beyond their uncertainty.
void flagUnphysical(ShotAnalysis& out) {
  const CollisionProperties& c = out.collision;
  const auto found =
      unphysicalFindings({c.e.value, c.e.sigma}, {c.beta.value, c.beta.sigma},
                         {c.kinetic_energy_change_J.value, c.kinetic_energy_change_J.sigma});
  if (found.empty()) return;
  addFlag(out, "unphysical");
  for (const std::string& s : found) out.notes.push_back(s);
}

// Track residuals against the detector's own uncertainty, and SPEC eq. 5.1
// with the centre scatter actually seen: can |v_n| and v_s be told here?
void flagTracks(ShotAnalysis& out, const FlagInputs& q) {
  const CollisionFits& fits = *q.fits;
  const double px = q.scale.px;
  double resid_px = 0;
  std::vector<double> det_sigma;
  for (const FrameData& fd : q.frames->data)
    for (int s = 0; s < 2; ++s)
      if (const SphereMeasurement* m = trackAt(fd, s))
        det_sigma.push_back(std::max(m->circle.sigma_u, m->circle.sigma_v));
  // Weighted residual RMS (frames weighted by their detection uncertainty, as
  // in the fits), in pixels: poorly measured frames at the border count less.
  // Scatter beyond the detector's word only widens the fits' sigmas (their
  // chi^2 scales them): a fast-spinning, motion-blurred sphere's dots move its
  // outline by 0.2-0.3 px from frame to frame. What cannot be trusted is a
  // track whose large residuals have order (a bend, an alternating offset;
  // residual_structure.hpp), or that scatters by more than a pixel.
  const double large_px = std::max(0.1, 10 * median(det_sigma));
  bool misfit = false;
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side)
      for (int k = 0; k < 2; ++k) {
        const LinearFit& af = fits.fit[s][side]->fit.axisFit(k);
        const double rms_px = std::sqrt(af.chi2 / af.weights.sum()) / px;
        resid_px = std::max(resid_px, rms_px);
        misfit = misfit || (rms_px > large_px && (rms_px > 1.0 || residualsStructured(af)));
      }
  if (misfit) addFlag(out, "large_residuals");
  ImagingGeometry g;
  g.position_sigma_px = std::max(resid_px, 0.01);
  g.pixels_per_diameter = 2 * 0.5 * (q.r_med[0] + q.r_med[1]);
  g.diameter_m = q.contact;
  g.frame_interval_s = q.frames->frame_dt;
  g.frames_per_side = std::min({out.sphere[0].frames_before, out.sphere[0].frames_after,
                                out.sphere[1].frames_before, out.sphere[1].frames_after});
  const CollisionProperties& c = out.collision;
  // e also when v_n's own sigma (the Monte Carlo's: the line of centres'
  // direction from the instant included, which eq. 5.1 leaves out) is more
  // than 5 % of it: a nearly grazing impact.
  if (relativeVelocityError(g, c.vn_m_s.value) > 0.05 ||
      !(c.vn_m_s.sigma <= 0.05 * std::abs(c.vn_m_s.value)))
    addFlag(out, "e_untrustworthy_geometry");
  if (relativeVelocityError(g, c.vs_m_s.value) > 0.05) addFlag(out, "beta_untrustworthy_geometry");
}

// What the burst itself says: saturated frames, blobs set aside, frames lost.
void flagBurst(ShotAnalysis& out, const FlagInputs& q) {
  if (q.saturated > 0) {
    addFlag(out, "saturated_frames");
    out.notes.push_back(std::to_string(q.saturated) +
                        " frame(s) mostly at full scale: lower the exposure or the gain");
  }
  if (q.third_blobs > 0) {
    addFlag(out, "extra_blobs_ignored");
    out.notes.push_back(std::to_string(q.third_blobs) +
                        " round blob(s) that are not this shot's spheres were ignored (see the "
                        "frames' notes)");
  }
  const Burst& burst = *q.burst;
  const std::size_t good = q.frames->good.size();
  if (good < burst.frames.size() || burst.stats.dropped > 0) {
    addFlag(out, "frames_lost");
    out.notes.push_back(std::to_string(burst.frames.size() - good) +
                        " frame(s) failed or incomplete, " + std::to_string(burst.stats.dropped) +
                        " dropped: the fits used the rest");
  }
}

// Gravity as a check of the scale and the clock: a free fit's acceleration
// along gravity should be g.
void flagGravity(ShotAnalysis& out, const FlagInputs& q) {
  const auto fall = fallAlongGravity(q.frames->data, *q.fits, q.scale, q.gdir);
  if (!fall) return;
  const double a = (*fall)[0], sa = (*fall)[1];
  if (std::abs(a - kG) > std::max(0.1 * kG, 5 * sa) && sa < 0.05 * kG) {
    addFlag(out, "gravity_scale_mismatch");
    out.notes.push_back("the spheres fall at " + fmt("%.2f", a) +
                        " m/s^2 along gravity instead of 9.81: the pixel size, a diameter or "
                        "the frame rate is probably wrong");
  }
}

// A measured spin no better known than an unmeasured one (simulated
// thesis-like shots: 130-480 rad/s sigma against at most 22 on every other
// shot): beta and gamma rest on the contact point's velocity. Before the
// impact the launchers' spread stands in where the dots pin a direction less
// well than it (measureSpins); a note says so. After it nothing bounds the
// spin, though beta then leans on the impulse (betaSpinWeight).
void flagPoorSpins(ShotAnalysis& out, const ShotSpins& spins, double launch_spin_rad_s) {
  for (int s = 0; s < 2; ++s)
    if (const int n = spins.side[s][0].prior_directions; n > 0)
      out.notes.push_back("sphere " + std::to_string(s + 1) + ", before the impact: its dots pin " +
                          std::to_string(n) + " of the spin's 3 directions less well than the " +
                          "launchers' spread (launch_spin_rad_s " + fmt("%.1f", launch_spin_rad_s) +
                          " rad/s), which was combined with them there");
  const std::vector<std::string> notes = poorlyMeasuredSpins(spins);
  if (notes.empty()) return;
  addFlag(out, "spin_poorly_measured");
  out.notes.insert(out.notes.end(), notes.begin(), notes.end());
}

void addQualityFlags(ShotAnalysis& out, const FlagInputs& q) {
  for (int s = 0; s < 2; ++s) {
    if (out.sphere[s].frames_before < 5) addFlag(out, "few_frames_before");
    if (out.sphere[s].frames_after < 5) addFlag(out, "few_frames_after");
  }
  flagInstants(out, q);
  flagUnphysical(out);
  flagSpinImpulse(out, q);
  flagTracks(out, q);
  flagBurst(out, q);
  flagGravity(out, q);
}

// What every pass of the inverse shares: the settings, the spins, the frames.
struct InverseInputs {
  const AnalysisSettings& set;
  const ShotSpins& spins;
  std::array<double, 2> r_med;
  double px, exposure_s;
  bool dark;
  double contact, contact_sigma;  ///< m
  const std::vector<FrameData>& data;
  FreeFlight flight;
  double frame_dt;
};

// One pass of Walton's inverse and its spread over draws of every fitted
// input, on given fits and depths (and the scale that placed the centres).
struct InversePass {
  CollisionFits fits;
  DepthFits depth;
  PixelScale scale;
  ShotModel model;
  ShotUncertainty u;
  std::optional<Measured> nz_size;
};
// The fits follow the centres' images, which touch at the contact distance's
// in-plane part (analysis/contact.hpp): both instants found again there, with
// n_z as the model knows it before the inverse (the sizes and the rig's
// prior), and the contact distance's sigma widened by what n_z's own
// uncertainty leaves in it (d |n_z| sigma, and d sigma^2 / sqrt 2 about 0).
void touchInPlane(InversePass& p, const InverseInputs& in) {
  const double m = p.model.nz_mean, s = p.model.nz_sigma;
  const double d = inPlaneContactDistance(in.contact, m, s);
  if (!(d < in.contact) || !findInstants(p.fits, d, p.model.contact_sigma)) return;
  p.model.contact = d;
  p.model.contact_sigma = std::hypot(p.model.contact_sigma, in.contact * std::abs(m) * s,
                                     in.contact * s * s / std::numbers::sqrt2);
  useInstants(p.model, p.fits);
}

InversePass inversePass(const InverseInputs& in, CollisionFits fits, DepthFits depth,
                        PixelScale scale) {
  InversePass p{std::move(fits), std::move(depth), std::move(scale), {}, {}, {}};
  p.model = shotModel(in.set, p.fits, in.spins, in.r_med, in.px, in.exposure_s, in.dark);
  const double t_c0 = p.model.w_before * p.fits.t_before + (1 - p.model.w_before) * p.fits.t_after;
  p.nz_size = lineOfCentresZFromSize(p.depth, p.fits.t_split, t_c0, in.contact);
  useDepths(p.model, p.depth, p.nz_size, p.fits, in.set, in.r_med);
  touchInPlane(p, in);
  p.u = propagateShot(p.model);
  return p;
}

// The pass' Monte Carlo inputs pointing at its own fits: the model was built
// on the fits where the pass was made, and the pass has been moved since.
ShotModel boundModel(const InversePass& p) {
  ShotModel m = p.model;
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side) m.fit[s][side] = &p.fits.fit[s][side]->fit;
  return m;
}

// With the lens, the post-impact depths held to the v_z the impulse gives
// (the first pass' inverse, appendix B), and the fits and the inverse again.
// The first pass stands when there is nothing to hold or the second fails.
InversePass withHeldDepths(const InverseInputs& in, InversePass first) {
  if (!first.u.nominal.ok || !in.set.camera) return first;
  DepthFits held = first.depth;
  if (!holdDepthsToImpulse(held, first.u, first.fits.t_split)) return first;
  PixelScale held_scale = first.scale;
  setDepths(held_scale, held, first.fits.t_split);
  auto refit = fitCollision(in.data, held_scale, in.contact, in.contact_sigma, in.flight,
                            in.exposure_s, in.frame_dt);
  if (!refit) return first;
  InversePass second = inversePass(in, std::move(*refit), std::move(held), std::move(held_scale));
  return second.u.nominal.ok ? second : first;
}

// The spheres' depth motion from their apparent sizes, into `out` (v_z per
// sphere and side, notes). With a lens whose depths change the centres' places
// (setDepths), `refit` fits the trajectories again into `fits` and the depths
// are measured again on them.
Result<DepthFits> fitDepths(ShotAnalysis& out, const std::vector<FrameData>& data,
                            CollisionFits& fits, PixelScale& scale, const AnalysisSettings& set,
                            const std::array<double, 2>& r_med,
                            const std::function<Result<CollisionFits>()>& refit) {
  const std::array<double, 2> mass{massOf(set, 0), massOf(set, 1)};
  DepthFits depth = measureDepthMotion(&out.notes, data, fits, set, scale);
  completeDepths(depth, fits, set, r_med, mass);
  if (set.camera && setDepths(scale, depth, fits.t_split)) {
    auto again = refit();
    if (!again) return again.error();
    fits = std::move(*again);
    depth = measureDepthMotion(nullptr, data, fits, set, scale);  // notes given above
    completeDepths(depth, fits, set, r_med, mass);
  }
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side)
      if (const auto& d = depth[s][side])
        out.sphere[s].vz_from_size_m_s[side] = Measured{d->vz_m_s, d->vz_sigma_m_s};
  return depth;
}

// Gravity along the image's gravity direction, known or fitted; with it
// known, each sphere's air drag where its mass is given (without the mass the
// drag's size is unknown: a vacuum).
FreeFlight freeFlight(const AnalysisSettings& set, const Vec3& gravity) {
  FreeFlight f{gravity, set.fix_gravity, {}};
  for (int s = 0; s < 2; ++s)
    if (set.air_density_kg_m3 > 0 && set.mass_kg[s] > 0)
      f.drag[s] = AirDrag{set.diameter_m[s], set.mass_kg[s], set.air_density_kg_m3};
  return f;
}

// no_spin_before / no_spin_after, with a note saying why, per sphere and side.
void flagUnmeasuredSpins(ShotAnalysis& out, const ShotSpins& spins) {
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side)
      if (const auto& why = spins.side[s][side].unknown_reason) {
        addFlag(out, side == 0 ? "no_spin_before" : "no_spin_after");
        out.notes.push_back("sphere " + std::to_string(s + 1) + ", " +
                            (side == 0 ? "before" : "after") + " the impact: " + *why);
      }
}

}  // namespace

Result<ShotAnalysis> analyzeBurst(const Burst& burst, const AnalysisSettings& set) {
  // ---- frames and clock; spheres in every frame; which blobs are spheres; tracks
  auto frames = prepareFrames(burst, set.fps);
  if (!frames) return frames.error();
  std::vector<FrameData>& data = frames->data;
  const std::array<double, 2> diam = set.diameter_m;
  if (!(diam[0] > 0) || !(diam[1] > 0))
    return fail("the sphere diameters must be given and > 0 (got " + fmt("%g", diam[0]) + " and " +
                fmt("%g", diam[1]) + " m)");
  const int saturated = detectSpheres(burst, data, diam, set.pixel_size_m, frames->max_value,
                                      set.progress, set.polarity, set.camera);
  auto blobs = selectSphereBlobs(data, diam, set.pixel_size_m);
  if (!blobs) return blobs.error();
  if (auto st = trackSpheres(data, *blobs, diam); !st) return st.error();
  remeasureCutOutlines(burst, data, diam, set.pixel_size_m, frames->max_value, set.polarity,
                       set.camera);
  const std::array<double, 2> r_med = trackRadii(data);
  const auto px = pixelSize(set, r_med);
  if (!px) return px.error();
  ShotAnalysis out;
  out.pixel_size_m = *px;
  PixelScale scale{*px, set.origin_u_px, set.origin_v_px};
  if (set.camera) {
    scale.camera = set.camera;
    scale.radius_m = {0.5 * diam[0], 0.5 * diam[1]};
  }
  Eigen::Vector2d gdir(set.gravity_dir_image[0], set.gravity_dir_image[1]);
  if (!(gdir.norm() > 0)) return fail("gravity_dir_image must be a non-zero direction");
  gdir.normalize();
  const FreeFlight flight = freeFlight(set, Vec3(kG * gdir.x(), -kG * gdir.y(), 0.0));

  // ---- trajectory fits on each side, the two collision instants
  const double contact = 0.5 * (diam[0] + diam[1]);
  const double contact_sigma = contactSigma_m(set, *px);
  auto fits = fitCollision(data, scale, contact, contact_sigma, flight, burst.exposure_us * 1e-6,
                           frames->frame_dt);
  if (!fits) return fits.error();
  const AnalysisSettings shot_set = withRadiusScatter(set, data, *fits, scale, out);

  // ---- out-of-plane motion from the apparent size (when the camera's distance
  // is known); with the lens, the fits again with each centre at its depth
  auto depth = fitDepths(out, data, *fits, scale, shot_set, r_med, [&] {
    return fitCollision(data, scale, contact, contact_sigma, flight, burst.exposure_us * 1e-6,
                        frames->frame_dt);
  });
  if (!depth) return depth.error();

  // ---- dots and spins, per sphere and side
  const ShotSpins spins = measureSpins(burst, data, *fits, r_med, frames->max_value,
                                       set.unknown_spin_sigma_rad_s, &scale);
  flagUnmeasuredSpins(out, spins);
  flagPoorSpins(out, spins, set.unknown_spin_sigma_rad_s);

  // ---- Walton's inverse, and its spread over draws of every fitted input
  int dark_frames = 0;
  for (const FrameData& f : data) dark_frames += f.found.dark_spheres ? 1 : 0;
  const bool dark = mostlyDark(dark_frames, static_cast<int>(data.size()));
  const InverseInputs in{shot_set, spins,         r_med, *px,    burst.exposure_us * 1e-6, dark,
                         contact,  contact_sigma, data,  flight, frames->frame_dt};
  const InversePass pass = withHeldDepths(in, inversePass(in, *fits, *depth, scale));
  out.collision.line_of_centres_z_from_size = pass.nz_size;
  const ShotUncertainty& u = pass.u;
  if (!u.nominal.ok)
    return fail(
        "the measured kinematics are not a collision (the spheres do not approach at "
        "the contact instant); check the tracks");
  const InstantAgreement instants = instantAgreement(pass.fits, u, shot_set, pass.scale.px);
  if (!pass.fits.contact_reached)
    out.notes.push_back(
        "the fitted centres never came within the contact distance (nearly "
        "grazing: at the instant found they were " +
        fmt("%.0f", 1e6 * pass.fits.shortfall_m) +
        " um further apart): the collision instant is where each sphere's track "
        "bends, from the kinks alone");
  fillKinematics(out, u, pass.fits, spins, pass.model.vz_fraction, instants);
  out.kink_gap = {u.nominal.kink_gap, u.kink_gap.sigma(),
                  u.kink_gap_var_per_offset_var * pass.scale.px * pass.scale.px};
  withoutUnmeasuredSpins(out.collision, spins);
  if (set.error_budget) {
    out.error_budget = errorBudget(boundModel(pass), 300, 12345, out.collision.beta_spin_weight);
    // beta's rows only where beta is stated (both spins measured).
    if (!std::isfinite(out.collision.beta.value))
      for (ErrorBudgetRow& r : out.error_budget) r.beta = std::nan("");
  }
  fillFrames(out, burst, data, spins);

  // ---- quality flags
  FlagInputs q;
  q.settings = &shot_set;
  q.burst = &burst;
  q.frames = &*frames;
  q.fits = &pass.fits;
  q.u = &u;
  q.instants = &instants;
  q.r_med = r_med;
  q.scale = pass.scale;
  q.gdir = gdir;
  q.contact = contact;
  q.saturated = saturated;
  q.third_blobs = blobs->third_blobs;
  addQualityFlags(out, q);
  return out;
}

}  // namespace collide::vision
