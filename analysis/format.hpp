#pragma once
// Number formatting for user-facing error messages in analysis/.
#include <cstdio>
#include <string>

namespace collide::detail {

/// Six significant digits, as a user would read a value back ("-0.0254", "1e+99").
inline std::string formatNumber(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}

}  // namespace collide::detail
