#pragma once
#include <cstdint>
#include <string>

namespace collide::app {

/// A unique, sortable shot id from a wall-clock time and a sequence number:
/// "YYYYMMDD-HHMMSS-NNNN" (UTC).
std::string makeShotId(std::int64_t wall_time_unix_ns, int sequence);

/// Current wall-clock time, nanoseconds since the Unix epoch.
std::int64_t wallTimeUnixNs();

}  // namespace collide::app
