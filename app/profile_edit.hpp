#pragma once
// Editing a rig profile's TOML text in place: one value at a time, keeping the
// user's comments and layout, and writing the file safely. Used by the GUI's
// burst settings and calibration dialog; the profile stays a file users edit.
#include <array>
#include <string>
#include <utility>
#include <vector>

#include "analysis/result.hpp"

namespace collide::app {

/// `text` with `key` in table `[section]` set to `toml_value` (a TOML literal,
/// e.g. "40" or "[0.1, 6.5, -4.9, 3.4]"), keeping the rest of the line (its
/// comment) and every other line as they were. A key absent from the section
/// is added at its end. Only plain `[section]` tables are edited (not
/// `[[array]]` entries). Errors: no such section.
Result<std::string> setProfileValue(const std::string& text, const std::string& section,
                                    const std::string& key, const std::string& toml_value);

/// `text` with table `[section]` (a sub-table such as "camera.calibration")
/// holding exactly `entries` (key, TOML literal), in that order: an existing
/// table's lines (up to the next table header) are replaced whole; a missing
/// one is added after its parent's tables ([camera], [camera.*]), or at the
/// end when there is no parent. Every other line stays as it was. Errors:
/// the parent table is missing.
Result<std::string> setProfileTable(
    const std::string& text, const std::string& section,
    const std::vector<std::pair<std::string, std::string>>& entries);

/// A TOML array of numbers written so that they read back exactly ("%.17g").
std::string tomlNumberArray(const std::array<double, 4>& values);

/// Replaces the profile file at `path` with `text`: the previous file is first
/// copied to `path` + ".bak" (replacing an older backup), then the new text is
/// written to a temporary file, synced and renamed over `path`, so the profile
/// is always either the old or the new one, never a half-written file.
/// `backup_path` (if given) receives the backup's path. Errors name the file.
Status writeProfileFile(const std::string& path, const std::string& text,
                        std::string* backup_path = nullptr);

}  // namespace collide::app
