#pragma once
// Internals shared by the vendor-file readers (footage.cpp, photron_mraw.cpp,
// phantom_cine.cpp): the memory-mapped file, the reader interface, the
// packed-pixel unpackers and the checked little-endian field access.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>

#include "analysis/result.hpp"
#include "vision/footage.hpp"

namespace collide::vision::detail {

/// A whole file mapped read-only. The mapping lives as long as the object.
class MappedFile {
 public:
  /// Errors: missing file, not a regular file, empty file, mmap failure.
  static Result<std::shared_ptr<const MappedFile>> open(const std::string& path);
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;

  const std::uint8_t* data() const { return data_; }
  std::uint64_t size() const { return size_; }
  const std::string& path() const { return path_; }
  /// True if [offset, offset + length) lies inside the file (overflow-safe).
  bool holds(std::uint64_t offset, std::uint64_t length) const {
    return offset <= size_ && length <= size_ - offset;
  }

 private:
  MappedFile() = default;
  const std::uint8_t* data_ = nullptr;
  std::uint64_t size_ = 0;
  std::string path_;
};

class FootageReader {
 public:
  virtual ~FootageReader() = default;
  FootageInfo info;
  /// Decodes stored frame `index` (already range-checked) into `out`.
  virtual Status decode(std::int64_t index, cv::Mat& out) const = 0;
};

Result<std::unique_ptr<FootageReader>> openPhotron(const std::string& path);
Result<std::unique_ptr<FootageReader>> openCine(const std::string& path);
Result<std::unique_ptr<FootageReader>> openB16(const std::string& path);

/// Largest frame side and pixel count accepted from a header: beyond any
/// high-speed camera, small enough that no header can make us allocate absurdly.
inline constexpr int kMaxSide = 16384;
inline constexpr std::int64_t kMaxPixels = std::int64_t{1} << 27;  // 128 Mpixel

/// 12-bit pixels packed two in three bytes, most significant bits first:
/// p0 = b0 << 4 | b1 >> 4, p1 = (b1 & 15) << 8 | b2. `pixels` is even.
void unpack12(const std::uint8_t* in, std::uint16_t* out, std::size_t pixels);
/// 10-bit pixels packed four in five bytes, most significant bits first.
/// `pixels` is a multiple of 4. With `lut` (1024 entries) each value is mapped.
void unpack10(const std::uint8_t* in, std::uint16_t* out, std::size_t pixels,
              const std::uint16_t* lut);
/// Phantom's 10-to-12-bit linearisation table for packed 10-bit CINE data.
const std::uint16_t* phantomLinLut10();

inline std::uint16_t le16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>(p[0] | p[1] << 8);
}
inline std::uint32_t le32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}
inline std::uint64_t le64(const std::uint8_t* p) {
  return static_cast<std::uint64_t>(le32(p)) | static_cast<std::uint64_t>(le32(p + 4)) << 32;
}

/// The pixel format frames decode to: 8-bit storage gives Mono8; wider storage
/// Mono12 when at most 12 bits are real data, else Mono16.
inline PixelFormat pixelFormatFor(int stored_bits, int effective_bits) {
  return stored_bits <= 8       ? PixelFormat::Mono8
         : effective_bits <= 12 ? PixelFormat::Mono12
                                : PixelFormat::Mono16;
}

}  // namespace collide::vision::detail
