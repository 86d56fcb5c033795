// A shot file read by h5py, with none of our code: the layout in
// docs/shot-format.md is what other tools see. Skips when no python3 on the
// machine can import h5py (Debian: python3-h5py).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "app/store/shot_file.hpp"
#include "tests/app/shot_fixtures.hpp"

namespace {

using namespace collide::testing;

/// The first python3 that imports h5py (a virtualenv's python3 on PATH may
/// lack the Debian package that the system one has).
std::string pythonWithH5py() {
  for (const char* python : {"python3", "/usr/bin/python3"}) {
    const std::string probe = std::string(python) + " -c 'import h5py' >/dev/null 2>&1";
    if (std::system(probe.c_str()) == 0) return python;
  }
  return "";
}

/// Runs `script` with `python` on `h5_path`; returns its stdout parsed as JSON.
nlohmann::json runPython(const std::string& python, const ScratchDir& dir,
                         const std::string& script, const std::string& h5_path) {
  const std::string script_path = dir.file("read.py");
  writeAll(script_path, script);
  const std::string command = python + " '" + script_path + "' '" + h5_path + "'";
  FILE* pipe = popen(command.c_str(), "r");
  std::string out;
  char buf[4096];
  std::size_t n;
  while (pipe && (n = fread(buf, 1, sizeof buf, pipe)) > 0) out.append(buf, n);
  const int status = pipe ? pclose(pipe) : -1;
  EXPECT_EQ(status, 0) << "python failed; output: " << out;
  return nlohmann::json::parse(out, nullptr, false);
}

class H5py : public ::testing::Test {
 protected:
  void SetUp() override {
    python = pythonWithH5py();
    if (python.empty())
      GTEST_SKIP() << "no python3 can import h5py (install python3-h5py to run this test)";
  }
  std::string python;
  ScratchDir dir;
};

TEST_F(H5py, ReadsFramesTruthAndAttributesWithoutOurCode) {
  ShotSpec spec;
  spec.format = collide::vision::PixelFormat::Mono16;
  const auto shot = makeShot(spec);
  const std::string path = dir.file("shot.h5");
  ASSERT_TRUE(collide::app::writeShot(path, shot, {.compress = true}).ok());

  const auto j = runPython(python, dir, R"(
import h5py, json, sys
with h5py.File(sys.argv[1], "r") as f:
    images = f["frames/images"]
    print(json.dumps({
        "shape": list(images.shape),
        "dtype": str(images.dtype),
        "frame0_sum": int(images[0].astype("int64").sum()),
        "frame4_px_y5_x7": int(images[4, 5, 7]),
        "images_units": images.attrs["units"],
        "frame_ids": [int(i) for i in f["frames/id"][:]],
        "shot_id": f.attrs["id"],
        "format_version": int(f.attrs["format_version"]),
        "position_units": f["truth/position_m"].attrs["units"],
        "position_f1_s0": [float(v) for v in f["truth/position_m"][1, 0, :]],
        "orientation_f2_s1": [float(v) for v in f["truth/orientation_wxyz"][2, 1, :]],
        "t_collision_s": float(f["truth/t_collision_s"][()]),
        "rig_profile": f["rig_profile_toml"][()].decode("utf-8"),
    }))
)",
                           path);
  ASSERT_TRUE(j.is_object()) << "python printed no JSON";
  const auto& frames = shot.burst.frames;
  EXPECT_EQ(j["shape"], nlohmann::json::array({6, spec.height, spec.width}));
  EXPECT_EQ(j["dtype"], "uint16");
  EXPECT_EQ(j["frame0_sum"].get<double>(), cv::sum(frames[0].image)[0]);
  EXPECT_EQ(j["frame4_px_y5_x7"], frames[4].image.at<std::uint16_t>(5, 7));
  EXPECT_EQ(j["images_units"], "DN");
  EXPECT_EQ(j["frame_ids"], nlohmann::json::array({-2, -1, 0, 1, 2, 3}));
  EXPECT_EQ(j["shot_id"], shot.id);
  EXPECT_EQ(j["format_version"], collide::app::kShotFormatVersion);
  EXPECT_EQ(j["position_units"], "m");
  const auto& truth = *shot.truth;
  const collide::Vec3& p = truth.states[1][0].position_m;
  EXPECT_EQ(j["position_f1_s0"], nlohmann::json::array({p.x(), p.y(), p.z()}));
  const auto& q = truth.states[2][1].orientation;
  EXPECT_EQ(j["orientation_f2_s1"], nlohmann::json::array({q.w(), q.x(), q.y(), q.z()}));
  EXPECT_EQ(j["t_collision_s"], truth.t_collision_s);
  EXPECT_EQ(j["rig_profile"], shot.rig_profile_toml);
}

