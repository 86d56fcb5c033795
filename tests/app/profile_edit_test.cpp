// Editing a rig profile: values change, comments and other lines stay, the
// result parses to the new values, and the file is replaced with a backup.
#include "app/profile_edit.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "hw/rig_profile.hpp"

using namespace collide;
using namespace collide::app;

namespace {

std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string simText() {
  return readText(std::string(COLLIDE_SOURCE_DIR) + "/config/sim.toml");
}

}  // namespace

TEST(ProfileEdit, SetsAValueKeepsItsCommentAndParses) {
  const std::string text = simText();
  auto edited = setProfileValue(text, "burst", "post_trigger_frames", "25");
  ASSERT_TRUE(edited) << edited.error().message;
  EXPECT_NE(edited->find("post_trigger_frames = 25"), std::string::npos);
  EXPECT_NE(edited->find("# frames from the trigger on"), std::string::npos);
  auto p = hw::parseRigProfile(*edited, "edited.toml");
  ASSERT_TRUE(p) << p.error().message;
  EXPECT_EQ(p->burst.post_trigger_frames, 25);
  EXPECT_EQ(p->burst.pre_trigger_frames, 30);  // the other key untouched
  // Only that one line changed.
  int changed = 0;
  std::istringstream a(text), b(*edited);
  for (std::string la, lb; std::getline(a, la) && std::getline(b, lb);) changed += la != lb;
  EXPECT_EQ(changed, 1);
}

TEST(ProfileEdit, CalibrationCoefficientsRoundTripExactly) {
  const std::array<double, 4> c{0.1234567890123, 6.5, -4.75, 3.3333333333333335};
  auto edited = setProfileValue(simText(), "calibration", "coefficients", tomlNumberArray(c));
  ASSERT_TRUE(edited) << edited.error().message;
  auto p = hw::parseRigProfile(*edited, "edited.toml");
  ASSERT_TRUE(p) << p.error().message;
  for (int k = 0; k < 4; ++k) EXPECT_EQ(p->calibration.coefficients[k], c[k]);
}

TEST(ProfileEdit, SameKeyInAnotherSectionIsLeftAlone) {
  const std::string text = "[a]\nfps = 1 # one\n[b]\nfps = 2\n";
  auto edited = setProfileValue(text, "b", "fps", "5");
  ASSERT_TRUE(edited);
  EXPECT_EQ(*edited, "[a]\nfps = 1 # one\n[b]\nfps = 5\n");
}

TEST(ProfileEdit, MissingKeyIsAddedMissingSectionIsAnError) {
  auto added = setProfileValue("[a]\nx = 1\n\n[b]\ny = 2\n", "a", "z", "3");
  ASSERT_TRUE(added);
  EXPECT_EQ(*added, "[a]\nx = 1\nz = 3\n\n[b]\ny = 2\n");
  auto missing = setProfileValue("[a]\nx = 1\n", "camera", "fps", "3");
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().message.find("[camera]"), std::string::npos);
}

TEST(ProfileEdit, WriteKeepsABackupOfThePreviousFile) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("collide-profile-edit-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "rig.toml").string();
  ASSERT_TRUE(writeProfileFile(path, "old\n"));
  EXPECT_FALSE(std::filesystem::exists(path + ".bak"));  // nothing to back up the first time
  std::string backup;
  ASSERT_TRUE(writeProfileFile(path, "new\n", &backup));
  EXPECT_EQ(backup, path + ".bak");
  EXPECT_EQ(readText(path), "new\n");
  EXPECT_EQ(readText(backup), "old\n");
  // No temporary files left behind.
  int files = 0;
  for (auto& e : std::filesystem::directory_iterator(dir)) files += e.is_regular_file();
  EXPECT_EQ(files, 2);
  std::filesystem::remove_all(dir);
}

TEST(ProfileEdit, WriteIntoAMissingFolderFailsNamingTheFile) {
  Status s = writeProfileFile("/nonexistent-collide-dir/rig.toml", "x\n");
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().message.find("/nonexistent-collide-dir/rig.toml"), std::string::npos);
}

TEST(ProfileEdit, TableIsAddedAfterItsParentsTablesAndReplacedWhole) {
  const std::string text =
      "name = \"x\"\n\n[camera]\nbackend = \"sim\"  # the camera\n\n[camera.imaging]\n"
      "ambient = 0.1\n\n# the burst\n[burst]\npre_trigger_frames = 1\n";
  auto added =
      setProfileTable(text, "camera.calibration", {{"focal_px", "2500"}, {"rms_px", "0.2"}});
  ASSERT_TRUE(added.ok()) << added.error().message;
  EXPECT_EQ(*added,
            "name = \"x\"\n\n[camera]\nbackend = \"sim\"  # the camera\n\n[camera.imaging]\n"
            "ambient = 0.1\n\n[camera.calibration]\nfocal_px = 2500\nrms_px = 0.2\n\n"
            "# the burst\n[burst]\npre_trigger_frames = 1\n");
  // Again with other keys: the old ones go, nothing else moves.
  auto replaced = setProfileTable(*added, "camera.calibration", {{"focal_px", "2400"}});
  ASSERT_TRUE(replaced.ok());
  EXPECT_EQ(*replaced,
            "name = \"x\"\n\n[camera]\nbackend = \"sim\"  # the camera\n\n[camera.imaging]\n"
            "ambient = 0.1\n\n[camera.calibration]\nfocal_px = 2400\n\n"
            "# the burst\n[burst]\npre_trigger_frames = 1\n");
  auto missing = setProfileTable("[burst]\n", "camera.calibration", {{"focal_px", "1"}});
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("no [camera] table"), std::string::npos);
  // The real profile still parses with the table added at its end.
  auto sim = setProfileTable(simText(), "camera.calibration",
                             {{"image_px", "[640, 480]"},
                              {"focal_px", "2500"},
                              {"focal_px_sigma", "5"},
                              {"principal_px", "[320, 240]"},
                              {"principal_px_sigma", "[1, 1]"},
                              {"distortion", "[0, 0, 0, 0]"},
                              {"distortion_sigma", "[0, 0, 0, 0]"}});
  ASSERT_TRUE(sim.ok());
  auto parsed = hw::parseRigProfile(*sim, "sim.toml + calibration");
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  EXPECT_TRUE(parsed->camera_calibration.has_value());
}
