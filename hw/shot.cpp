#include "hw/shot.hpp"

namespace collide::hw {

const char* toString(ShotStatus s) {
  return s == ShotStatus::Ok ? "ok" : "failed";
}

}  // namespace collide::hw
