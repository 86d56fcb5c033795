// The heap-checking read driver (app/store/heap_check_driver.*): collections
// built here byte by byte from the HDF5 file format's layout (not by the code
// under test), damaged the two ways libhdf5 1.10 cannot survive, and shot
// files of every size read through the driver unchanged; string references
// into the heap damaged as libhdf5 1.10 cannot survive either.
#include "app/store/heap_check_driver.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <utility>
#include <vector>

#include "app/store/save.hpp"
#include "app/store/shot_file.hpp"
#include "tests/app/shot_fixtures.hpp"

namespace collide::testing {
namespace {

using app::h5::globalHeapDamage;
using ::testing::HasSubstr;

/// A global-heap collection with 8-byte lengths: "GCOL", version 1, three
/// reserved bytes, its size; objects of 16-byte headers and data padded to 8.
class Collection {
 public:
  explicit Collection(std::size_t size) : bytes_(size, 0) {
    const char magic[4] = {'G', 'C', 'O', 'L'};
    for (int i = 0; i < 4; ++i) bytes_[i] = static_cast<unsigned char>(magic[i]);
    bytes_[4] = 1;
    put(8, size);
  }
  /// Appends object `index` of `data_size` bytes; returns its offset.
  std::size_t add(unsigned index, std::uint64_t data_size) {
    const std::size_t at = next_;
    bytes_[at] = static_cast<unsigned char>(index & 0xff);
    bytes_[at + 1] = static_cast<unsigned char>(index >> 8);
    bytes_[at + 2] = 1;  // one reference
    put(at + 8, data_size);
    next_ += 16 + (data_size + 7) / 8 * 8;
    return at;
  }
  /// The free-space object (index 0) over the rest, its header included.
  void addFreeSpace() {
    put(next_ + 8, bytes_.size() - next_);
    next_ = bytes_.size();
  }
  void put(std::size_t at, std::uint64_t value) {
    for (int i = 0; i < 8; ++i) bytes_[at + i] = static_cast<unsigned char>(value >> (8 * i));
  }
  std::optional<std::string> damage() const {
    return globalHeapDamage(bytes_.data(), bytes_.size(), 8);
  }

