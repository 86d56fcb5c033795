// pco .b16: one 16-bit monochrome image per file (pco cameras save a recording
// as numbered .b16 files; loadFrameFolder reads such a folder). Little-endian
// header: "PCO-", file size, header size (= offset of the pixels), width,
// height, -1 if an extended header follows, then (extended) 0 for
// monochrome, 1 for colour. The header records no frame rate or exposure.
// Written from the format description, not checked on a camera's own file.
#include <cstring>

#include "vision/footage_reader.hpp"

namespace collide::vision::detail {
namespace {

class B16Reader final : public FootageReader {
 public:
  std::shared_ptr<const MappedFile> file;
  std::uint64_t pixels_at = 0;

  Status decode(std::int64_t, cv::Mat& out) const override {
    const std::uint8_t* src = file->data() + pixels_at;
    const std::size_t w = static_cast<std::size_t>(info.width);
    for (int r = 0; r < info.height; ++r) {
      std::uint16_t* row = out.ptr<std::uint16_t>(r);
      const std::uint8_t* in = src + 2 * w * static_cast<std::size_t>(r);
      for (std::size_t c = 0; c < w; ++c) row[c] = le16(in + 2 * c);
    }
    return Ok{};
  }
};

}  // namespace

Result<std::unique_ptr<FootageReader>> openB16(const std::string& path) {
  auto mapped = MappedFile::open(path);
  if (!mapped) return mapped.error();
  const MappedFile& f = **mapped;
  const std::uint8_t* d = f.data();
  if (!f.holds(0, 20) || std::memcmp(d, "PCO-", 4) != 0)
    return fail(path + " is not a pco .b16 image (it does not start with 'PCO-'): check the file");
  const std::uint32_t header = le32(d + 8);
  const std::int32_t width = static_cast<std::int32_t>(le32(d + 12));
  const std::int32_t height = static_cast<std::int32_t>(le32(d + 16));
  if (width < 1 || height < 1 || width > kMaxSide || height > kMaxSide ||
      std::int64_t{width} * height > kMaxPixels)
    return fail(path + ": image size " + std::to_string(width) + " x " + std::to_string(height) +
                " is impossible: the file is damaged or not a pco .b16 image");
  if (f.holds(0, 28) && static_cast<std::int32_t>(le32(d + 20)) == -1 && le32(d + 24) != 0)
    return fail(path + " is a colour pco image; only monochrome .b16 is read");
  const std::uint64_t bytes =
      2 * static_cast<std::uint64_t>(width) * static_cast<std::uint64_t>(height);
  if (header < 20 || !f.holds(header, bytes))
    return fail(path + " is shorter than its header says (" + std::to_string(width) + " x " +
                std::to_string(height) + " 16-bit pixels after " + std::to_string(header) +
                " header bytes): the file is truncated; copy it again");
  auto r = std::make_unique<B16Reader>();
  r->pixels_at = header;
  FootageInfo& in = r->info;
  in.format = "pco B16";
  in.data_path = path;
  in.width = width;
  in.height = height;
  in.frame_count = 1;
  in.stored_bits = in.effective_bits = 16;
  in.pixel_format = PixelFormat::Mono16;
  in.frame_bytes = bytes;
  r->file = std::move(*mapped);
  return std::unique_ptr<FootageReader>(std::move(r));
}

}  // namespace collide::vision::detail
