// Shot files that are well-formed HDF5 (every checksum right) but declare
// what no collide file holds: the reader says what is wrong with the file
// instead of sizing an allocation by it or letting the library write past a
// buffer (issue 15, item 7). Found by tests/fuzz/shot_content_fuzz.cpp; each
// case here failed before the fix: std::bad_alloc ("internal error") for the
// declared sizes, a 12-byte H5Aread into a 4-byte number for the attribute.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <hdf5.h>

#include <string>

#include "app/store/shot_file.hpp"
#include "tests/app/shot_fixtures.hpp"

namespace {

using namespace collide::testing;
using ::testing::AllOf;
using ::testing::HasSubstr;

// A good shot file in `dir`, then `edit` applied to it through the library.
template <class Edit>
std::string editedShot(const ScratchDir& dir, Edit edit) {
  const std::string path = dir.file("shot.h5");
  EXPECT_TRUE(collide::app::writeShot(path, makeShot()).ok());
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  EXPECT_GE(f, 0);
  edit(f);
  H5Fclose(f);
  return path;
}

// Replaces dataset `name` by one of `type` declaring `dims`, never written.
void declareUnwritten(hid_t f, const char* name, hid_t type, std::vector<hsize_t> dims) {
  ASSERT_GE(H5Ldelete(f, name, H5P_DEFAULT), 0);
  const hid_t space = dims.empty()
                          ? H5Screate(H5S_SCALAR)
                          : H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
  const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
  if (!dims.empty()) {
    std::vector<hsize_t> chunk(dims.size(), 1);
    H5Pset_chunk(dcpl, static_cast<int>(chunk.size()), chunk.data());
  }
  const hid_t d = H5Dcreate2(f, name, type, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
  ASSERT_GE(d, 0);
  H5Dclose(d), H5Pclose(dcpl), H5Sclose(space);
}

TEST(ShotReaderBounds, ADatasetDeclaringMoreThanTheFileHoldsIsRefusedNamingIt) {
  ScratchDir dir;
  const std::string path = editedShot(dir, [](hid_t f) {
    declareUnwritten(f, "/frames/id", H5T_STD_I64LE, {hsize_t{1} << 34});  // 137 GB
  });
  const auto read = collide::app::readShot(path, {.frames = false, .contained = false});
  ASSERT_FALSE(read.ok());
  EXPECT_THAT(read.error().message,
              AllOf(HasSubstr(path), HasSubstr("/frames/id"), HasSubstr("declares 17179869184"),
                    HasSubstr("corrupt or incomplete")));
}

TEST(ShotReaderBounds, AHugeFixedLengthStringIsRefusedBeforeItsBuffer) {
  ScratchDir dir;
  const std::string path = editedShot(dir, [](hid_t f) {
    const hid_t type = H5Tcopy(H5T_C_S1);
    H5Tset_size(type, std::size_t{1} << 33);  // one 8.6 GB string
    declareUnwritten(f, "/rig_profile_toml", type, {});
    H5Tclose(type);
  });
  const auto read = collide::app::readShot(path, {.frames = false, .contained = false});
  ASSERT_FALSE(read.ok());
  EXPECT_THAT(read.error().message, AllOf(HasSubstr(path), HasSubstr("/rig_profile_toml")));
}

TEST(ShotReaderBounds, ANumberAttributeHoldingSeveralIsRefused) {
  ScratchDir dir;
  const std::string path = editedShot(dir, [](hid_t f) {
    H5Adelete(f, "format_version");
    const hsize_t three = 3;
    const hid_t space = H5Screate_simple(1, &three, nullptr);
    const hid_t a = H5Acreate2(f, "format_version", H5T_STD_I32LE, space, H5P_DEFAULT, H5P_DEFAULT);
    const std::int32_t values[3] = {1, 1, 1};
    H5Awrite(a, H5T_NATIVE_INT32, values);
    H5Aclose(a), H5Sclose(space);
  });
  const auto read = collide::app::readShot(path, {.frames = false, .contained = false});
  ASSERT_FALSE(read.ok());
  EXPECT_THAT(read.error().message,
              AllOf(HasSubstr(path), HasSubstr("format_version"), HasSubstr("one whole number")));
}

TEST(ShotReaderBounds, AGoodShotStillReads) {
  ScratchDir dir;
  const std::string path = editedShot(dir, [](hid_t) {});
  const auto read = collide::app::readShot(path, {.frames = true, .contained = false});
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_EQ(read->burst.frames.size(), makeShot().burst.frames.size());
}

}  // namespace
