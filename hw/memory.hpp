#pragma once
// How much memory this machine can give a burst, so that a burst too large
// for it is refused with the figures before anything is armed or read,
// instead of aborting the process half-way.
#include <cstdint>
#include <optional>
#include <string>

namespace collide::hw {

/// Bytes the kernel says can be allocated without swapping (MemAvailable in
/// /proc/meminfo, which counts reclaimable cache), or nullopt where unknown.
std::optional<std::uint64_t> availableMemoryBytes();

/// "1.25 GB": a byte count for messages.
std::string formatBytes(double bytes);

}  // namespace collide::hw
