// Fuzz target: a shot folder's catalog.sqlite, which may be damaged (a disk
// error, a copy cut short). Opening and listing it must give rows or an error
// saying to run `collide catalog rebuild`, never a crash.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "app/store/catalog.hpp"
#include "app/store/save.hpp"
#include "tests/app/shot_fixtures.hpp"
#include "tests/fuzz/seeds.hpp"

namespace {

std::string folder() {
  static const std::string dir = [] {
    std::string d = collide::fuzz::scratchPath("catalog-fuzz");
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

}  // namespace

// Seed: the catalog of a folder of three saved shots.
extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  const std::string dir = folder() + "-seed";
  std::filesystem::create_directories(dir);
  for (int i = 0; i < 3; ++i) {
    collide::testing::ShotSpec spec;
    spec.id = "20260314-101500-000" + std::to_string(i);
    spec.width = 4;
    spec.height = 3;
    spec.frames = 2;
    (void)collide::app::saveShot(dir, collide::testing::makeShot(spec));
  }
  collide::fuzz::addSeed(collide::fuzz::corpusFolder(*argc, *argv), "seed-catalog.sqlite",
                         dir + "/catalog.sqlite");
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string dir = folder();
  std::error_code ec;
  for (const char* suffix : {"", "-wal", "-shm"})
    std::filesystem::remove(dir + "/catalog.sqlite" + suffix, ec);
  {
    std::ofstream out(dir + "/catalog.sqlite", std::ios::binary);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  auto catalog = collide::app::Catalog::open(dir, collide::app::Catalog::Mode::OpenExisting);
  if (!catalog) {
    if (catalog.error().message.empty()) __builtin_trap();
    return 0;
  }
  (void)catalog->query();
  return 0;
}
