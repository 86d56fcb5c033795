#include "vision/frame.hpp"

#include <algorithm>
#include <cctype>

namespace collide::vision {

const char* toString(PixelFormat f) {
  switch (f) {
    case PixelFormat::Mono8: return "Mono8";
    case PixelFormat::Mono12: return "Mono12";
    case PixelFormat::Mono16: return "Mono16";
  }
  return "Mono8";
}

bool parsePixelFormat(const std::string& s, PixelFormat& out) {
  std::string l = s;
  std::transform(l.begin(), l.end(), l.begin(), [](unsigned char c) { return std::tolower(c); });
  if (l == "mono8")
    out = PixelFormat::Mono8;
  else if (l == "mono12")
    out = PixelFormat::Mono12;
  else if (l == "mono16")
    out = PixelFormat::Mono16;
  else
    return false;
  return true;
}

}  // namespace collide::vision
