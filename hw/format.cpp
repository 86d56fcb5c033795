#include "hw/format.hpp"

#include <cstdio>

namespace collide::hw {

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

Status prefixed(const std::string& label, Status s) {
  if (s || s.error().message.rfind(label, 0) == 0) return s;
  return fail(label + ": " + s.error().message);
}

}  // namespace collide::hw
