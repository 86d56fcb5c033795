// The rig's control thread (RigWorker) on its own, without the window: what
// the window asks of it from any thread is done on the control thread, and
// every signal comes back on the thread that made the worker, in the order
// the control thread sent it. Requests and signals cross through Mailbox
// (a std::mutex ThreadSanitizer sees), so this file also runs in
// `./collide.sh tsan`, where any report fails it.
#include <gtest/gtest.h>

#include <QSignalSpy>
#include <QThread>
#include <atomic>
#include <filesystem>
#include <set>
#include <thread>
#include <vector>

#include "app/gui/mailbox.hpp"
#include "app/gui/rig_worker.hpp"
#include "gui_test_support.hpp"

using namespace collide;
using namespace collide::gui;
using namespace collide::gui::testing;

namespace {

// Where (which thread) each of the worker's signals was heard, and in what
// order: direct connections, so the slot runs on the emitting thread.
struct Heard {
  std::set<QThread*> threads;
  std::vector<QString> order;
  RigStatus last_status;
  void listen(RigWorker& w) {
    auto note = [this](const QString& what) {
      threads.insert(QThread::currentThread());
      order.push_back(what);
    };
    QObject::connect(&w, &RigWorker::profileLoaded, [note] { note("profileLoaded"); });
    QObject::connect(&w, &RigWorker::status, [this, note](const RigStatus& s) {
      last_status = s;
      note("status");
    });
    QObject::connect(&w, &RigWorker::error, [note](QString m) { note("error: " + m); });
    QObject::connect(&w, &RigWorker::shotStep, [note] { note("shotStep"); });
    QObject::connect(&w, &RigWorker::shotFired, [note] { note("shotFired"); });
    QObject::connect(&w, &RigWorker::campaignProgress, [note] { note("campaignProgress"); });
    QObject::connect(&w, &RigWorker::campaignFinished, [note] { note("campaignFinished"); });
    QObject::connect(&w, &RigWorker::reconnectFinished, [note] { note("reconnectFinished"); });
  }
  QStringList errors() const {
    QStringList out;
    for (const QString& o : order)
      if (o.startsWith("error: ")) out << o;
    return out;
  }
};

}  // namespace

TEST(Mailbox, WorkFromManyThreadsRunsOnTheMailboxThreadInTheOrderEachPostedIt) {
  application();
  Mailbox box;
  constexpr int kThreads = 4, kEach = 500;
  std::vector<std::pair<int, int>> ran;  // touched only on this thread
  std::atomic<int> wrong_thread{0};
  QThread* const here = QThread::currentThread();
  std::vector<std::thread> posters;
  for (int t = 0; t < kThreads; ++t)
    posters.emplace_back([&, t] {
      for (int i = 0; i < kEach; ++i)
        box.post([&, t, i] {
          if (QThread::currentThread() != here) ++wrong_thread;
          ran.emplace_back(t, i);
        });
    });
  for (auto& p : posters) p.join();
  ASSERT_TRUE(QTest::qWaitFor([&] { return ran.size() == kThreads * kEach; }, 10000))
      << ran.size() << " of " << kThreads * kEach << " ran";
  EXPECT_EQ(wrong_thread.load(), 0);
  std::vector<int> next(kThreads, 0);
  for (const auto& [t, i] : ran) {
    EXPECT_EQ(i, next[t]) << "thread " << t << "'s work ran out of order";
    next[t] = i + 1;
  }
}

TEST(Mailbox, WorkRunsOnTheThreadTheMailboxLivesIn) {
  application();
  // Made and moved before the thread starts, as RigWorker does with its
  // inbox: what the thread then sees was set before it existed.
  QThread other;
  Mailbox box;
  box.moveToThread(&other);
  other.start();
  std::atomic<QThread*> ran_on{nullptr};
  box.post([&] { ran_on = QThread::currentThread(); });
  ASSERT_TRUE(QTest::qWaitFor([&] { return ran_on.load() != nullptr; }, 5000));
  EXPECT_EQ(ran_on.load(), &other);
  other.quit();
  other.wait();
}

TEST(Mailbox, WorkThatRunsANestedEventLoopKeepsTheOrder) {
  application();
  Mailbox box;
  std::vector<int> ran;
  box.post([&] {
    ran.push_back(1);
    box.post([&] { ran.push_back(3); });
    QCoreApplication::processEvents();  // delivers 2 (queued before 3), then 3
    ran.push_back(4);
  });
  box.post([&] { ran.push_back(2); });
  ASSERT_TRUE(QTest::qWaitFor([&] { return ran.size() == 4; }, 5000));
  EXPECT_EQ(ran, (std::vector<int>{1, 2, 3, 4}));
}

TEST(Mailbox, WorkStillQueuedWhenItIsDestroyedIsDropped) {
  application();
  int ran = 0;
  {
    Mailbox box;
    box.post([&] { ++ran; });
  }
  QCoreApplication::processEvents();
  EXPECT_EQ(ran, 0);
}

