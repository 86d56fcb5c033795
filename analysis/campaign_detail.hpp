#pragma once
// Helpers shared by campaign.cpp and campaign_restitution.cpp; not part of the
// public API.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "analysis/result.hpp"

namespace collide::campaign_detail {

/// A number as a user reads it in a message: 4 significant digits.
inline std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

/// "shot 7: beta = nan must be finite: <what to do>" for the first field that
/// fails; std::nullopt when the value is acceptable.
inline std::optional<Error> requireFinite(std::size_t shot, const char* field, double value,
                                          const char* what_to_do) {
  if (std::isfinite(value)) return std::nullopt;
  return fail("shot " + std::to_string(shot) + ": " + field + " = " + num(value) +
              " must be a finite number: " + what_to_do);
}

/// A standard uncertainty: finite and > 0 (or >= 0 when zero is allowed, for
/// inputs whose error is optional, like v_n's in an e fit).
inline std::optional<Error> requireSigma(std::size_t shot, const char* field, double value,
                                         bool zero_allowed) {
  const bool ok = std::isfinite(value) && (zero_allowed ? value >= 0 : value > 0);
  if (ok) return std::nullopt;
  return fail(
      "shot " + std::to_string(shot) + ": " + field + " = " + num(value) + " must be " +
      (zero_allowed ? "finite and >= 0" : "finite and > 0") +
      ": it is the measurement's standard uncertainty (see the error model, thesis eq. 5.1)");
}

/// v_n of an approaching pair: finite and < 0.
inline std::optional<Error> requireApproaching(std::size_t shot, double v_n_m_s) {
  if (std::isfinite(v_n_m_s) && v_n_m_s < 0) return std::nullopt;
  return fail("shot " + std::to_string(shot) + ": v_n = " + num(v_n_m_s) +
              " m/s must be finite and negative (the spheres approach): check the normal "
              "n = (r1 - r2)/|r1 - r2| and that the velocities are the pre-impact ones");
}

/// max(1, sqrt(chi2/dof)): the Birge ratio by which uncertainties are inflated
/// when the data scatter more than their own sigmas say (PDG convention; never
/// shrinks them, since a small chi2 is as likely luck as overstated sigmas).
inline double birgeScale(double chi2, int dof) {
  if (dof <= 0) return 1.0;
  return std::max(1.0, std::sqrt(chi2 / dof));
}

/// Robust scale of normalised residuals: max(1, 1.4826 median |z|) (the MAD
/// about zero, consistent with a Gaussian sigma; never below the stated sigmas).
inline double robustScale(const std::vector<double>& z) {
  if (z.empty()) return 1.0;
  std::vector<double> a(z.size());
  for (std::size_t i = 0; i < z.size(); ++i) a[i] = std::abs(z[i]);
  std::nth_element(a.begin(), a.begin() + a.size() / 2, a.end());
  return std::max(1.0, 1.4826 * a[a.size() / 2]);
}

}  // namespace collide::campaign_detail