 private:
  std::vector<unsigned char> bytes_;
  std::size_t next_ = 16;
};

TEST(GlobalHeapDamage, AWellFormedCollectionPasses) {
  Collection c(4096);
  c.add(1, 12);
  c.add(2, 83);
  c.add(3, 0);  // an empty string is an object of size 0, not free space
  c.addFreeSpace();
  EXPECT_EQ(c.damage(), std::nullopt);
}

TEST(GlobalHeapDamage, AFullCollectionOrATailTooSmallForAHeaderPasses) {
  Collection full(16 + 16 + 32);
  full.add(1, 32);
  EXPECT_EQ(full.damage(), std::nullopt);
  Collection tail(16 + 16 + 8 + 8);  // 8 bytes left: no room for a free-space header
  tail.add(1, 8);
  EXPECT_EQ(tail.damage(), std::nullopt);
}

TEST(GlobalHeapDamage, FreeSpaceOfSizeZeroIsTheLoop) {
  Collection c(4096);
  c.add(1, 12);
  const std::size_t free_at = c.add(2, 20);
  c.put(free_at, 0);      // index 0 ...
  c.put(free_at + 8, 0);  // ... of size 0
  const auto damage = c.damage();
  ASSERT_TRUE(damage.has_value());
  EXPECT_THAT(*damage, HasSubstr("has size 0"));
  EXPECT_THAT(*damage, HasSubstr("at byte " + std::to_string(free_at)));
}

TEST(GlobalHeapDamage, AnObjectPastTheCollectionIsTheOverflow) {
  Collection c(4096);
  c.add(1, 12);
  const std::size_t at = c.add(2, 4096);  // claims more than the collection holds
  const auto damage = c.damage();
  ASSERT_TRUE(damage.has_value());
  EXPECT_THAT(*damage,
              HasSubstr("object 2 at byte " + std::to_string(at) + " declares 4096 bytes"));
}

TEST(GlobalHeapDamage, ACollectionShorterThanItsHeader) {
  const unsigned char bytes[8] = {'G', 'C', 'O', 'L', 1, 0, 0, 0};
  EXPECT_TRUE(globalHeapDamage(bytes, sizeof bytes, 8).has_value());
}

// Results long enough to need a collection larger than the 4096-byte minimum,
// which the library reads in two parts: the driver checks it whole and the
// shot reads back unchanged.
TEST(HeapCheckDriver, ShotFilesWithLargeStringsReadBackUnchanged) {
  ScratchDir dir;
  ShotSpec spec;
  spec.id = "20260314-101500-0001";
  hw::Shot shot = makeShot(spec);
  ASSERT_TRUE(app::saveShot(dir.path(), shot).ok());
  const std::string path = dir.file(spec.id + ".h5");
  std::string json = "{\"note\": \"";
  for (int i = 0; i < 20000; ++i) json += static_cast<char>('a' + i % 26);
  json += "\"}";
  ASSERT_TRUE(app::storeResults(path, json).ok());
  for (bool contained : {true, false}) {
    auto read = app::readShot(path, {.frames = true, .contained = contained});
    ASSERT_TRUE(read.ok()) << read.error().message;
    EXPECT_EQ(read->results_json, json);
    EXPECT_EQ(read->id, shot.id);
    ASSERT_EQ(read->burst.frames.size(), shot.burst.frames.size());
  }
}

// A frame whose first pixels spell a collection's header ("GCOL", version 1,
// then a size past the end of the file) is raw data, not a collection: the
// driver checks only reads of a collection's size, and the shot reads back.
TEST(HeapCheckDriver, AFrameThatStartsLikeACollectionIsNotMistakenForOne) {
  ScratchDir dir;
  ShotSpec spec;
  spec.width = 40;  // 1200-byte frames: not a collection's 4096
  hw::Shot shot = makeShot(spec);
  cv::Mat& first = shot.burst.frames.at(0).image;
  const unsigned char header[16] = {'G',  'C',  'O',  'L',  1,    0,    0, 0,
                                    0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0, 0};
  std::memcpy(first.data, header, sizeof header);
  ASSERT_TRUE(app::saveShot(dir.path(), shot).ok());
  auto read = app::readShot(dir.file(spec.id + ".h5"), {.frames = true});
  ASSERT_TRUE(read.ok()) << read.error().message;
  const cv::Mat& back = read->burst.frames.at(0).image;
  EXPECT_EQ(std::memcmp(back.data, header, sizeof header), 0);
}

/// Where a shot file stores the references of a string dataset: the byte of
/// its first and the file's size of addresses (with libhdf5's own reader).
std::pair<haddr_t, std::size_t> referencesOf(const std::string& path, const std::string& dataset) {
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t d = H5Dopen2(file, dataset.c_str(), H5P_DEFAULT);
  const hid_t fcpl = H5Fget_create_plist(file);
  std::size_t address_size = 0, length_size = 0;
  H5Pget_sizes(fcpl, &address_size, &length_size);
  const haddr_t offset = H5Dget_offset(d);
  H5Pclose(fcpl);
  H5Dclose(d);
  H5Fclose(file);
  return {offset, address_size};
}

/// A field of a variable-length string's reference: its length (4 bytes), the
/// collection's address, the object's index (4 bytes).
enum class Field { Length, Index };

/// Saves a shot into `dir` and overwrites `field` of the first reference of
/// /sequencer/name with `value` (little-endian); the file's path, or "" after
/// a failure.
std::string shotWithDamagedReference(const ScratchDir& dir, Field field, std::uint32_t value) {
  ShotSpec spec;
  if (!app::saveShot(dir.path(), makeShot(spec)).ok()) return {};
  const std::string path = dir.file(spec.id + ".h5");
  const auto [offset, address_size] = referencesOf(path, "/sequencer/name");
  if (offset == HADDR_UNDEF) return {};
  const haddr_t at = offset + (field == Field::Length ? 0 : 4 + address_size);
  unsigned char bytes[4];
  for (int i = 0; i < 4; ++i) bytes[i] = static_cast<unsigned char>(value >> (8 * i));
  std::FILE* f = std::fopen(path.c_str(), "r+b");
  const bool written =
      f && std::fseek(f, static_cast<long>(at), SEEK_SET) == 0 && std::fwrite(bytes, 1, 4, f) == 4;
  if (f) std::fclose(f);
  return written ? path : std::string();
}

// A string reference naming an object its collection does not hold, or one
// of another length: libhdf5 1.10 reads a pointer from past the collection's
// object table (found by shot_file_fuzz, as SEGVs in H5HG_read), or copies the
// object's size into a buffer of the string's. The file is refused, naming
// the string and the object.
TEST(HeapCheckDriver, AStringReferringToAMissingObjectIsRefused) {
  ScratchDir dir;
  const std::string path = shotWithDamagedReference(dir, Field::Index, 0x00ffff00);
  ASSERT_FALSE(path.empty());
  auto read = app::readShot(path, {.contained = true});
  ASSERT_FALSE(read.ok());
  EXPECT_THAT(read.error().message, HasSubstr("/sequencer/name is corrupt: string 0 refers to "
                                              "object 16776960"));
  EXPECT_THAT(read.error().message, HasSubstr("which has no such object"));
}

TEST(HeapCheckDriver, AStringLongerThanItsObjectIsRefused) {
  ScratchDir dir;
  const std::string path = shotWithDamagedReference(dir, Field::Length, 5000);
  ASSERT_FALSE(path.empty());
  for (bool contained : {true, false}) {
    auto read = app::readShot(path, {.contained = contained});
    ASSERT_FALSE(read.ok());
    EXPECT_THAT(read.error().message, HasSubstr("not the 5000 the string declares"));
  }
}

}  // namespace
}  // namespace collide::testing
