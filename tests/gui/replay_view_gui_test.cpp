// The replay view's drawings: given an analysis, the detected spheres, the
// fitted trajectories and the contact point land where they belong on each
// frame. The analysis here is built from the simulation's ground truth (the
// spheres' true centres, trajectories fitted to them), so what is checked is
// the drawing, independently of the vision core.
#include <gtest/gtest.h>

#include <QLabel>
#include <QPushButton>
#include <QSlider>

#include "analysis/trajectory.hpp"
#include "app/gui/replay_view.hpp"
#include "app/rig_setup.hpp"
#include "gui_test_support.hpp"
#include "hw/sequencer.hpp"

using namespace collide;
using namespace collide::gui;
using namespace collide::gui::testing;

namespace {

QPointF pixelOf(const hw::Shot& shot, const Vec3& p) {
  const double s = shot.scene.pixel_size_m;
  return {shot.scene.origin_u_px + p.x() / s, shot.scene.origin_v_px - p.y() / s};
}

struct Fixture {
  hw::Shot shot;
  vision::ShotAnalysis analysis;
};

Fixture simulatedShotWithTruthAnalysis() {
  auto profile = hw::loadRigProfile(sourcePath("config/sim.toml"));
  if (!profile) throw std::runtime_error(profile.error().message);
  auto rig = app::buildRig(*profile);
  if (!rig) throw std::runtime_error(rig.error().message);
  Fixture f{hw::Sequencer(*rig).fire(hw::ShotRequest::atSpeeds(2.1, 1.9)), {}};
  (void)hw::shutDown(*rig);
  if (f.shot.status != hw::ShotStatus::Ok || !f.shot.truth) throw std::runtime_error("shot failed");
  const hw::TruthRecord& truth = *f.shot.truth;
  vision::ShotAnalysis& a = f.analysis;
  a.pixel_size_m = f.shot.scene.pixel_size_m;
  const double t0 = truth.t_s.front();  // the analysis clock starts at the first frame
  const double tc = truth.t_collision_s - t0;
  for (std::size_t k = 0; k < truth.t_s.size(); ++k) {
    vision::FrameDetections fd;
    fd.frame_id = truth.frame_id[k];
    fd.t_s = truth.t_s[k] - t0;
    for (int i = 0; i < 2; ++i) {
      const QPointF px = pixelOf(f.shot, truth.states[k][i].position_m);
      fd.sphere[i] = vision::SphereDetection{px.x(), px.y(),
                                             0.5 * f.shot.scene.diameter_m[i] / a.pixel_size_m};
    }
    a.frames.push_back(fd);
  }
  for (int i = 0; i < 2; ++i)
    for (int side = 0; side < 2; ++side) {
      std::vector<double> t;
      std::vector<Vec3> p;
      for (std::size_t k = 0; k < truth.t_s.size(); ++k)
        if ((side == 0) == (truth.t_s[k] - t0 < tc)) {
          t.push_back(truth.t_s[k] - t0);
          p.push_back(truth.states[k][i].position_m);
        }
      Eigen::VectorXd times(t.size());
      Eigen::MatrixXd pos(t.size(), 2);
      for (std::size_t k = 0; k < t.size(); ++k) {
        times[k] = t[k];
        pos(k, 0) = p[k].x();
        pos(k, 1) = p[k].y();
      }
      auto fit = fitTrajectory(times, pos, Weights::equal(), tc);
      if (fit) a.trajectory[i][side] = *fit;
    }
  a.collision.t_collision_s.value = tc;
  return f;
}

}  // namespace

TEST(ReplayViewGui, OverlaysSitWhereTheTruthIs) {
  application();
  const Fixture f = simulatedShotWithTruthAnalysis();
  const hw::TruthRecord& truth = *f.shot.truth;
  ASSERT_TRUE(f.analysis.trajectory[0][0] && f.analysis.trajectory[1][0]);
  for (std::size_t k : {std::size_t(5), f.shot.burst.frames.size() - 5}) {
    const Overlay o = analysisOverlay(f.shot, f.analysis, k);
    ASSERT_EQ(o.circles.size(), 2u);
    for (int i = 0; i < 2; ++i) {
      const QPointF px = pixelOf(f.shot, truth.states[k][i].position_m);
      EXPECT_NEAR(o.circles[i].centre.x(), px.x(), 1e-6);
      EXPECT_NEAR(o.circles[i].centre.y(), px.y(), 1e-6);
    }
    // Four fitted paths: two spheres, before and after the impact.
    ASSERT_EQ(o.paths.size(), 4u);
    // The fitted centres at this frame's instant, one per sphere.
    int fitted = 0;
    for (const auto& m : o.markers) {
      for (int i = 0; i < 2; ++i) {
        const QPointF px = pixelOf(f.shot, truth.states[k][i].position_m);
        if (std::hypot(m.at.x() - px.x(), m.at.y() - px.y()) < 0.5) ++fitted;
      }
    }
    EXPECT_EQ(fitted, 2) << "frame " << k;
  }
  // The contact marker: midway between the centres at the true contact.
  const Overlay o = analysisOverlay(f.shot, f.analysis, 10);
  // (The red cross; its time is in the caption, not written over the spheres.)
  const auto contact =
      std::find_if(o.markers.begin(), o.markers.end(),
                   [](const Overlay::Marker& m) { return m.colour == QColor(255, 80, 60); });
  ASSERT_NE(contact, o.markers.end());
  std::size_t kc = 0;
  for (std::size_t k = 0; k < truth.t_s.size(); ++k)
    if (truth.t_s[k] < truth.t_collision_s) kc = k;
  // The truth at the last frame before contact, flown on to the contact.
  const double dt = truth.t_collision_s - truth.t_s[kc];
  Vec3 mid = Vec3::Zero();
  for (int i = 0; i < 2; ++i) {
    const SphereState& s = truth.states[kc][i];
    mid += 0.5 * (s.position_m + s.velocity_m_s * dt + 0.5 * kGravity_m_s2 * dt * dt);
  }
  const QPointF px = pixelOf(f.shot, mid);
  EXPECT_NEAR(contact->at.x(), px.x(), 0.5);
  EXPECT_NEAR(contact->at.y(), px.y(), 0.5);
}