TEST_F(H5py, EveryDatasetCarriesUnits) {
  const std::string path = dir.file("shot.h5");
  ASSERT_TRUE(collide::app::writeShot(path, makeShot()).ok());
  const auto j = runPython(python, dir, R"(
import h5py, json, sys
datasets, without_units = [], []
def visit(name, obj):
    if isinstance(obj, h5py.Dataset):
        datasets.append(name)
        if "units" not in obj.attrs:
            without_units.append(name)
with h5py.File(sys.argv[1], "r") as f:
    f.visititems(visit)
print(json.dumps({"datasets": datasets, "without_units": without_units}))
)",
                           path);
  ASSERT_TRUE(j.is_object()) << "python printed no JSON";
  EXPECT_EQ(j["without_units"], nlohmann::json::array());
  // Sanity: the walk saw the whole layout, truth and results included.
  EXPECT_GT(j["datasets"].size(), 50u);
  EXPECT_THAT(j["datasets"].get<std::vector<std::string>>(),
              ::testing::IsSupersetOf({"frames/images", "truth/spin_rad_s", "results/json",
                                       "results/gamma_deg", "launchers/readback_kPa"}));
}

// Files edited by another program: a dataset deleted is named; frames whose
// declared size no camera has are refused before any allocation, while the
// metadata (listing, cataloguing) still reads.
TEST_F(H5py, AMissingDatasetIsNamed) {
  const std::string path = dir.file("shot.h5");
  ASSERT_TRUE(collide::app::writeShot(path, makeShot()).ok());
  runPython(python, dir, R"(
import h5py, sys
with h5py.File(sys.argv[1], "r+") as f:
    del f["frames/timestamp_ns"]
print("{}")
)",
            path);
  const auto read = collide::app::readShot(path, {.frames = false});
  ASSERT_FALSE(read.ok());
  EXPECT_THAT(read.error().message,
              ::testing::AllOf(::testing::HasSubstr(path),
                               ::testing::HasSubstr("lacks dataset /frames/timestamp_ns")));
}

TEST_F(H5py, FramesLargerThanAnyCameraAreRefusedBeforeAllocating) {
  const std::string path = dir.file("shot.h5");
  ShotSpec spec;
  spec.frames = 70;
  ASSERT_TRUE(collide::app::writeShot(path, makeShot(spec)).ok());
  // 70 frames of 60000 x 60000 (252 GB declared), chunked so the file stays small.
  runPython(python, dir, R"(
import h5py, sys
with h5py.File(sys.argv[1], "r+") as f:
    attrs = dict(f["frames/images"].attrs)
    del f["frames/images"]
    d = f.create_dataset("frames/images", shape=(70, 60000, 60000), dtype="u1",
                         chunks=(1, 600, 600))
    for k, v in attrs.items():
        d.attrs[k] = v
print("{}")
)",
            path);
  const auto read = collide::app::readShot(path);
  ASSERT_FALSE(read.ok());
  EXPECT_THAT(
      read.error().message,
      ::testing::AllOf(::testing::HasSubstr(path),
                       ::testing::HasSubstr("60000 x 60000 pixels, larger than any camera")));
  const auto listed = collide::app::readShot(path, {.frames = false});
  EXPECT_TRUE(listed.ok()) << listed.error().message;
}

}  // namespace
