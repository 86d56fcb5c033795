// Frames are stored with HDF5's Fletcher-32 checksum (issue 15 §3): our
// checksum of a direct chunk write is the one the HDF5 library's own filter
// computes, and a frame damaged on disk is named and set aside on reading
// while the rest of the shot stays readable.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <hdf5.h>

#include <fstream>
#include <random>
#include <vector>

#include "app/store/h5.hpp"
#include "app/store/shot_file.hpp"
#include "tests/app/shot_fixtures.hpp"

namespace {

using namespace collide::testing;
using ::testing::HasSubstr;

// The HDF5 library writes `data` through a dataset with the fletcher32 filter;
// the stored chunk (read back raw) is the data followed by the library's checksum.
std::vector<std::uint8_t> libraryChunk(const std::vector<std::uint8_t>& data,
                                       const std::string& path) {
  const hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  const hsize_t dims[1] = {data.size()};
  const hid_t space = H5Screate_simple(1, dims, nullptr);
  const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_chunk(dcpl, 1, dims);
  H5Pset_fletcher32(dcpl);
  const hid_t d = H5Dcreate2(f, "d", H5T_NATIVE_UINT8, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
  H5Dwrite(d, H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data());
  const hsize_t offset[1] = {0};
  hsize_t size = 0;
  H5Dget_chunk_storage_size(d, offset, &size);
  std::vector<std::uint8_t> chunk(size);
  std::uint32_t mask = 0;
  H5Dread_chunk(d, H5P_DEFAULT, offset, &mask, chunk.data());
  H5Dclose(d), H5Pclose(dcpl), H5Sclose(space), H5Fclose(f);
  return chunk;
}

TEST(FrameChecksum, OursIsTheHdf5LibrarysFletcher32) {
  ScratchDir dir;
  std::mt19937 rng(5);
  for (const std::size_t n : {1u, 2u, 7u, 719u, 720u, 721u, 5000u, 307200u}) {
    std::vector<std::uint8_t> data(n);
    for (auto& b : data) b = static_cast<std::uint8_t>(rng());
    const auto chunk = libraryChunk(data, dir.file("lib.h5"));
    ASSERT_EQ(chunk.size(), n + 4) << n;
    const std::uint32_t stored = chunk[n] | chunk[n + 1] << 8 | chunk[n + 2] << 16 |
                                 static_cast<std::uint32_t>(chunk[n + 3]) << 24;
    EXPECT_EQ(collide::app::h5::fletcher32(data.data(), n), stored) << n << " bytes";
  }
}

// Flips one byte of frame `frame`'s stored chunk in the file.
void damageFrame(const std::string& path, hsize_t frame) {
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t d = H5Dopen2(f, "/frames/images", H5P_DEFAULT);
  const hsize_t offset[3] = {frame, 0, 0};
  unsigned mask = 0;
  haddr_t addr = 0;
  hsize_t size = 0;
  ASSERT_GE(H5Dget_chunk_info_by_coord(d, offset, &mask, &addr, &size), 0);
  H5Dclose(d), H5Fclose(f);
  std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
  file.seekg(static_cast<std::streamoff>(addr + size / 3));
  char c = 0;
  file.read(&c, 1);
  file.seekp(static_cast<std::streamoff>(addr + size / 3));
  c = static_cast<char>(c ^ 0x10);
  file.write(&c, 1);
}

class DamagedFrame : public ::testing::TestWithParam<bool> {};

TEST_P(DamagedFrame, IsNamedAndSetAsideTheOtherFramesRead) {
  ScratchDir dir;
  const std::string path = dir.file("shot.h5");
  ShotSpec spec;
  spec.format = collide::vision::PixelFormat::Mono16;
  const auto shot = makeShot(spec);
  collide::app::WriteOptions options;
  options.compress = GetParam();
  ASSERT_TRUE(collide::app::writeShot(path, shot, options).ok());
  // Intact, every frame reads (the library checks each checksum).
  auto intact = collide::app::readShot(path);
  ASSERT_TRUE(intact.ok()) << intact.error().message;
  damageFrame(path, 2);
  auto read = collide::app::readShot(path);
  ASSERT_TRUE(read.ok()) << read.error().message;
  const auto& frames = read->burst.frames;
  ASSERT_EQ(frames.size(), shot.burst.frames.size());
  EXPECT_EQ(frames[2].status, collide::vision::FrameStatus::Failed);
  EXPECT_TRUE(frames[2].image.empty());
  EXPECT_THAT(read->burst.note, HasSubstr("frame 2"));
  EXPECT_THAT(read->burst.note, HasSubstr("checksum"));
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (i == 2) continue;
    EXPECT_EQ(frames[i].status, shot.burst.frames[i].status) << i;
    EXPECT_EQ(cv::norm(frames[i].image, shot.burst.frames[i].image, cv::NORM_INF), 0) << i;
  }
}

INSTANTIATE_TEST_SUITE_P(Compression, DamagedFrame, ::testing::Values(false, true),
                         [](const auto& info) { return info.param ? "deflate" : "raw"; });

}  // namespace
