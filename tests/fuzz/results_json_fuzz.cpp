// Fuzz target: results JSON as stored in shot files and read back by
// `collide fit`, the catalog and the GUI (a file may have been edited or
// damaged). Any input gives results or a one-line error.
#include <cstddef>
#include <cstdint>
#include <string>

#include "app/report/results_json.hpp"
#include "app/report/results_summary.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string json(reinterpret_cast<const char*>(data), size);
  if (auto r = collide::app::parseResultsJson(json)) (void)collide::app::toCampaignShot(*r);
  (void)collide::app::summarizeResults(json);
  return 0;
}
