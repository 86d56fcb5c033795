// How fast camera files are read: Footage::read of every frame of a
// 1024 x 1024 recording, from the page cache (the file is read once before
// timing), into one reused image. Target (issue 13): at least 1 GB/s
// including 12-bit unpacking.
//
//   COLLIDE_BENCH_DIR=<scratch folder> build/bench/footage_bench
//
// The files (about 1.3 GB in all) are written into the folder (default: the
// system's temporary folder) and deleted at the end. Bytes/s counts the bytes stored in the
// file; "decoded/s" the 16-bit (or 8-bit) pixels produced.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>

#include "tests/vision/footage_writers.hpp"
#include "vision/footage.hpp"

namespace {

namespace fs = std::filesystem;
using namespace collide::testing;

constexpr int kWidth = 1024, kHeight = 1024, kFrames = 256;

std::string benchDir() {
  const char* env = std::getenv("COLLIDE_BENCH_DIR");
  return env && *env ? env : fs::temp_directory_path().string();
}

cv::Mat noise(int type, int hi) {
  cv::Mat m(kHeight, kWidth, type);
  cv::RNG rng(1);
  rng.fill(m, cv::RNG::UNIFORM, 0, hi + 1);
  return m;
}

// A recording written once per process; the path of the file to open.
std::string mrawFile(int bits) {
  const std::string stem = benchDir() + "/footage_bench_" + std::to_string(bits);
  if (!fs::exists(stem + ".mraw")) {
    const auto frame =
        mrawFrameBytes(noise(bits == 8 ? CV_8UC1 : CV_16UC1, bits == 8 ? 255 : 4095), bits);
    std::ofstream os(stem + ".mraw", std::ios::binary | std::ios::trunc);
    for (int i = 0; i < kFrames; ++i)
      os.write(reinterpret_cast<const char*>(frame.data()),
               static_cast<std::streamsize>(frame.size()));
    writeText(stem + ".cih", cihText(kWidth, kHeight, bits, kFrames, 100000));
  }
  return stem + ".mraw";
}

std::string cineFile(bool packed10) {
  const std::string path = benchDir() + "/footage_bench_" + (packed10 ? "p10" : "16") + ".cine";
  if (!fs::exists(path)) {
    CineSpec s;
    s.width = kWidth;
    s.height = kHeight;
    s.bit_count = 16;
    s.real_bpp = 12;
    s.packed10 = packed10;
    const cv::Mat img = noise(CV_16UC1, packed10 ? 1023 : 4095);
    writeBytes(path, cineBytes(s, std::vector<cv::Mat>(kFrames, img)));
  }
  return path;
}

void readAll(benchmark::State& state, const std::string& path) {
  auto footage = collide::vision::Footage::open(path);
  if (!footage) {
    state.SkipWithError(footage.error().message.c_str());
    return;
  }
  const auto& in = footage->info();
  cv::Mat img;
  for (std::int64_t i = 0; i < in.frame_count; ++i) (void)footage->read(i, img);  // page cache
  for (auto _ : state) {
    for (std::int64_t i = 0; i < in.frame_count; ++i) {
      if (!footage->read(i, img).ok()) state.SkipWithError("read failed");
      benchmark::DoNotOptimize(img.data);
    }
    benchmark::ClobberMemory();
  }
  const auto frames = static_cast<double>(state.iterations() * in.frame_count);
  state.SetBytesProcessed(static_cast<std::int64_t>(frames * static_cast<double>(in.frame_bytes)));
  state.counters["decoded/s"] =
      benchmark::Counter(frames * static_cast<double>(img.total() * img.elemSize()),
                         benchmark::Counter::kIsRate, benchmark::Counter::kIs1024);
  state.counters["frames/s"] = benchmark::Counter(frames, benchmark::Counter::kIsRate);
}

void BM_Mraw12Packed(benchmark::State& s) {
  readAll(s, mrawFile(12));
}
void BM_Mraw16(benchmark::State& s) {
  readAll(s, mrawFile(16));
}
void BM_Mraw8(benchmark::State& s) {
  readAll(s, mrawFile(8));
}
void BM_Cine16(benchmark::State& s) {
  readAll(s, cineFile(false));
}
void BM_Cine10Packed(benchmark::State& s) {
  readAll(s, cineFile(true));
}

BENCHMARK(BM_Mraw12Packed)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Mraw16)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Mraw8)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Cine16)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Cine10Packed)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  for (const char* name : {"footage_bench_12.mraw", "footage_bench_12.cih", "footage_bench_16.mraw",
                           "footage_bench_16.cih", "footage_bench_8.mraw", "footage_bench_8.cih",
                           "footage_bench_16.cine", "footage_bench_p10.cine"}) {
    std::error_code ec;
    fs::remove(fs::path(benchDir()) / name, ec);
  }
  return 0;
}
