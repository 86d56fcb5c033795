#include "analysis/depth_from_size.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>

#include "analysis/least_squares.hpp"

namespace collide {

double depthFromRadius(double r_px, double r_plane_px, double camera_distance_m) {
  return camera_distance_m * (1.0 - r_plane_px / r_px);
}

double apparentRadiusPx(const PinholeCamera& camera, const Vec3& c, double radius_m) {
  const Vec3 to_camera = camera.centre_m - c;
  const double dist = to_camera.norm();
  if (!(dist > radius_m)) return std::nan("");
  const Vec3 u = to_camera / dist;
  // The tangent circle: centre R^2 / L towards the camera, radius R sqrt(1 - R^2 / L^2).
  const Vec3 centre = c + u * (radius_m * radius_m / dist);
  const double rho = radius_m * std::sqrt(1 - radius_m * radius_m / (dist * dist));
  const Vec3 e1 = u.unitOrthogonal(), e2 = u.cross(e1);
  constexpr int kN = 64;
  std::array<Eigen::Vector2d, kN> pts;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (int i = 0; i < kN; ++i) {
    const double phi = 2 * std::numbers::pi * i / kN;
    pts[i] = camera.project(centre + rho * (std::cos(phi) * e1 + std::sin(phi) * e2));
    mean += pts[i] / kN;
  }
  double r = 0;
  for (const Eigen::Vector2d& p : pts) r += (p - mean).norm() / kN;
  return r;
}

double planeRadiusPx(const PinholeCamera& camera, double u_px, double v_px, double radius_m) {
  return apparentRadiusPx(camera, camera.sphereCentre(u_px, v_px, radius_m), radius_m);
}

double depthResidualScale(const DepthMotion& d) {
  return d.dof > 0 ? std::max(1.0, std::sqrt(d.chi2 / d.dof)) : 1.0;
}

void completeDepthSigmas(DepthMotion& d, double camera_distance_m, double radius_px, double span_s,
                         double radius_systematic_px) {
  const double sc = depthResidualScale(d);
  d.dz0_sigma_m *= sc;
  d.vz_sigma_m_s =
      std::hypot(sc * d.vz_sigma_m_s, camera_distance_m * std::max(0.0, radius_systematic_px) /
                                          (radius_px * std::max(span_s, 1e-6)));
  d.chi2 = d.dof;  // the scale is in the sigmas now
}

Result<DepthMotion> fitDepthMotion(const Eigen::VectorXd& t, const Eigen::VectorXd& r,
                                   const Eigen::VectorXd& sr, double r0, double z0, double t_ref) {
  return fitDepthMotion(t, r, sr, Eigen::VectorXd::Constant(t.size(), r0), z0, t_ref);
}

Result<DepthMotion> fitDepthMotion(const Eigen::VectorXd& t, const Eigen::VectorXd& r,
                                   const Eigen::VectorXd& sr, const Eigen::VectorXd& r0v, double z0,
                                   double t_ref) {
  const Eigen::Index n = t.size();
  if (r0v.size() != n) return fail("depth from size: plane radii and times differ in number");
  if (r.size() != n || sr.size() != n)
    return fail("depth from size: " + std::to_string(n) + " times but " + std::to_string(r.size()) +
                " radii and " + std::to_string(sr.size()) + " sigmas");
  if (n < 3) return fail("depth from size needs at least 3 frames, got " + std::to_string(n));
  if (!(r0v.array() > 0).all() || !r0v.allFinite() || !(z0 > 0) || !std::isfinite(z0))
    return fail(
        "depth from size needs the radius in the object plane (px) and the camera's distance "
        "(m), both > 0");
  Eigen::MatrixXd a(n, 2);
  Eigen::VectorXd dz(n), sz(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!(r[i] > 0) || !std::isfinite(r[i]) || !(sr[i] > 0) || !std::isfinite(sr[i]))
      return fail("depth from size: frame " + std::to_string(i) +
                  " has no usable radius (radius and its sigma must be finite and > 0)");
    a(i, 0) = 1.0;
    a(i, 1) = t[i] - t_ref;
    dz[i] = depthFromRadius(r[i], r0v[i], z0);
    sz[i] = z0 * r0v[i] * sr[i] / (r[i] * r[i]);
  }
  auto fit = weightedLeastSquares(a, dz, Weights::fromSigmas(sz), "depth from size");
  if (!fit) return fit.error();
  DepthMotion m;
  m.dz0_m = fit->coefficients[0];
  m.dz0_sigma_m = fit->sigma(0);
  m.vz_m_s = fit->coefficients[1];
  m.vz_sigma_m_s = fit->sigma(1);
  m.chi2 = fit->chi2;
  m.dof = fit->dof;
  return m;
}

void conserveMomentumZ(std::array<double, 4>& vz, std::array<double, 4>& sigma,
                       const std::array<double, 2>& mass) {
  for (double x : sigma)
    if (!(x > 0) || !std::isfinite(x)) return;
  const Eigen::Vector4d c(-mass[0], mass[0], -mass[1], mass[1]);
  Eigen::Vector4d v, var;
  for (int i = 0; i < 4; ++i) v[i] = vz[i], var[i] = sigma[i] * sigma[i];
  const Eigen::Vector4d sc = var.cwiseProduct(c);  // Sigma c
  const double csc = c.dot(sc);
  if (!(csc > 0)) return;
  const Eigen::Vector4d adjusted = v - sc * (c.dot(v) / csc);
  for (int i = 0; i < 4; ++i) {
    vz[i] = adjusted[i];
    sigma[i] = std::sqrt(std::max(0.0, var[i] - sc[i] * sc[i] / csc));
  }
}

void holdDepthToImpulse(DepthMotion& after, const DepthMotion& before, double vz_impulse_m_s,
                        double vz_impulse_sigma_m_s, double t_contact_s, double t_ref_s) {
  if (!std::isfinite(vz_impulse_m_s) || !(vz_impulse_sigma_m_s > 0) ||
      !std::isfinite(vz_impulse_sigma_m_s))
    return;
  const double wi = 1 / (vz_impulse_sigma_m_s * vz_impulse_sigma_m_s);
  const double ws = after.vz_sigma_m_s > 0 && std::isfinite(after.vz_sigma_m_s)
                        ? 1 / (after.vz_sigma_m_s * after.vz_sigma_m_s)
                        : 0.0;
  after.vz_m_s = (wi * vz_impulse_m_s + ws * after.vz_m_s) / (wi + ws);
  after.vz_sigma_m_s = 1 / std::sqrt(wi + ws);
  const double dz_contact = before.dz0_m + before.vz_m_s * (t_contact_s - t_ref_s);
  after.dz0_m = dz_contact - after.vz_m_s * (t_contact_s - t_ref_s);
  after.dz0_sigma_m = before.dz0_sigma_m;
}

}  // namespace collide
