#include "app/report/results_summary.hpp"

#include <nlohmann/json.hpp>

namespace collide::app {

Result<ResultsSummary> summarizeResults(const std::string& results_json) {
  const nlohmann::json j = nlohmann::json::parse(results_json, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return fail("results are not valid JSON: check what the analysis wrote");
  if (!j.is_object())
    return fail("results JSON should be an object {...}, not " + std::string(j.type_name()));
  ResultsSummary s;
  struct Field {
    const char* key;
    std::optional<double> ResultsSummary::*member;
  };
  static constexpr Field kFields[] = {
      {"e", &ResultsSummary::e},           {"beta", &ResultsSummary::beta},
      {"f", &ResultsSummary::f},           {"gamma_deg", &ResultsSummary::gamma_deg},
      {"vn_m_s", &ResultsSummary::vn_m_s}, {"vs_m_s", &ResultsSummary::vs_m_s},
  };
  for (const Field& field : kFields) {
    const auto it = j.find(field.key);
    if (it == j.end() || it->is_null()) continue;
    if (!it->is_number())
      return fail(std::string("results JSON field \"") + field.key + "\" should be a number, not " +
                  it->type_name());
    s.*field.member = it->get<double>();
  }
  if (const auto it = j.find("quality_flags"); it != j.end() && !it->is_null()) {
    if (!it->is_array()) return fail("results JSON field \"quality_flags\" should be an array");
    for (const auto& flag : *it) {
      if (!flag.is_string())
        return fail("results JSON field \"quality_flags\" should hold strings only");
      s.quality_flags.push_back(flag.get<std::string>());
    }
  }
  return s;
}

std::string joinFlags(const std::vector<std::string>& flags) {
  std::string out;
  for (const auto& f : flags) {
    if (!out.empty()) out += ',';
    out += f;
  }
  return out;
}

std::vector<std::string> splitFlags(const std::string& joined) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (start < joined.size()) {
    const std::size_t end = std::min(joined.find(',', start), joined.size());
    out.push_back(joined.substr(start, end - start));
    start = end + 1;
  }
  return out;
}

}  // namespace collide::app
