#include "analysis/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>

namespace collide {

namespace {

std::string fmt(const char* spec, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, spec, v);
  return buf;
}

std::string rangeText(double p_min_kPa, double p_max_kPa) {
  return fmt("%g", p_min_kPa) + ".." + fmt("%g", p_max_kPa) + " kPa";
}

Eigen::Vector4d basis(double p_kPa) {
  const double x = p_kPa / 100.0;
  return {1.0, x, x * x, x * x * x};
}

// Where dv/dx = c1 + 2 c2 x + 3 c3 x^2 is smallest on [x_lo, x_hi]: an end
// point or the parabola's vertex. Returns that x if the slope there is <= 0.
std::optional<double> nonIncreasingAt(const LaunchCalibration::Coefficients& c, double x_lo,
                                      double x_hi) {
  auto slope = [&](double x) { return c[1] + 2 * c[2] * x + 3 * c[3] * x * x; };
  double x_min = slope(x_lo) <= slope(x_hi) ? x_lo : x_hi;
  if (c[3] != 0.0) {
    const double vertex = -c[2] / (3 * c[3]);
    if (vertex > x_lo && vertex < x_hi && slope(vertex) < slope(x_min)) x_min = vertex;
  }
  if (slope(x_min) > 0) return std::nullopt;
  return x_min;
}

// Why a cubic on a range cannot serve as a calibration, or nullopt if it can.
std::optional<std::string> problemWith(const LaunchCalibration::Coefficients& c, double p_min_kPa,
                                       double p_max_kPa) {
  for (double ci : c)
    if (!std::isfinite(ci)) return "a coefficient is not finite; recalibrate";
  if (!std::isfinite(p_min_kPa) || !std::isfinite(p_max_kPa) || p_min_kPa >= p_max_kPa)
    return "working range " + rangeText(p_min_kPa, p_max_kPa) +
           " is empty or not finite; give p_min_kPa < p_max_kPa";
  if (auto x = nonIncreasingAt(c, p_min_kPa / 100.0, p_max_kPa / 100.0))
    return "exit speed does not increase with pressure near p = " + fmt("%.1f", *x * 100.0) +
           " kPa, so it cannot be inverted on " + rangeText(p_min_kPa, p_max_kPa) +
           "; narrow the working range or recalibrate";
  return std::nullopt;
}

}  // namespace

Result<LaunchCalibration> LaunchCalibration::create(const Coefficients& c, double p_min_kPa,
                                                    double p_max_kPa) {
  if (auto problem = problemWith(c, p_min_kPa, p_max_kPa))
    return fail("launch calibration: " + *problem);
  return LaunchCalibration(c, p_min_kPa, p_max_kPa);
}

LaunchCalibration LaunchCalibration::thesis() {
  return create().value();
}

double LaunchCalibration::speed_m_s(double p_kPa) const {
  return basis(p_kPa).dot(Eigen::Vector4d(c_[0], c_[1], c_[2], c_[3]));
}

Result<double> LaunchCalibration::pressure_kPa(double v_m_s) const {
  const double v_lo = minSpeed_m_s(), v_hi = maxSpeed_m_s();
  if (!std::isfinite(v_m_s) || v_m_s < v_lo || v_m_s > v_hi)
    return fail("wanted exit speed " + fmt("%.2f", v_m_s) +
                " m/s is outside the calibrated range " + fmt("%.2f", v_lo) + " .. " +
                fmt("%.2f", v_hi) + " m/s (p " + rangeText(p_min_kPa_, p_max_kPa_) +
                "): choose a speed in range or recalibrate");
  // v is strictly increasing on the range (checked at construction), so
  // bisection always converges to the one root, down to adjacent doubles.
  double lo = p_min_kPa_, hi = p_max_kPa_;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    (speed_m_s(mid) < v_m_s ? lo : hi) = mid;
  }
  // Of the two brackets, the one whose speed is closer.
  return std::abs(speed_m_s(lo) - v_m_s) <= std::abs(speed_m_s(hi) - v_m_s) ? lo : hi;
}

double CalibrationRefit::speedSigma_m_s(double p_kPa) const {
  const Eigen::Vector4d b = basis(p_kPa);
  return std::sqrt(b.dot(covariance * b));
}

Result<CalibrationRefit> refitLaunchCalibration(const Eigen::VectorXd& p_kPa,
                                                const Eigen::VectorXd& v_m_s,
                                                const Weights& weights, double p_min_kPa,
                                                double p_max_kPa) {
  // Five, not four: with four pairs the cubic interpolates and there is no
  // residual left to judge the calibration by.
  if (p_kPa.size() < 5)
    return fail("launch calibration refit: " + std::to_string(p_kPa.size()) +
                " (pressure, speed) pairs; measure at least 5 pressures across the range");
  Eigen::MatrixXd design(p_kPa.size(), 4);
  for (Eigen::Index i = 0; i < p_kPa.size(); ++i) design.row(i) = basis(p_kPa[i]).transpose();
  auto ls = weightedLeastSquares(design, v_m_s, weights, "launch calibration refit");
  if (!ls) return ls.error();
  const LaunchCalibration::Coefficients c{ls->coefficients[0], ls->coefficients[1],
                                          ls->coefficients[2], ls->coefficients[3]};
  if (auto problem = problemWith(c, p_min_kPa, p_max_kPa))
    return fail("launch calibration refit: " + *problem +
                " (check the measured speeds, or measure more pressures)");
  LaunchCalibration cal = LaunchCalibration::create(c, p_min_kPa, p_max_kPa).value();
  return CalibrationRefit{.calibration = cal,
                          .covariance = ls->covariance,
                          .residuals_m_s = ls->residuals,
                          .rms_m_s = ls->residualRms(),
                          .dof = ls->dof};
}

}  // namespace collide
