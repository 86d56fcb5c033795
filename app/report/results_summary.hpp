#pragma once
// The few analysis results the catalog and the shot file keep as columns /
// scalar datasets, taken from a shot's results JSON (the full results stay in
// the JSON text). Contract with analysis: these top-level keys, each optional:
//   "e", "beta", "f" (dimensionless), "gamma_deg" (degrees), "vn_m_s",
//   "vs_m_s" (m/s): numbers or null;  "quality_flags": array of strings.
#include <optional>
#include <string>
#include <vector>

#include "analysis/result.hpp"

namespace collide::app {

struct ResultsSummary {
  std::optional<double> e, beta, f, gamma_deg, vn_m_s, vs_m_s;
  std::vector<std::string> quality_flags;
};

/// Errors: the text is not JSON, not a JSON object, or a listed key has the
/// wrong type (the message names the key).
Result<ResultsSummary> summarizeResults(const std::string& results_json);

/// The quality flags as one catalog cell, "a,b,c" (empty for none).
std::string joinFlags(const std::vector<std::string>& flags);
std::vector<std::string> splitFlags(const std::string& joined);

}  // namespace collide::app
