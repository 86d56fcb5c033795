#pragma once
#include <cstdint>
#include <string>

namespace collide::app {

/// A unique, sortable shot id from a wall-clock time and a sequence number:
/// "YYYYMMDD-HHMMSS-NNNN" (UTC).
std::string makeShotId(std::int64_t wall_time_unix_ns, int sequence);

/// The id to try when `id` is taken: the trailing sequence number plus one,
/// keeping its width ("20260314-101500-0007" -> "...-0008", "...-9999" ->
/// "...-10000"); an id without a trailing number gets "-0001" appended.
std::string nextShotId(const std::string& id);

/// Current wall-clock time, nanoseconds since the Unix epoch.
std::int64_t wallTimeUnixNs();

}  // namespace collide::app
