// `collide export SHOT.h5 --png DIR`: a shot's frames as PNG files to look at.
#include <iostream>

#include "app/cli/command.hpp"
#include "app/store/shot_file.hpp"
#include "vision/frame_io.hpp"

namespace {

void setupExport(CLI::App& sub, std::function<int()>& run) {
  auto shot_path = std::make_shared<std::string>();
  auto png_dir = std::make_shared<std::string>();
  sub.add_option("SHOT", *shot_path, "Shot file (.h5)")->required();
  sub.add_option("--png", *png_dir, "Folder to write frame_<index>_id<id>.png files into")
      ->required();
  sub.footer(
      "Mono8 frames become 8-bit PNGs and Mono16 16-bit PNGs, pixel for pixel; Mono12 frames are\n"
      "scaled by 16 into 16-bit PNGs so that viewers show their real contrast. Frames that failed\n"
      "in transport (no image data) are skipped.");
  run = [=] {
    auto shot = collide::app::readShot(*shot_path);
    if (!shot) {
      std::cerr << "collide export: " << shot.error().message << "\n";
      return collide::cli::kExitBadInput;
    }
    auto exported =
        collide::vision::exportBurstPng(shot->burst, *png_dir, {.stretch_mono12 = true});
    if (!exported) {
      std::cerr << "collide export: " << exported.error().message << "\n";
      return collide::cli::kExitFailure;
    }
    std::cout << "wrote " << exported->written << " PNG files to " << *png_dir;
    if (exported->skipped) std::cout << " (skipped " << exported->skipped << " without image data)";
    std::cout << "\n";
    return collide::cli::kExitOk;
  };
}

}  // namespace

COLLIDE_COMMAND(export, "Write a shot's frames as PNG files (--png DIR)", setupExport);
