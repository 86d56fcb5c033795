#include "app/footage_shot.hpp"

#include <filesystem>

#include "vision/footage.hpp"
#include "vision/frame_io.hpp"

namespace collide::app {
namespace fs = std::filesystem;

Result<hw::Shot> shotFromFootage(const std::string& path, const FootageShotOptions& options) {
  std::error_code ec;
  double pixel_size_m = 0;
  Result<vision::Burst> burst = fail("no footage");
  if (vision::isFootageFile(path)) {
    auto footage = vision::Footage::open(path);
    if (!footage) return footage.error();
    pixel_size_m = footage->info().pixel_size_m;
    burst = vision::loadFootage(*footage, options.fps, {}, options.max_bytes);
  } else if (fs::is_directory(path, ec)) {
    if (!(options.fps > 0))
      return fail(path + " is a folder of frames: give the frame rate it was recorded at");
    burst = vision::loadFrameFolder(path, options.fps);
  } else if (fs::is_regular_file(path, ec)) {
    burst = vision::loadVideo(path, options.fps);
  } else {
    return fail(path + ": no such file or folder");
  }
  if (!burst) return burst.error();
  if (burst->frames.empty()) return fail(path + ": no frames");
  hw::Shot shot;
  shot.id = fs::path(path).filename().string();
  shot.status = hw::ShotStatus::Ok;
  shot.scene.pixel_size_m = pixel_size_m;  // 0: measured from the spheres
  shot.scene.diameter_m = options.diameter_m;
  shot.camera.fps = burst->fps;
  shot.burst = std::move(burst).value();
  return shot;
}

}  // namespace collide::app
