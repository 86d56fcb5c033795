#include "analysis/residual_structure.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace collide {

namespace {

// sqrt(w_i) r_i for the observations with w_i > 0, in order.
std::vector<double> weightedResiduals(const LinearFit& fit) {
  std::vector<double> e;
  e.reserve(static_cast<std::size_t>(fit.residuals.size()));
  for (Eigen::Index i = 0; i < fit.residuals.size(); ++i) {
    const double w = fit.weights.size() == fit.residuals.size() ? fit.weights[i] : 1.0;
    if (w > 0) e.push_back(std::sqrt(w) * fit.residuals[i]);
  }
  return e;
}

}  // namespace

Lag1Sums lag1Sums(const LinearFit& fit) {
  const std::vector<double> e = weightedResiduals(fit);
  Lag1Sums out;
  out.n = static_cast<int>(e.size());
  for (std::size_t i = 0; i < e.size(); ++i) {
    out.squares += e[i] * e[i];
    if (i + 1 < e.size()) out.products += e[i] * e[i + 1];
  }
  return out;
}

namespace {

// r1 from a fit's sums; NaN when they say nothing about order.
double lag1Correlation(const Lag1Sums& sums, int dof) {
  if (sums.n < 3 || dof < 3 || !(sums.squares > 0)) return std::numeric_limits<double>::quiet_NaN();
  return sums.products / sums.squares;
}

}  // namespace

double residualLag1Correlation(const LinearFit& fit) {
  return lag1Correlation(lag1Sums(fit), fit.dof);
}

double residualTrendF(const LinearFit& fit) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> r;
  for (Eigen::Index i = 0; i < fit.residuals.size(); ++i)
    if (fit.weights.size() != fit.residuals.size() || fit.weights[i] > 0)
      r.push_back(fit.residuals[i]);
  const auto n = static_cast<Eigen::Index>(r.size());
  if (n < 6) return kNaN;
  // [1, x, x^2, x^3] with x the centred, scaled sample index; the quadratic
  // part is fitted too, as the residuals are unweighted here.
  Eigen::MatrixXd a(n, 4);
  const Eigen::VectorXd y = Eigen::Map<const Eigen::VectorXd>(r.data(), n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double x =
        (2.0 * static_cast<double>(i) - static_cast<double>(n - 1)) / static_cast<double>(n - 1);
    a.row(i) << 1, x, x * x, x * x * x;
  }
  const auto chi2 = [&](int columns) {
    const Eigen::MatrixXd part = a.leftCols(columns);
    const Eigen::VectorXd c = part.colPivHouseholderQr().solve(y);
    return (y - part * c).squaredNorm();
  };
  const double quadratic = chi2(3), cubic = chi2(4);
  if (!(cubic > 0) || !(quadratic > 0)) return kNaN;
  return (quadratic - cubic) / (cubic / static_cast<double>(n - 4));
}

namespace {

// Student's t quantile at the normal quantile z for nu degrees of freedom
// (Cornish-Fisher expansion, a few per cent at nu >= 5).
double studentQuantile(double z, double nu) {
  const double z3 = z * z * z, z5 = z3 * z * z;
  return z + (z3 + z) / (4 * nu) + (5 * z5 + 16 * z3 + 3 * z) / (96 * nu * nu);
}

}  // namespace

bool residualsStructured(const LinearFit& fit, double z) {
  const Lag1Sums sums = lag1Sums(fit);
  const double n = sums.n;
  if (const double r1 = lag1Correlation(sums, fit.dof);
      std::isfinite(r1) && std::abs(r1 + 1.0 / n) > z / std::sqrt(n))
    return true;
  if (const double f = residualTrendF(fit); std::isfinite(f)) {
    const double t = studentQuantile(z, n - 4);
    return f > t * t;
  }
  return false;
}

double residualInflation(const TrajectoryFit& fit) {
  double num = 0, den = 0;
  for (int k = 0; k < 2; ++k) {  // x and y pooled
    const Lag1Sums sums = lag1Sums(fit.axisFit(k));
    num += sums.products, den += sums.squares;
  }
  if (!(den > 0)) return 1;
  const double rho = std::clamp(num / den, 0.0, 0.8);
  return (1 + rho) / (1 - rho);
}

double wanderSigma(const Eigen::VectorXd& t, const Eigen::VectorXd& gain, double rms,
                   double time_s) {
  if (t.size() != gain.size()) return std::numeric_limits<double>::quiet_NaN();
  if (!(rms > 0) || !(time_s > 0)) return 0;
  constexpr double kReach = 8;  // exp(-32): nothing beyond
  double var = 0;
  for (Eigen::Index i = 0; i < t.size(); ++i) {
    var += gain[i] * gain[i];
    for (Eigen::Index j = i + 1; j < t.size(); ++j) {
      const double d = (t[j] - t[i]) / time_s;
      if (d > kReach) break;
      var += 2 * gain[i] * gain[j] * std::exp(-0.5 * d * d);
    }
  }
  return std::sqrt(std::max(0.0, var)) * rms;
}

Eigen::Matrix<double, 3, Eigen::Dynamic> quadraticGains(const Eigen::VectorXd& t,
                                                        const Eigen::VectorXd& w, double t_ref) {
  const Eigen::Index n = t.size();
  if (w.size() != n || (w.array() > 0).count() < 3) return {};
  // In units of the span, so the normal matrix is well conditioned.
  const double span = std::max((t.array() - t_ref).abs().maxCoeff(), 1e-300);
  Eigen::MatrixXd a(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double tau = (t[i] - t_ref) / span;
    a.row(i) << 1.0, tau, 0.5 * tau * tau;
  }
  const Eigen::MatrixXd aw = a.transpose() * w.asDiagonal();  // A' W
  const Eigen::MatrixXd g = (aw * a).ldlt().solve(aw);        // (A' W A)^-1 A' W
  Eigen::Matrix<double, 3, Eigen::Dynamic> out(3, n);
  out.row(0) = g.row(0);
  out.row(1) = g.row(1) / span;
  out.row(2) = g.row(2) / (span * span);
  return out;
}

}  // namespace collide
