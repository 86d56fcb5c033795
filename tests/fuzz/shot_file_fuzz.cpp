// Fuzz target: the shot file reader (HDF5), as `collide analyze`, `export`,
// `replay` and folder scans use it. Every input gives a shot or a one-line
// error naming the file; a file that crashes libhdf5 itself is contained (read
// in the helper process first, see ReadOptions::contained) and reported as
// corrupt.
// Dimensions in the file never size an allocation unchecked.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <fstream>
#include <string>

#include "app/store/save.hpp"
#include "app/store/shot_file.hpp"
#include "tests/app/shot_fixtures.hpp"
#include "tests/fuzz/seeds.hpp"

// Seeds: small valid shot files (8 and 16-bit, with truth and results).
extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  const std::string corpus = collide::fuzz::corpusFolder(*argc, *argv);
  const std::string dir = "/tmp/collide-shot-fuzz-seeds-" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  for (const std::string& path : collide::fuzz::writeSmallShots(dir))
    collide::fuzz::addSeed(corpus, std::filesystem::path(path).filename(), path);
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = collide::fuzz::scratchPath("shot-fuzz", ".h5");
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  // 0.1 s: a seed reads in about 5 ms here; a looping read costs 0.1 s, not
  // 30 s. A read cut short is an error naming the file, not a finding.
  auto shot =
      collide::app::readShot(path, {.frames = true, .contained = true, .time_limit_s = 0.1});
  if (!shot && shot.error().message.find(path) == std::string::npos) __builtin_trap();
  // A memory error in our own reader, found in the helper process: a finding.
  if (!shot && shot.error().message.find("Collide's own reader") != std::string::npos)
    __builtin_trap();
  return 0;
}
