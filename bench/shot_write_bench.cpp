// How fast a shot reaches the disk: writeShot (HDF5, one frame per chunk,
// fsync, rename) against a plain sequential write()+fsync of the same frame
// bytes to the same folder. Target: HDF5 at least 70 % of plain.
//
//   COLLIDE_BENCH_DIR=<folder on the disk that will hold shots> build/bench/shot_write_bench
//
// The folder defaults to the current one; a tmpfs folder is refused (it would
// measure memory, not the disk). Each iteration writes both files, alternating
// which goes first, and deletes them.
#include <benchmark/benchmark.h>
#include <fcntl.h>
#include <linux/magic.h>
#include <sys/statfs.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <opencv2/imgproc.hpp>
#include <string>

#include "app/store/shot_file.hpp"

namespace {

using Clock = std::chrono::steady_clock;

constexpr int kFrames = 300, kWidth = 640, kHeight = 480;  // 92.2 MB of Mono8

std::string benchDir() {
  const char* env = std::getenv("COLLIDE_BENCH_DIR");
  return env && *env ? env : ".";
}

bool onTmpfs(const std::string& dir) {
  struct statfs fs {};
  return statfs(dir.c_str(), &fs) == 0 && fs.f_type == TMPFS_MAGIC;
}

/// A realistic burst: dark background, noise, so nothing is trivially sparse.
const collide::hw::Shot& realisticShot() {
  static const collide::hw::Shot shot = [] {
    collide::hw::Shot s;
    s.id = "20260314-101500-0001";
    s.rig_profile_toml = "[rig]\nname = \"bench\"\n";
    s.scene.material_name = "nylon-6/6";
    s.burst.format = collide::vision::PixelFormat::Mono8;
    cv::RNG rng(1);
    for (int i = 0; i < kFrames; ++i) {
      collide::vision::Frame f;
      f.id = i - 50;
      f.timestamp_ns = i * 1000000LL;
      f.image = cv::Mat(kHeight, kWidth, CV_8UC1);
      rng.fill(f.image, cv::RNG::NORMAL, 20, 8);
      cv::circle(f.image, {100 + i, 240}, 60, cv::Scalar(230), cv::FILLED);
      s.burst.frames.push_back(f);
    }
    return s;
  }();
  return shot;
}

double frameBytes() {
  return static_cast<double>(kFrames) * kWidth * kHeight;
}

/// Seconds to write every frame with write() and fsync, as a raw recorder would.
double plainWrite_s(const std::string& path, const collide::hw::Shot& shot, bool& ok) {
  const auto t0 = Clock::now();
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  ok = fd >= 0;
  for (const auto& f : shot.burst.frames) {
    const std::size_t bytes = f.image.total() * f.image.elemSize();
    ok = ok && ::write(fd, f.image.data, bytes) == static_cast<ssize_t>(bytes);
  }
  ok = ok && ::fsync(fd) == 0;
  if (fd >= 0) ::close(fd);
  const double s = std::chrono::duration<double>(Clock::now() - t0).count();
  ::unlink(path.c_str());
  return s;
}

double hdf5Write_s(const std::string& path, const collide::hw::Shot& shot,
                   const collide::app::WriteOptions& options, std::string& error) {
  const auto t0 = Clock::now();
  const auto written = collide::app::writeShot(path, shot, options);
  const double s = std::chrono::duration<double>(Clock::now() - t0).count();
  if (!written) error = written.error().message;
  ::unlink(path.c_str());
  return s;
}

void BM_WriteShotVsPlain(benchmark::State& state) {
  const std::string dir = benchDir();
  if (onTmpfs(dir)) return state.SkipWithError("COLLIDE_BENCH_DIR is on tmpfs: use a disk folder");
  const auto& shot = realisticShot();
  // Argument: deflate level, 0 = no compression (the default).
  const collide::app::WriteOptions options{.compress = state.range(0) != 0,
                                           .deflate_level = static_cast<int>(state.range(0))};
  double hdf5_s = 0, plain_s = 0;
  bool hdf5_first = true;
  for (auto _ : state) {
    std::string error;
    bool plain_ok = true;
    const std::string h5 = dir + "/bench-shot.h5", raw = dir + "/bench-shot.raw";
    if (hdf5_first) {
      hdf5_s += hdf5Write_s(h5, shot, options, error);
      plain_s += plainWrite_s(raw, shot, plain_ok);
    } else {
      plain_s += plainWrite_s(raw, shot, plain_ok);
      hdf5_s += hdf5Write_s(h5, shot, options, error);
    }
    hdf5_first = !hdf5_first;
    if (!error.empty()) return state.SkipWithError(error.c_str());
    if (!plain_ok) return state.SkipWithError("plain write failed");
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["hdf5_MB_s"] = frameBytes() * n / hdf5_s / 1e6;
  state.counters["plain_MB_s"] = frameBytes() * n / plain_s / 1e6;
  state.counters["hdf5_over_plain"] = plain_s / hdf5_s;
  state.SetLabel(
      (options.compress ? "deflate " + std::to_string(options.deflate_level) : std::string("raw")) +
      ", 300 x 640x480 Mono8 in " + dir);
}
BENCHMARK(BM_WriteShotVsPlain)
    ->ArgName("deflate")
    ->Arg(0)
    ->Arg(1)
    ->Arg(4)
    ->Iterations(4)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

/// Reading back (page cache warm: the file was just written), with and
/// without the images: listing and catalog rebuilds use the latter.
void BM_ReadShot(benchmark::State& state) {
  const std::string dir = benchDir();
  const std::string path = dir + "/bench-read.h5";
  if (auto w = collide::app::writeShot(path, realisticShot()); !w)
    return state.SkipWithError(w.error().message.c_str());
  const bool frames = state.range(0) != 0;
  for (auto _ : state) {
    auto shot = collide::app::readShot(path, {.frames = frames});
    if (!shot) return state.SkipWithError(shot.error().message.c_str());
    benchmark::DoNotOptimize(shot->burst.frames.data());
  }
  if (frames) state.SetBytesProcessed(static_cast<std::int64_t>(frameBytes() * state.iterations()));
  ::unlink(path.c_str());
}
BENCHMARK(BM_ReadShot)->ArgName("frames")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
