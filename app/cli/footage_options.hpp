#pragma once
// Options of the commands that read footage (analyze --frames, track):
// `--polarity auto|dark|bright` (which way round the spheres are lit) and
// `--range FIRST:LAST` (frame ids of a camera file).
#include <cstdint>
#include <exception>
#include <optional>
#include <string>

#include "vision/footage.hpp"
#include "vision/sphere_detector.hpp"

namespace collide::cli {

inline constexpr const char* kPolarityHelp =
    "Sphere polarity: auto (default: dark when most of the frame is bright), dark (silhouettes "
    "on a backlight), bright (lit spheres on a dark background)";

/// False for anything but auto, dark or bright (the caller names the flag).
inline bool parsePolarity(const std::string& s, vision::SphereDetectorSettings::Polarity& out) {
  using P = vision::SphereDetectorSettings::Polarity;
  if (s == "auto")
    out = P::Auto;
  else if (s == "dark")
    out = P::Dark;
  else if (s == "bright")
    out = P::Bright;
  else
    return false;
  return true;
}

/// "A:B", "A:" or ":B" (frame ids, may be negative); false if malformed.
inline bool parseFrameRange(const std::string& s, vision::FootageRange& out) {
  const std::size_t colon = s.find(':');
  if (colon == std::string::npos) return false;
  auto part = [](const std::string& t, std::optional<std::int64_t>& v) {
    if (t.empty()) return true;
    std::size_t used = 0;
    try {
      v = std::stoll(t, &used);
    } catch (const std::exception&) {
      return false;
    }
    return used == t.size();
  };
  return part(s.substr(0, colon), out.first_id) && part(s.substr(colon + 1), out.last_id);
}

}  // namespace collide::cli
