#include "analysis/rotation.hpp"

#include <cmath>
#include <limits>
#include <string>

namespace collide {

namespace {

// Points spread over at least a plane through the origin have a weighted
// scatter matrix with two clearly non-zero eigenvalues.
bool spansAPlane(const Eigen::Matrix3Xd& p, const Eigen::VectorXd& w) {
  const Eigen::Matrix3d scatter = p * w.asDiagonal() * p.transpose();
  const Eigen::Vector3d ev =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter, Eigen::EigenvaluesOnly)
          .eigenvalues();  // ascending
  return ev[2] > 0 && ev[1] > 1e-10 * ev[2];
}

}  // namespace

Result<RotationFit> fitRotation(const Eigen::Matrix3Xd& from_m, const Eigen::Matrix3Xd& to_m,
                                const Eigen::VectorXd& weights) {
  const Eigen::Index n = from_m.cols();
  if (to_m.cols() != n)
    return fail("rotation fit: " + std::to_string(n) + " points in the first frame but " +
                std::to_string(to_m.cols()) + " in the second; pass matched pairs only");
  const Eigen::VectorXd w = weights.size() == 0 ? Eigen::VectorXd::Ones(n) : weights;
  if (w.size() != n)
    return fail("rotation fit: " + std::to_string(w.size()) + " weights for " + std::to_string(n) +
                " points; give one weight per matched point");
  if (!from_m.allFinite() || !to_m.allFinite())
    return fail("rotation fit: a dot position is not finite; drop that dot");
  for (Eigen::Index i = 0; i < n; ++i)
    if (!std::isfinite(w[i]) || w[i] < 0)
      return fail("rotation fit: weight of point " + std::to_string(i) +
                  " must be finite and >= 0");
  const int used = int((w.array() > 0).count());
  if (used < 2)
    return fail("rotation fit: " + std::to_string(used) +
                " matched dots; a rotation needs at least 2 (match more dots)");
  if (!spansAPlane(from_m, w) || !spansAPlane(to_m, w))
    return fail(
        "rotation fit: the matched dots lie on one line through the sphere centre, so the "
        "rotation about that line is undetermined; match a dot off that line");

  // Kabsch: with H = sum w from to^T = U S V^T the best rotation is
  // V diag(1, 1, det(V U^T)) U^T. The determinant factor turns the best
  // orthogonal matrix into the best proper rotation when noise (or a
  // mirror-image match) would otherwise give a reflection.
  const Eigen::Matrix3d h = from_m * w.asDiagonal() * to_m.transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1.0 : 1.0;

  RotationFit fit;
  fit.rotation = svd.matrixV() * d * svd.matrixU().transpose();
  const Eigen::AngleAxisd aa(fit.rotation);
  fit.rotation_vector_rad = aa.axis() * aa.angle();
  const Eigen::ArrayXd r2 = (to_m - fit.rotation * from_m).colwise().squaredNorm().transpose();
  fit.residual_rms_m = std::sqrt((w.array() * r2).sum() / w.sum());
  fit.points = used;
  return fit;
}

Result<SpinEstimate> spinFromRotations(const std::vector<InterFrameRotation>& pairs) {
  double sum_w = 0.0;
  Vec3 sum_wx = Vec3::Zero();
  int used = 0;
  for (size_t i = 0; i < pairs.size(); ++i) {
    const InterFrameRotation& p = pairs[i];
    const std::string where = "spin: frame pair " + std::to_string(i);
    if (!p.rotation_vector_rad.allFinite())
      return fail(where + " has a non-finite rotation vector; drop that pair");
    if (!std::isfinite(p.dt_s) || p.dt_s <= 0)
      return fail(where + " has time step " + std::to_string(p.dt_s) +
                  " s; it must be > 0 (frames in time order)");
    if (!std::isfinite(p.weight) || p.weight < 0)
      return fail(where + " has weight " + std::to_string(p.weight) + "; it must be >= 0");
    if (p.weight == 0) continue;
    sum_w += p.weight;
    sum_wx += p.weight * p.angularVelocity_rad_s();
    ++used;
  }
  if (used == 0)
    return fail("spin: no frame pair with positive weight; track the dots over at least 2 frames");

  SpinEstimate s;
  s.pairs = used;
  s.spin_rad_s = sum_wx / sum_w;
  if (used > 1) {
    // Relative weights: the scale of the pairs' noise comes from their scatter,
    // var(mean) = sum w (x - mean)(x - mean)^T / ((N - 1) sum w) (s^2/N for equal weights).
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    for (const InterFrameRotation& p : pairs) {
      if (p.weight == 0) continue;
      const Vec3 dx = p.angularVelocity_rad_s() - s.spin_rad_s;
      scatter += p.weight * dx * dx.transpose();
    }
    s.covariance = scatter / ((used - 1) * sum_w);
  } else {
    s.covariance.setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  s.sigma_rad_s = s.covariance.diagonal().array().sqrt();
  s.rate_rad_s = s.spin_rad_s.norm();
  if (s.rate_rad_s > 0) {
    const Vec3 u = s.spin_rad_s / s.rate_rad_s;
    s.rate_sigma_rad_s = std::sqrt(u.dot(s.covariance * u));
  } else {
    // At zero spin the magnitude is not differentiable; quote the largest component error.
    s.rate_sigma_rad_s = s.sigma_rad_s.maxCoeff();
  }
  return s;
}

}  // namespace collide
