// Fuzz target: footage recorded elsewhere, a folder holding one image file
// (the first byte picks its type: PNG, TIFF, PGM, BMP or JPEG), read as
// `collide analyze --frames DIR` reads it. Any input gives a burst or a
// one-line error naming the file.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "tests/fuzz/seeds.hpp"
#include "vision/frame_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static const std::string dir = collide::fuzz::scratchPath("footage-fuzz");
  static const char* kExtensions[] = {".png", ".tif", ".pgm", ".bmp", ".jpg"};
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  std::filesystem::create_directories(dir);
  const std::string file = dir + "/frame_0001" + kExtensions[data[0] % 5];
  {
    std::ofstream out(file, std::ios::binary);
    out.write(reinterpret_cast<const char*>(data + 1), static_cast<std::streamsize>(size - 1));
  }
  auto burst = collide::vision::loadFrameFolder(dir, 1000.0);
  if (!burst && burst.error().message.empty()) __builtin_trap();
  return 0;
}