TEST(ReplayViewGui, StepsThroughTheBurstWithItsOverlays) {
  application();
  auto f = std::make_shared<Fixture>(simulatedShotWithTruthAnalysis());
  ReplayView view;
  view.resize(1000, 600);
  view.show();
  view.setShot(ShotPtr(f, &f->shot));
  view.setAnalysis(AnalysisPtr(f, &f->analysis));
  const int n = static_cast<int>(f->shot.burst.frames.size());
  EXPECT_EQ(view.frameCount(), n);
  EXPECT_EQ(f->shot.burst.frames[view.frameIndex()].id, 0) << "opens at the trigger frame";
  QTest::mouseClick(view.findChild<QPushButton*>("first_frame"), Qt::LeftButton);
  EXPECT_EQ(view.frameIndex(), 0);
  QTest::mouseClick(view.findChild<QPushButton*>("previous_frame"), Qt::LeftButton);
  EXPECT_EQ(view.frameIndex(), 0);
  QTest::mouseClick(view.findChild<QPushButton*>("last_frame"), Qt::LeftButton);
  EXPECT_EQ(view.frameIndex(), n - 1);
  view.findChild<QSlider*>("frame_slider")->setValue(7);
  EXPECT_EQ(view.frameIndex(), 7);
  EXPECT_EQ(view.imageView()->overlay().circles.size(), 2u);
  EXPECT_TRUE(view.imageView()->overlay().caption.contains(
      QString("frame %1").arg(f->shot.burst.frames[7].id)));
  // Play runs to the end on its own.
  QTest::mouseClick(view.findChild<QPushButton*>("play"), Qt::LeftButton);
  ASSERT_TRUE(QTest::qWaitFor([&] { return view.frameIndex() == n - 1; }, 20000));
}

// Issue 14: Replay speaks one clock, the trigger's (frame 0): the frame time
// and the contact time in the caption agree with the simulation's truth on
// it; no text is drawn over the spheres, and a legend says what the colours are.
TEST(ReplayViewGui, FrameAndContactTimesShareTheTriggerClock) {
  application();
  auto f = std::make_shared<Fixture>(simulatedShotWithTruthAnalysis());
  ReplayView view;
  view.resize(1366, 700);
  view.show();
  view.setShot(ShotPtr(f, &f->shot));
  view.setAnalysis(AnalysisPtr(f, &f->analysis));
  const hw::TruthRecord& truth = *f->shot.truth;
  // The true contact on the trigger clock: from the truth sample of a frame.
  std::size_t k = 0;
  for (std::size_t i = 0; i < truth.t_s.size(); ++i)
    if (truth.t_s[i] < truth.t_collision_s) k = i;
  const double contact_ms =
      (truth.t_collision_s - truth.t_s[k] + truth.frame_id[k] / f->shot.burst.fps) * 1e3;
  // Step (clicks) to the frame just after the contact.
  QTest::mouseClick(view.findChild<QPushButton*>("first_frame"), Qt::LeftButton);
  while (f->shot.burst.frames[view.frameIndex()].id * 1e3 / f->shot.burst.fps < contact_ms &&
         view.frameIndex() + 1 < view.frameCount())
    QTest::mouseClick(view.findChild<QPushButton*>("next_frame"), Qt::LeftButton);
  const Overlay& o = view.imageView()->overlay();
  const QString caption = o.caption;
  const int at = caption.indexOf("contact at ");
  ASSERT_GE(at, 0) << caption.toStdString();
  const double shown_ms = caption.mid(at + 11).section(' ', 0, 0).toDouble();
  EXPECT_NEAR(shown_ms, contact_ms, 0.05) << caption.toStdString();
  const double frame_ms = caption.section("t = ", 1).section(' ', 0, 0).toDouble();
  EXPECT_GE(frame_ms, shown_ms) << "the frame after the contact is later than it";
  EXPECT_LT(frame_ms - shown_ms, 1e3 / f->shot.burst.fps + 1e-6);
  for (const auto& m : o.markers) EXPECT_TRUE(m.label.isEmpty()) << m.label.toStdString();
  EXPECT_GE(o.legend.size(), 3u);
  EXPECT_TRUE(screenshot(&view, "replay_contact"));
}
