#pragma once
// Test helpers: edit a rig profile's TOML text line by line, so a test can
// take config/sim.toml and change one field (TOML forbids redefining a key, so
// overrides cannot simply be appended).
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "hw/rig.hpp"
#include "hw/rig_profile.hpp"

namespace collide::hw::testing {

inline std::vector<std::string> splitLines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

inline std::string joinLines(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& l : lines) out += l + "\n";
  return out;
}

inline std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("test data missing: " + path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline std::string simProfileText() {
  return readFile(std::string(COLLIDE_SOURCE_DIR) + "/config/sim.toml");
}

// Index of the header line of `section` ("camera", or "launcher" with
// `occurrence` 1 or 2 for [[launcher]]), and one past its last line.
inline std::pair<std::size_t, std::size_t> sectionSpan(const std::vector<std::string>& lines,
                                                       const std::string& section,
                                                       int occurrence = 1) {
  int seen = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (lines[i] == "[" + section + "]" || lines[i] == "[[" + section + "]]") {
      if (++seen < occurrence) continue;
      std::size_t end = i + 1;
      while (end < lines.size() && (lines[end].empty() || lines[end][0] != '[')) ++end;
      return {i, end};
    }
  }
  throw std::runtime_error("no section [" + section + "] in the profile");
}

inline bool isKeyLine(const std::string& line, const std::string& key) {
  return line.rfind(key + " ", 0) == 0 || line.rfind(key + "=", 0) == 0;
}

/// 1-based line of `key` in `section`.
inline int lineOf(const std::string& text, const std::string& section, const std::string& key,
                  int occurrence = 1) {
  const auto lines = splitLines(text);
  const auto [begin, end] = sectionSpan(lines, section, occurrence);
  for (std::size_t i = begin + 1; i < end; ++i)
    if (isKeyLine(lines[i], key)) return static_cast<int>(i) + 1;
  throw std::runtime_error("no key " + key + " in [" + section + "]");
}

/// `text` with `key = value` in `section` (replacing the existing line, or
/// added right after the header). `value` is TOML: "5", "\"sim\"", "[1, 2]".
inline std::string withKey(const std::string& text, const std::string& section,
                           const std::string& key, const std::string& value, int occurrence = 1) {
  auto lines = splitLines(text);
  const auto [begin, end] = sectionSpan(lines, section, occurrence);
  for (std::size_t i = begin + 1; i < end; ++i) {
    if (isKeyLine(lines[i], key)) {
      lines[i] = key + " = " + value;
      return joinLines(lines);
    }
  }
  lines.insert(lines.begin() + static_cast<long>(begin) + 1, key + " = " + value);
  return joinLines(lines);
}

/// `text` without the `key` line of `section`.
inline std::string withoutKey(const std::string& text, const std::string& section,
                              const std::string& key, int occurrence = 1) {
  auto lines = splitLines(text);
  const auto [begin, end] = sectionSpan(lines, section, occurrence);
  for (std::size_t i = begin + 1; i < end; ++i) {
    if (isKeyLine(lines[i], key)) {
      lines.erase(lines.begin() + static_cast<long>(i));
      return joinLines(lines);
    }
  }
  throw std::runtime_error("no key " + key + " in [" + section + "]");
}

/// The rig `text` (a whole profile) describes, built (closed); throws (failing
/// the test) on a profile or backend error.
inline Rig rigFrom(const std::string& text) {
  auto profile = parseRigProfile(text, "sim.toml");
  if (!profile) throw std::runtime_error(profile.error().message);
  auto rig = makeRig(*profile);
  if (!rig) throw std::runtime_error(rig.error().message);
  return std::move(rig).value();
}

}  // namespace collide::hw::testing
