// The live view: its overlay finds the spheres where the simulation put them,
// with their dots, and the view keeps up with a streaming camera at screen
// rate without asking for every frame.
#include <gtest/gtest.h>

#include "app/gui/live_view.hpp"
#include "app/rig_setup.hpp"
#include "gui_test_support.hpp"
#include "hw/sequencer.hpp"

using namespace collide;
using namespace collide::gui;
using namespace collide::gui::testing;

TEST(LiveViewGui, OverlayCirclesSitOnTheTrueSpheres) {
  application();
  auto profile = hw::loadRigProfile(sourcePath("config/sim.toml"));
  ASSERT_TRUE(profile);
  auto rig = app::buildRig(*profile);
  ASSERT_TRUE(rig);
  const hw::Shot shot = hw::Sequencer(*rig).fire(hw::ShotRequest::atSpeeds(2.0, 2.0));
  (void)hw::shutDown(*rig);
  ASSERT_EQ(shot.status, hw::ShotStatus::Ok) << shot.failure_reason;
  ASSERT_TRUE(shot.truth);
  // A frame well before the contact: both spheres whole and apart.
  std::size_t k = 0;
  for (std::size_t i = 0; i < shot.burst.frames.size(); ++i)
    if (shot.burst.frames[i].id == -12) k = i;
  const Overlay o = detectSpheresAndDots(shot.burst.frames[k], shot.burst.format);
  ASSERT_EQ(o.circles.size(), 2u);
  const double s = shot.scene.pixel_size_m;
  for (int i = 0; i < 2; ++i) {
    const Vec3& p = shot.truth->states[k][i].position_m;
    const QPointF truth(shot.scene.origin_u_px + p.x() / s, shot.scene.origin_v_px - p.y() / s);
    // Sorted left to right, like the spheres before impact.
    EXPECT_NEAR(o.circles[i].centre.x(), truth.x(), 1.0) << "sphere " << i;
    EXPECT_NEAR(o.circles[i].centre.y(), truth.y(), 1.0) << "sphere " << i;
    EXPECT_NEAR(o.circles[i].radius, 0.5 * shot.scene.diameter_m[i] / s, 1.0);
  }
  EXPECT_GT(o.markers.size(), 2u) << "dots on the spheres";
  for (const auto& m : o.markers) {
    // Every dot lies on one of the two discs.
    const double d0 =
        std::hypot(m.at.x() - o.circles[0].centre.x(), m.at.y() - o.circles[0].centre.y());
    const double d1 =
        std::hypot(m.at.x() - o.circles[1].centre.x(), m.at.y() - o.circles[1].centre.y());
    EXPECT_LT(std::min(d0 - o.circles[0].radius, d1 - o.circles[1].radius), 0.0);
  }
}

TEST(LiveViewGui, ShowsTheNewestFrameAtScreenRateNotEveryFrame) {
  application();
  auto profile = hw::loadRigProfile(sourcePath("config/sim.toml"));
  ASSERT_TRUE(profile);
  auto rig = app::buildRig(*profile);
  ASSERT_TRUE(rig);
  ASSERT_TRUE(hw::bringUp(*rig));
  rig->camera->setLiveView(true);
  LiveView view;
  view.resize(640, 480);
  view.show();
  view.setRefreshRate(10);
  // The camera is borrowed here; the rig outlives the view in this test.
  view.setCamera(CameraPtr(rig->camera.get(), [](hw::Camera*) {}));
  ASSERT_TRUE(QTest::qWaitFor([&] { return view.framesShown() >= 3; }, 10000));
  // A shot streams 70 frames in a fraction of a second: the view shows a few.
  const auto shown = view.framesShown();
  const auto published = rig->camera->publishedFrames();
  const hw::Shot shot = hw::Sequencer(*rig).fire(hw::ShotRequest::atSpeeds(2.0, 2.0));
  ASSERT_EQ(shot.status, hw::ShotStatus::Ok);
  QTest::qWait(300);
  EXPECT_GE(rig->camera->publishedFrames() - published, 70u);
  EXPECT_LT(view.framesShown() - shown, 20u);
  EXPECT_FALSE(view.imageView()->image().isNull());
  view.setCamera(nullptr);
  (void)hw::shutDown(*rig);
}
