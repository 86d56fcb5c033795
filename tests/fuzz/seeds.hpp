#pragma once
// Seeds a fuzz target makes for itself at start-up, in the first corpus folder
// on its command line (where libFuzzer also keeps what it finds): binary
// inputs (a shot file, a catalog) are made by the current code, so they
// always match the current format and need no binary blobs in the repository.
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "app/store/shot_file.hpp"
#include "tests/app/shot_fixtures.hpp"

namespace collide::fuzz {

/// The first argument that is not a libFuzzer flag: the writable corpus
/// folder; empty when there is none (e.g. a single input is being replayed).
inline std::string corpusFolder(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (!a.empty() && a[0] != '-' && std::filesystem::is_directory(a)) return a;
  }
  return "";
}

/// "/tmp/collide-<name>-<pid><suffix>": a scratch file or folder of this fuzz
/// process, removed with whatever is under it when the process exits (a run's
/// end, not a crash: a crash's input is kept by libFuzzer itself).
inline std::string scratchPath(const std::string& name, const std::string& suffix = "") {
  static std::vector<std::string> paths;
  if (paths.empty())
    std::atexit([] {
      std::error_code ec;
      for (const auto& p : paths) std::filesystem::remove_all(p, ec);
    });
  paths.push_back("/tmp/collide-" + name + "-" + std::to_string(::getpid()) + suffix);
  return paths.back();
}

inline std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Copies `source` into `folder` as `name` unless `folder` is empty.
inline void addSeed(const std::string& folder, const std::string& name, const std::string& source) {
  if (folder.empty()) return;
  std::error_code ec;
  std::filesystem::copy_file(source, std::filesystem::path(folder) / name,
                             std::filesystem::copy_options::overwrite_existing, ec);
}

/// Small valid shot files (8 and 16-bit, 8 x 6 pixels, 3 frames, with truth
/// and results) written by the current code into `dir` as seed-<format>.h5:
/// their paths (none for a format the writer refused).
inline std::vector<std::string> writeSmallShots(const std::string& dir) {
  std::vector<std::string> paths;
  for (auto format : {vision::PixelFormat::Mono8, vision::PixelFormat::Mono16}) {
    testing::ShotSpec spec;
    spec.format = format;
    spec.width = 8;
    spec.height = 6;
    spec.frames = 3;
    const std::string path = dir + "/seed-" + vision::toString(format) + ".h5";
    if (app::writeShot(path, testing::makeShot(spec))) paths.push_back(path);
  }
  return paths;
}

}  // namespace collide::fuzz
