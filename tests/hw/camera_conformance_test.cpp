// The Camera conformance suite (camera_conformance.hpp) over the simulated
// and replay cameras.
#include "camera_conformance.hpp"

#include "hw/camera_replay.hpp"
#include "hw/camera_sim.hpp"
#include "hw/sim_world.hpp"

using namespace collide::hw;
using namespace collide::hw::testing;

namespace {

CameraBench simBench() {
  auto world = *SimWorld::create(*defaultRigProfile(), monotonicClock());
  CameraSimSettings s;
  s.noise_grey = 1.0;
  CameraConfig c{0, 0, 160, 120, PixelFormat::Mono8, 1000.0, 200.0, 0.0};
  CameraBench b{world, std::make_unique<CameraSim>(world, s), c};
  b.no_unplug_reason =
      "the simulated camera goes silent (camera.silent_after_bursts), it does not go away: the "
      "shot that gets no frame marks it lost (tests/hw/device_lost_sim_test.cpp)";
  return b;
}

// A stored burst of 12 pre- and 20 post-trigger frames at 500 frames/s.
Burst storedBurst() {
  Burst b;
  b.format = PixelFormat::Mono12;
  b.fps = 500.0;
  b.exposure_us = 100.0;
  for (int id = -12; id < 20; ++id) {
    collide::vision::Frame f;
    f.id = id;
    f.timestamp_ns = 7'000'000'000 + id * 2'000'000;
    f.image = cv::Mat(48, 64, CV_16UC1, cv::Scalar(1000 + id));
    b.frames.push_back(f);
  }
  return b;
}

CameraBench replayBench() {
  CameraConfig c{0, 0, 64, 48, PixelFormat::Mono12, 500.0, 100.0, 0.0};
  CameraBench b{nullptr, std::make_unique<CameraReplay>(storedBurst(), "stored", true), c};
  b.no_unplug_reason = "a replay camera plays a stored burst: it has no device that can go away";
  return b;
}

}  // namespace

INSTANTIATE_TEST_SUITE_P(Backends, CameraConformance,
                         ::testing::Values(CameraBackend{"sim", &simBench},
                                           CameraBackend{"replay", &replayBench}),
                         [](const auto& info) { return info.param.name; });
