#pragma once
// Where a shot's ground truth comes from: a simulated camera knows exactly
// what it showed; a real one has no truth (Camera::groundTruth() is null).
#include <optional>

#include "hw/shot.hpp"
#include "vision/frame.hpp"

namespace collide::hw {

class TruthSource {
 public:
  virtual ~TruthSource() = default;
  /// The ground truth behind `burst` (one sample per frame, by frame id and
  /// timestamp), or nothing if no simulated shot lies behind it. Control thread.
  virtual std::optional<TruthRecord> truthFor(const vision::Burst& burst) const = 0;
};

}  // namespace collide::hw
