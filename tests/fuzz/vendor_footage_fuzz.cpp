// Fuzz target: vendor camera files, as `collide info`, `analyze --frames` and
// the Replay view open them. The first byte picks the format: a Phantom .cine
// (the rest of the input is the file), a Photron .mraw with a .cih or .cihx
// header (the input is split at its first 0xFF 0x00 0xFF: header, then
// pixels), or a pco .b16. Any input gives frames or a one-line error naming
// the file; header numbers never size an allocation unchecked.
#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "tests/fuzz/seeds.hpp"
#include "tests/vision/footage_writers.hpp"
#include "vision/footage.hpp"

namespace {

namespace t = collide::testing;

const std::string& folder() {
  static const std::string dir = [] {
    std::string d = collide::fuzz::scratchPath("vendor-fuzz");
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

const char kSplit[] = {'\xff', '\x00', '\xff'};

std::vector<std::uint8_t> seed(std::uint8_t kind, const std::string& header,
                               const std::vector<std::uint8_t>& body) {
  std::vector<std::uint8_t> out{kind};
  out.insert(out.end(), header.begin(), header.end());
  if (!header.empty()) out.insert(out.end(), kSplit, kSplit + 3);
  out.insert(out.end(), body.begin(), body.end());
  return out;
}

}  // namespace

// Seeds: small files of every layout the readers decode, from the test writers.
extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  const std::string corpus = collide::fuzz::corpusFolder(*argc, *argv);
  if (corpus.empty()) return 0;
  cv::Mat img8(4, 8, CV_8UC1), img16(4, 8, CV_16UC1), codes10(4, 8, CV_16UC1);
  cv::randu(img8, 0, 255);
  cv::randu(img16, 0, 4095);
  cv::randu(codes10, 0, 1023);
  t::CineSpec c8;
  c8.width = 8;
  c8.height = 4;
  t::CineSpec c16 = c8;
  c16.bit_count = 16;
  c16.real_bpp = 12;
  t::CineSpec c10 = c8;
  c10.packed10 = true;
  c10.real_bpp = 10;
  const std::vector<std::vector<std::uint8_t>> seeds = {
      seed(0, "", t::cineBytes(c8, {img8, img8})),
      seed(0, "", t::cineBytes(c16, {img16})),
      seed(0, "", t::cineBytes(c10, {codes10})),
      seed(1, t::cihText(8, 4, 8, 2, 1000),
           [&] {
             auto a = t::mrawFrameBytes(img8, 8);
             a.insert(a.end(), a.begin(), a.end());
             return a;
           }()),
      seed(1, t::cihText(8, 4, 12, 1, 1000), t::mrawFrameBytes(img16, 12)),
      seed(2, t::cihxText(8, 4, 16, 1, 50000, 2000, 0, "mm", 0.05), t::mrawFrameBytes(img16, 16)),
      seed(3, "", t::b16Bytes(img16)),
  };
  for (std::size_t i = 0; i < seeds.size(); ++i)
    t::writeBytes(corpus + "/seed-" + std::to_string(i), seeds[i]);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::string dir = folder();
  std::error_code ec;
  for (const char* name : {"/x.cine", "/x.mraw", "/x.cih", "/x.cihx", "/x.b16"})
    std::filesystem::remove(dir + name, ec);
  const std::uint8_t kind = data[0] % 4;
  const std::vector<std::uint8_t> rest(data + 1, data + size);
  std::string path;
  if (kind == 0 || kind == 3) {
    path = dir + (kind == 0 ? "/x.cine" : "/x.b16");
    t::writeBytes(path, rest);
  } else {
    auto cut = std::search(rest.begin(), rest.end(), kSplit, kSplit + 3);
    const std::string header(rest.begin(), cut);
    const std::vector<std::uint8_t> pixels(cut == rest.end() ? rest.end() : cut + 3, rest.end());
    t::writeText(dir + (kind == 1 ? "/x.cih" : "/x.cihx"), header);
    path = dir + "/x.mraw";
    t::writeBytes(path, pixels);
  }
  auto burst = collide::vision::loadFootage(path, 0, {}, std::uint64_t{64} << 20);
  if (!burst && burst.error().message.empty()) __builtin_trap();
  return 0;
}
