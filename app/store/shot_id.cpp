#include "app/store/shot_id.hpp"

#include <chrono>
#include <cstdio>
#include <ctime>

namespace collide::app {

std::string makeShotId(std::int64_t wall_time_unix_ns, int sequence) {
  std::time_t secs = static_cast<std::time_t>(wall_time_unix_ns / 1000000000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[40];
  std::snprintf(buf, sizeof buf, "%04d%02d%02d-%02d%02d%02d-%04d", tm.tm_year + 1900, tm.tm_mon + 1,
                tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, sequence % 10000);
  return buf;
}

std::string nextShotId(const std::string& id) {
  const std::size_t dash = id.find_last_of('-');
  const std::size_t start = dash == std::string::npos ? 0 : dash + 1;
  const std::string tail = id.substr(start);
  const bool numeric = !tail.empty() && tail.size() <= 9 &&
                       tail.find_first_not_of("0123456789") == std::string::npos;
  if (!numeric || dash == std::string::npos) return id + "-0001";
  const std::string next = std::to_string(std::stol(tail) + 1);
  return id.substr(0, start) +
         std::string(tail.size() > next.size() ? tail.size() - next.size() : 0, '0') + next;
}

std::int64_t wallTimeUnixNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace collide::app
