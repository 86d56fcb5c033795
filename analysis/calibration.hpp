#pragma once
// Launch calibration (SPEC "The rig", thesis Fig. 4.2): exit speed of a sphere
// against the regulator gauge reading,
//   v(p) = c0 + c1 x + c2 x^2 + c3 x^3,  x = p / 100,
// with v in m/s and p the regulator's GAUGE pressure in kPa. The thesis does
// not name its pressure unit; this project takes the reading to be kPa gauge
// throughout (config files, the regulator interface, this curve).
#include <Eigen/Dense>
#include <array>

#include "analysis/least_squares.hpp"
#include "analysis/result.hpp"

namespace collide {

class LaunchCalibration {
 public:
  /// (c0 m/s, c1, c2, c3 m/s per unit of (p/100)^k).
  using Coefficients = std::array<double, 4>;
  /// The thesis' cubic for 2.54 cm Nylon and Teflon spheres.
  static constexpr Coefficients kThesisCoefficients{0.143, 6.6, -5.0, 3.38};
  static constexpr double kDefaultMinPressure_kPa = 10.0;
  static constexpr double kDefaultMaxPressure_kPa = 150.0;

  /// A calibration on the working range [p_min_kPa, p_max_kPa] (gauge, kPa),
  /// on which v must be strictly increasing (dv/dp > 0 everywhere on it) so
  /// that a wanted speed maps to exactly one pressure.
  /// Errors: a non-finite coefficient or bound, p_min >= p_max, v not strictly
  /// increasing on the range (the message gives where dv/dp <= 0).
  static Result<LaunchCalibration> create(const Coefficients& c = kThesisCoefficients,
                                          double p_min_kPa = kDefaultMinPressure_kPa,
                                          double p_max_kPa = kDefaultMaxPressure_kPa);
  /// The thesis cubic on 10..150 kPa (valid by construction).
  static LaunchCalibration thesis();

  /// Exit speed (m/s) at gauge pressure p_kPa. Defined for any p; only the
  /// working range is calibrated.
  double speed_m_s(double p_kPa) const;
  /// Gauge pressure (kPa) that gives exit speed v_m_s: the inverse of
  /// speed_m_s on the working range, accurate to rounding.
  /// Errors: v not finite, or outside [speed(p_min), speed(p_max)]; the
  /// message names the speed limits and the pressure range.
  Result<double> pressure_kPa(double v_m_s) const;

  double minPressure_kPa() const { return p_min_kPa_; }
  double maxPressure_kPa() const { return p_max_kPa_; }
  double minSpeed_m_s() const { return speed_m_s(p_min_kPa_); }
  double maxSpeed_m_s() const { return speed_m_s(p_max_kPa_); }
  const Coefficients& coefficients() const { return c_; }

 private:
  LaunchCalibration(const Coefficients& c, double p_min_kPa, double p_max_kPa)
      : c_(c), p_min_kPa_(p_min_kPa), p_max_kPa_(p_max_kPa) {}
  Coefficients c_;
  double p_min_kPa_, p_max_kPa_;
};

/// A calibration refitted from measured (pressure, exit speed) pairs.
struct CalibrationRefit {
  LaunchCalibration calibration;
  /// Covariance of (c0, c1, c2, c3), scaled as the weights' kind says (least_squares.hpp).
  Eigen::Matrix4d covariance;
  Eigen::VectorXd residuals_m_s;  ///< measured minus fitted speed, per pair
  double rms_m_s = 0.0;           ///< RMS of the residuals
  int dof = 0;

  /// Standard uncertainty (m/s) of the fitted v at p_kPa, from the covariance.
  double speedSigma_m_s(double p_kPa) const;
};

/// Least-squares refit of the cubic to measured pairs (p_kPa[i] gauge kPa,
/// v_m_s[i] m/s). weights: Weights::fromSigmas(speed sigmas, m/s) when each
/// speed's uncertainty is known, else Weights::equal() (scale from residuals).
/// Errors: fewer than 5 pairs, lengths that differ, non-finite values, bad
/// weights, pressures that do not determine a cubic (fewer than 4 distinct),
/// a fitted cubic that is not strictly increasing on [p_min_kPa, p_max_kPa].
Result<CalibrationRefit> refitLaunchCalibration(
    const Eigen::VectorXd& p_kPa, const Eigen::VectorXd& v_m_s,
    const Weights& weights = Weights::equal(),
    double p_min_kPa = LaunchCalibration::kDefaultMinPressure_kPa,
    double p_max_kPa = LaunchCalibration::kDefaultMaxPressure_kPa);

}  // namespace collide
