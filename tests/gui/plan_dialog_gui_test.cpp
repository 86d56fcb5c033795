// Planning a shot from the GUI (issue 16 §1), driven by typing and clicks:
// a feasible wish shows how to set the rig, an infeasible one says why and
// plans the nearest feasible shot on one click, and "use this plan" loads
// the aimed profile and sets the launchers, so the shot fired next is the
// planned one (its recorded profile is the aimed one, its exit speeds the
// planned ones).
#include <gtest/gtest.h>

#include <QAbstractSpinBox>
#include <QLabel>
#include <QLineEdit>
#include <QPushButton>

#include "app/gui/main_window.hpp"
#include "app/gui/plan_dialog.hpp"
#include "app/gui/rig_panel.hpp"
#include "gui_test_support.hpp"
#include "gui_window_support.hpp"

using namespace collide;
using namespace collide::gui;
using namespace collide::gui::testing;

namespace {}  // namespace

TEST(PlanDialogGui, PlansRefusesWithTheNearestAndLoadsTheAimedProfile) {
  application();
  const std::string dir = freshDir("plan");
  MainWindow w(windowOptions(sourcePath("config/sim.toml"), dir + "/shots"));
  w.resize(1366, 768);
  w.show();
  ASSERT_TRUE(QTest::qWaitFor([&] { return w.profile() != nullptr; }, 20000));
  PlanDialog* dialog = w.openPlanDialog();
  ASSERT_NE(dialog, nullptr);
  auto* incidence = child<QAbstractSpinBox>(dialog, "plan_incidence");
  auto* speed = child<QAbstractSpinBox>(dialog, "plan_speed");
  auto* plan = child<QPushButton>(dialog, "plan_button");

  typeInto(incidence, "30");
  typeInto(speed, "1.8");
  QTest::mouseClick(plan, Qt::LeftButton);
  ASSERT_TRUE(dialog->currentPlan()) << dialog->shownText().toStdString();
  EXPECT_NEAR(dialog->currentPlan()->incidence_deg, 30.0, 0.05);
  EXPECT_NEAR(dialog->currentPlan()->speed_at_contact_m_s[0], 1.8, 0.01);
  EXPECT_TRUE(dialog->shownText().contains("kPa"));

  // Faster than the launch calibration reaches: refused, with the nearest.
  typeInto(speed, "25");
  QTest::mouseClick(plan, Qt::LeftButton);
  EXPECT_FALSE(dialog->currentPlan());
  EXPECT_TRUE(dialog->shownText().contains("cannot be fired")) << dialog->shownText().toStdString();
  ASSERT_TRUE(dialog->nearest());
  auto* nearest = child<QPushButton>(dialog, "plan_nearest");
  ASSERT_TRUE(nearest->isEnabled());
  QTest::mouseClick(nearest, Qt::LeftButton);
  ASSERT_TRUE(dialog->currentPlan()) << dialog->shownText().toStdString();
  EXPECT_LT(dialog->currentPlan()->speed_at_contact_m_s[0], 25.0);

  // Back to the wish, used: the aimed profile is loaded and the launchers set.
  typeInto(speed, "1.8");
  QTest::mouseClick(plan, Qt::LeftButton);
  ASSERT_TRUE(dialog->currentPlan());
  const app::ShotPlan planned = *dialog->currentPlan();
  const QString aimed_path = QString::fromStdString(dir + "/aimed.toml");
  ASSERT_TRUE(dialog->applyTo(aimed_path).isEmpty());
  ASSERT_TRUE(QTest::qWaitFor(
      [&] {
        return w.profile() && QString::fromStdString(w.profile()->source) == aimed_path &&
               std::abs(w.rigPanel()->wantedSpeeds()[0] - planned.exit_speed_m_s[0]) < 0.01;
      },
      20000));
  EXPECT_NEAR(w.rigPanel()->wantedSpeeds()[1], planned.exit_speed_m_s[1], 0.01);

  // Fired: the shot records the aimed profile and the planned exit speeds.
  ASSERT_TRUE(QTest::qWaitFor(
      [&] { return child<QPushButton>(w.rigPanel(), "arm_button")->isEnabled(); }, 20000));
  QTest::mouseClick(child<QPushButton>(w.rigPanel(), "arm_button"), Qt::LeftButton);
  auto* fire = child<QPushButton>(w.rigPanel(), "fire_button");
  ASSERT_TRUE(QTest::qWaitFor([&] { return fire->isEnabled(); }, 20000));
  QTest::mouseClick(fire, Qt::LeftButton);
  ASSERT_TRUE(QTest::qWaitFor([&] { return w.lastShot() != nullptr; }, 20000));
  const hw::Shot& shot = *w.lastShot();
  ASSERT_EQ(shot.status, hw::ShotStatus::Ok) << shot.failure_reason;
  EXPECT_EQ(shot.rig_profile_toml, planned.aimed.text);
  for (int i = 0; i < 2; ++i)
    EXPECT_NEAR(shot.launchers[i].wanted_speed_m_s, planned.exit_speed_m_s[i], 0.01);
  EXPECT_TRUE(screenshot(dialog, "plan_dialog"));
}
