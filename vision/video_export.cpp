#include "vision/video_export.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <system_error>

namespace collide::vision {
namespace {

namespace fs = std::filesystem;

Status checkRequest(const Burst& burst, const std::string& path, double fps) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  if (ext != ".avi") return fail(path + " does not end in .avi: the video is written as AVI");
  if (!(fps > 0) || !std::isfinite(fps))
    return fail("playback rate " + std::to_string(fps) + " frames/s for " + path + " must be > 0");
  const Frame* first = nullptr;
  for (const Frame& f : burst.frames) {
    if (f.image.empty()) continue;
    if (!first) first = &f;
    if (f.image.size() != first->image.size())
      return fail("frame " + std::to_string(f.id) + " differs in size from frame " +
                  std::to_string(first->id) + "; nothing was written to " + path);
  }
  if (!first) return fail("no frame has image data; nothing was written to " + path);
  return Ok{};
}

// Frames in the file as OpenCV's own MJPEG reader counts them (0 if unreadable).
std::size_t framesInFile(const std::string& path) {
  try {
    cv::VideoCapture cap(path, cv::CAP_OPENCV_MJPEG);
    if (!cap.isOpened()) return 0;
    std::size_t n = 0;
    while (cap.grab()) ++n;
    return n;
  } catch (const cv::Exception&) {
    return 0;
  }
}

Result<std::unique_ptr<cv::VideoWriter>> openWriter(const Burst& burst, const std::string& path,
                                                    double fps) {
  cv::Size size;
  for (const Frame& f : burst.frames)
    if (!f.image.empty()) size = f.image.size();
  auto writer = std::make_unique<cv::VideoWriter>();
  const std::string what = "cannot create the video file " + path;
  try {
    writer->open(path, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, size,
                 true);  // colour: see writeFrames
  } catch (const cv::Exception& e) {
    return fail(what + " (" + e.what() + "): check that the folder exists and is writable");
  }
  if (!writer->isOpened()) return fail(what + ": check that the folder exists and is writable");
  return writer;
}

Result<VideoExportReport> writeFrames(const Burst& burst, const std::string& path,
                                      cv::VideoWriter& writer) {
  VideoExportReport report;
  cv::Mat bgr;
  try {
    for (const Frame& f : burst.frames) {
      if (f.image.empty()) {
        ++report.skipped;
        continue;
      }
      // Grey as three equal channels: OpenCV 4.6's own MJPEG writer garbles
      // single-channel frames ("Corrupt JPEG data" on reading back).
      cv::cvtColor(displayGrey8(f.image, burst.format), bgr, cv::COLOR_GRAY2BGR);
      writer.write(bgr);
      ++report.written;
    }
    writer.release();
  } catch (const cv::Exception& e) {
    return fail("writing " + path + " failed at frame " + std::to_string(report.written) + " (" +
                e.what() + "): check free disk space");
  }
  const std::size_t found = framesInFile(path);
  if (found != report.written)
    return fail(path + " holds " + std::to_string(found) + " of the " +
                std::to_string(report.written) +
                " frames written (disk full?): free some space or choose another folder");
  return report;
}

}  // namespace

cv::Mat displayGrey8(const cv::Mat& image, PixelFormat format) {
  if (image.empty() || image.depth() == CV_8U) return image;
  cv::Mat grey8;
  image.convertTo(grey8, CV_8U, 255.0 / maxValue(format));
  return grey8;
}

Result<VideoExportReport> exportBurstVideo(const Burst& burst, const std::string& path,
                                           const VideoExportOptions& options) {
  if (Status ok = checkRequest(burst, path, options.playback_fps); !ok) return ok.error();
  auto writer = openWriter(burst, path, options.playback_fps);
  if (!writer) return writer.error();  // nothing written: an existing file stays as it was
  auto report = writeFrames(burst, path, **writer);
  if (!report) {
    std::error_code ec;
    if (fs::is_regular_file(path, ec)) fs::remove(path, ec);  // no half-written video left
  }
  return report;
}

}  // namespace collide::vision
