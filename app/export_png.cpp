#include "app/export_png.hpp"

#include <cstdio>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "app/atomic_file.hpp"

namespace collide::app {

Result<PngExport> exportPng(const vision::Burst& burst, const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return ioError(ec.value(), "creating the folder", dir);
  PngExport out;
  for (std::size_t i = 0; i < burst.frames.size(); ++i) {
    const vision::Frame& frame = burst.frames[i];
    if (frame.image.empty()) {
      ++out.skipped;
      continue;
    }
    char name[64];
    std::snprintf(name, sizeof name, "frame_%04zu_id%lld.png", i, static_cast<long long>(frame.id));
    const std::string path = (std::filesystem::path(dir) / name).string();
    cv::Mat image = frame.image;
    if (burst.format == vision::PixelFormat::Mono12) frame.image.convertTo(image, CV_16U, 16.0);
    bool ok = false;
    try {
      ok = cv::imwrite(path, image);
    } catch (const cv::Exception& e) {
      return fail("cannot write " + path + ": " + e.msg);
    }
    if (!ok)
      return fail("cannot write " + path + ": check that the folder is writable and not full");
    ++out.written;
  }
  return out;
}

}  // namespace collide::app
