#include "app/footage_shot.hpp"

#include <filesystem>

#include "vision/footage.hpp"
#include "vision/frame_io.hpp"

namespace collide::app {
namespace fs = std::filesystem;

Result<FootageKind> footageKind(const std::string& path, bool has_range, bool fps_given) {
  std::error_code ec;
  if (!fs::exists(path, ec))
    return fail(path +
                ": no such file or folder; give a folder of frames, a video or a camera file "
                "(.mraw/.cihx/.cih, .cine, .b16)");
  const bool folder = fs::is_directory(path, ec);
  const FootageKind kind = !folder && vision::isFootageFile(path) ? FootageKind::CameraFile
                           : folder                               ? FootageKind::Folder
                                                                  : FootageKind::Video;
  if (has_range && kind != FootageKind::CameraFile)
    return fail("a frame range (--range) applies to camera files (.mraw/.cihx/.cih/.cine), not " +
                path);
  if (kind == FootageKind::Folder && !fps_given)
    return fail(path +
                " is a folder of frames: give the frame rate it was recorded at (frames per "
                "second; --fps on the command line)");
  return kind;
}

Result<LoadedFootage> loadFootageAt(const std::string& path, double fps,
                                    const vision::FootageRange& range, std::uint64_t max_bytes) {
  const bool has_range = range.first_id.has_value() || range.last_id.has_value();
  auto kind = footageKind(path, has_range, fps > 0);
  if (!kind) return kind.error();
  LoadedFootage out;
  out.kind = *kind;
  Result<vision::Burst> burst = fail("no footage");
  if (*kind == FootageKind::CameraFile) {
    auto footage = vision::Footage::open(path);
    if (!footage) return footage.error();
    out.file_pixel_size_m = footage->info().pixel_size_m;
    burst = vision::loadFootage(*footage, fps, range, max_bytes);
  } else if (*kind == FootageKind::Folder) {
    burst = vision::loadFrameFolder(path, fps);
  } else {
    burst = vision::loadVideo(path, fps);
  }
  if (!burst) return burst.error();
  out.burst = std::move(burst).value();
  return out;
}

Result<hw::Shot> shotFromFootage(const std::string& path, const FootageShotOptions& options) {
  auto loaded = loadFootageAt(path, options.fps, {}, options.max_bytes);
  if (!loaded) return loaded.error();
  if (loaded->burst.frames.empty()) return fail(path + ": no frames");
  const double pixel_size_m = loaded->file_pixel_size_m;
  auto burst = std::move(loaded->burst);
  hw::Shot shot;
  shot.id = fs::path(path).filename().string();
  shot.status = hw::ShotStatus::Ok;
  shot.scene.pixel_size_m = pixel_size_m;  // 0: measured from the spheres
  shot.scene.diameter_m = options.diameter_m;
  shot.camera.fps = burst.fps;
  shot.burst = std::move(burst);
  return shot;
}

}  // namespace collide::app