TEST(RigWorkerGui, ShotCampaignAndReconnectRunOnTheControlThreadAndReportOnTheCallers) {
  application();
  const std::string dir = freshDir("rig-worker");
  const std::array<double, 2> speeds{2.2, 2.0};
  const std::string profile = aimedSimProfile(dir, 35.0, speeds);
  RigWorker w;
  // Its requests are delivered where it lives: on the control thread.
  ASSERT_EQ(w.thread(), w.controlThread());
  Heard heard;
  heard.listen(w);
  QSignalSpy loaded(&w, &RigWorker::profileLoaded);
  QSignalSpy fired(&w, &RigWorker::shotFired);
  QSignalSpy finished(&w, &RigWorker::campaignFinished);
  QSignalSpy progress(&w, &RigWorker::campaignProgress);
  QSignalSpy reconnected(&w, &RigWorker::reconnectFinished);

  // Asked from another thread (any thread may ask).
  std::thread([&] { w.requestLoadProfile(QString::fromStdString(profile)); }).join();
  ASSERT_TRUE(loaded.wait(20000)) << heard.errors().join("\n").toStdString();
  ASSERT_TRUE(loaded.first().at(1).value<CameraPtr>()) << "no camera built";

  w.requestArm(speeds);
  ASSERT_TRUE(
      QTest::qWaitFor([&] { return heard.last_status.armed && heard.last_status.settled; }, 20000))
      << "never armed and settled: " << heard.errors().join("\n").toStdString();

  const std::string shots = dir + "/shots";
  std::filesystem::create_directories(shots);
  w.requestFire(speeds, QString::fromStdString(shots));
  ASSERT_TRUE(fired.wait(60000)) << heard.errors().join("\n").toStdString();
  const auto shot = fired.first().at(0).value<ShotPtr>();
  const QString file = fired.first().at(1).toString();
  EXPECT_EQ(shot->status, hw::ShotStatus::Ok) << shot->failure_reason;
  EXPECT_TRUE(fired.first().at(2).toString().isEmpty()) << "not saved";
  EXPECT_TRUE(std::filesystem::exists(file.toStdString())) << file.toStdString();
  // The steps came before the shot, and the shot after the state that says
  // the rig is no longer busy (its buttons answer when the shot is shown).
  const auto at = [&](const QString& what) {
    return std::find(heard.order.begin(), heard.order.end(), what) - heard.order.begin();
  };
  EXPECT_LT(at("shotStep"), at("shotFired"));
  EXPECT_EQ(heard.order[at("shotFired") - 1], "status");
  EXPECT_FALSE(heard.last_status.busy);

  app::CampaignOptions options;
  options.shots = 2;
  options.out_dir = dir + "/campaign";
  options.angle_min_deg = 20;
  options.angle_max_deg = 40;
  w.requestCampaign(options);
  ASSERT_TRUE(finished.wait(120000)) << heard.errors().join("\n").toStdString();
  EXPECT_EQ(progress.count(), 2);
  EXPECT_TRUE(finished.first().at(2).toBool()) << finished.first().at(0).toString().toStdString();

  w.requestReconnect();
  ASSERT_TRUE(reconnected.wait(20000));
  EXPECT_TRUE(reconnected.first().at(0).toBool());
  EXPECT_TRUE(reconnected.first().at(1).toString().contains("Nothing to reconnect"));

  EXPECT_EQ(heard.threads, std::set<QThread*>{QThread::currentThread()})
      << "a signal was emitted on another thread than the worker's creator's";
  EXPECT_TRUE(heard.errors().isEmpty()) << heard.errors().join("\n").toStdString();
}

TEST(RigWorkerGui, ACampaignCancelledFromAnotherThreadStopsAndSaysSo) {
  application();
  const std::string dir = freshDir("rig-worker-cancel");
  const std::string profile = aimedSimProfile(dir, 35.0, {2.2, 2.0});
  RigWorker w;
  QSignalSpy loaded(&w, &RigWorker::profileLoaded);
  QSignalSpy finished(&w, &RigWorker::campaignFinished);
  std::atomic<bool> first_shot{false};
  QObject::connect(&w, &RigWorker::campaignProgress, [&] { first_shot = true; });
  w.requestLoadProfile(QString::fromStdString(profile));
  ASSERT_TRUE(loaded.wait(20000));

  app::CampaignOptions options;
  options.shots = 20;
  options.out_dir = dir + "/campaign";
  w.requestCampaign(options);
  ASSERT_TRUE(QTest::qWaitFor([&] { return first_shot.load(); }, 60000));
  std::thread([&] { w.requestCancel(); }).join();
  ASSERT_TRUE(finished.wait(60000));
  const QString summary = finished.first().at(0).toString();
  EXPECT_TRUE(finished.first().at(1).toBool())
      << "not reported as cancelled: " << summary.toStdString();
  EXPECT_FALSE(finished.first().at(2).toBool());
  EXPECT_TRUE(summary.contains("after the cancel")) << summary.toStdString();
}
