#pragma once
// Test helper: config/sim.toml with its [camera] section played by the aravis
// backend (the other devices stay simulated).
#include <string>
#include <vector>

#include "profile_text.hpp"

namespace collide::hw::testing {

/// sim.toml with [camera] replaced by `camera_lines` (the lines after the
/// header, e.g. {"backend = \"aravis\"", "device = \"Fake_1\"", ...}) and,
/// if `feature_lines` is not empty, a [camera.features] table holding them.
inline std::string aravisProfileText(const std::vector<std::string>& camera_lines,
                                     const std::vector<std::string>& feature_lines = {}) {
  auto lines = splitLines(simProfileText());
  const auto [begin, end] = sectionSpan(lines, "camera");
  std::vector<std::string> section{"[camera]"};
  section.insert(section.end(), camera_lines.begin(), camera_lines.end());
  if (!feature_lines.empty()) {
    section.push_back("");
    section.push_back("[camera.features]");
    section.insert(section.end(), feature_lines.begin(), feature_lines.end());
  }
  section.push_back("");
  lines.erase(lines.begin() + static_cast<long>(begin), lines.begin() + static_cast<long>(end));
  lines.insert(lines.begin() + static_cast<long>(begin), section.begin(), section.end());
  return joinLines(lines);
}

/// The usual role keys of an aravis camera on Aravis' fake cameras.
inline std::vector<std::string> aravisCameraLines(const std::string& device,
                                                  const std::vector<std::string>& extra = {}) {
  std::vector<std::string> l{"backend = \"aravis\"",
                             "device = \"" + device + "\"",
                             "roi = [0, 0, 160, 120]",
                             "format = \"Mono8\"",
                             "fps = 100.0",
                             "exposure_us = 1000.0",
                             "gain_db = 0.0"};
  l.insert(l.end(), extra.begin(), extra.end());
  return l;
}

}  // namespace collide::hw::testing
