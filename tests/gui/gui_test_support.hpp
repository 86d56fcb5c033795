#pragma once
// Shared by the GUI tests: one QApplication (offscreen unless the environment
// chose a platform, e.g. xcb under Xvfb), temporary folders, profiles, and
// screenshots of the views.
#include <gtest/gtest.h>
#include <unistd.h>

#include <QApplication>
#include <QDir>
#include <QString>
#include <QTest>
#include <QWidget>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <vector>

#include "app/campaign.hpp"
#include "hw/rig_profile.hpp"

namespace collide::gui::testing {

inline QApplication& application() {
  static int argc = 1;
  static char name[] = "collide-gui-test";
  static char* argv[] = {name, nullptr};
  if (qEnvironmentVariableIsEmpty("QT_QPA_PLATFORM")) qputenv("QT_QPA_PLATFORM", "offscreen");
  // Never destroyed: gtest_main returns from main() and static destructors
  // would otherwise tear the application down after Qt's own globals.
  static QApplication* app = [] {
    auto* a = new QApplication(argc, argv);
    QApplication::setOrganizationName("collide-tests");
    QApplication::setApplicationName("collide-gui-test");
    return a;
  }();
  return *app;
}

/// Removes the folders freshDir() made once every test has run, or keeps
/// them (and says where) when a test failed, for a look. Without it each run
/// left ~0.3 GB in /tmp (a campaign's shots), and a machine that runs the
/// suite often fills its disk.
class ScratchFolders : public ::testing::Environment {
 public:
  static ScratchFolders& instance() {
    static ScratchFolders* folders = [] {
      auto* f = new ScratchFolders;
      ::testing::AddGlobalTestEnvironment(f);  // gtest owns it from here
      return f;
    }();
    return *folders;
  }
  void add(const std::filesystem::path& dir) {
    std::lock_guard lock(mutex_);
    dirs_.push_back(dir);
  }
  void TearDown() override {
    std::lock_guard lock(mutex_);
    const bool keep = ::testing::UnitTest::GetInstance()->Failed();
    for (const auto& dir : dirs_) {
      std::error_code ignored;
      if (keep)
        std::fprintf(stderr, "[ scratch  ] kept %s for a look\n", dir.c_str());
      else
        std::filesystem::remove_all(dir, ignored);
    }
    dirs_.clear();
  }

 private:
  std::mutex mutex_;
  std::vector<std::filesystem::path> dirs_;
};
// Registered before RUN_ALL_TESTS, so its TearDown runs after the last test.
inline const bool scratch_folders_registered = (ScratchFolders::instance(), true);

inline std::string freshDir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("collide-gui-" + name + "-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  ScratchFolders::instance().add(dir);
  return dir.string();
}

inline std::string sourcePath(const std::string& relative) {
  return std::string(COLLIDE_SOURCE_DIR) + "/" + relative;
}

/// config/sim.toml, aimed (launcher 2's slide moved) so that shots at these
/// speeds meet at `incidence_deg`, written into `dir`. Returns its path.
inline std::string aimedSimProfile(const std::string& dir, double incidence_deg,
                                   std::array<double, 2> speeds) {
  auto profile = hw::loadRigProfile(sourcePath("config/sim.toml"));
  if (!profile) throw std::runtime_error(profile.error().message);
  auto aimed = app::aimForIncidence(*profile, incidence_deg, speeds);
  if (!aimed) throw std::runtime_error(aimed.error().message);
  const std::string path = dir + "/rig.toml";
  std::ofstream(path) << aimed->text;
  return path;
}

/// Saves a picture of `widget` as <name>.png into the build tree, and into
/// docs/screenshots/ when COLLIDE_UPDATE_SCREENSHOTS=1 (how the committed
/// pictures are kept current). Returns false if a file could not be written.
inline bool screenshot(QWidget* widget, const QString& name) {
  QApplication::processEvents();
  const QPixmap picture = widget->grab();
  bool ok = true;
  const QString build_dir = QString(COLLIDE_BINARY_DIR) + "/screenshots";
  QDir().mkpath(build_dir);
  ok = picture.save(build_dir + "/" + name + ".png") && ok;
  if (qgetenv("COLLIDE_UPDATE_SCREENSHOTS") == "1") {
    const QString docs = QString(COLLIDE_SOURCE_DIR) + "/docs/screenshots";
    QDir().mkpath(docs);
    ok = picture.save(docs + "/" + name + ".png") && ok;
  }
  return ok;
}

}  // namespace collide::gui::testing
