// The Camera conformance suite (camera_conformance.hpp) over CameraV4l2 on
// the host, against the fake capture driver of fake_v4l2.hpp (the real
// V4l2Device code underneath; vivid in the VM: tests/vm/v4l2_vm_test.cpp).
#include <cerrno>
#include <cstring>
#include <string>

#include "camera_conformance.hpp"
#include "fake_v4l2.hpp"
#include "hw/camera_v4l2.hpp"

using namespace collide::hw;
using namespace collide::hw::testing;

namespace {

// The fake stamps each frame on its own schedule, one period apart from
// STREAMON (as a driver stamping from its hardware clock): hardware-timed.
CameraBench v4l2Bench() {
  CameraBench b;
  CameraV4l2Settings s = fakeV4l2Settings();
  if (s.path.empty()) {
    b.skip_reason =
        std::string("cannot create the fake V4L2 device's memfd: ") + std::strerror(errno);
    return b;
  }
  b.camera = std::make_unique<CameraV4l2>(s);
  b.config = {0, 0, kWidth, kHeight, PixelFormat::Mono8, 100.0, 1000.0, 0.0};
  b.unplug = [] { fake().unplugged = true; };  // every ioctl ENODEV from now on
  b.requests = [] { return fake().calls.load(); };
  return b;
}

}  // namespace

INSTANTIATE_TEST_SUITE_P(V4l2, CameraConformance,
                         ::testing::Values(CameraBackend{"v4l2_fake", &v4l2Bench}),
                         [](const auto& info) { return info.param.name; });
