// Sustained acquisition from a GigE Vision camera over loopback: Aravis'
// simulator (arv-fake-gv-camera-0.8 -i 127.0.0.1, started here) streams
// Mono8 frames to CameraAravis, whose acquisition thread copies every frame
// into an armed pre-trigger ring (exactly the work of a real shot's wait for
// the trigger), while the vision core analyses a simulated shot over and over
// on another thread (pinned to the last CPU). Measured over 10 s after 1 s of
// warm-up: frames the camera sent (its frame counter), frames received
// complete, frames lost (failed + never seen), MB/s received, Aravis'
// underruns / missing / resent packets, analyses per second, and the CPU the
// receiving side used (cores, besides the vision workload).
// Target (issue 5): zero lost frames at >= 50 MB/s while vision analyses.
//   build/bench/aravis_acquisition_bench
// Figures and set-up: docs/benchmarks.md, "Aravis acquisition".
#include <benchmark/benchmark.h>
#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "app/analyze.hpp"
#include "app/rig_setup.hpp"
#include "hw/camera_aravis.hpp"
#include "hw/clock.hpp"
#include "hw/rig.hpp"
#include "hw/sequencer.hpp"
#include "tests/hw/gige_fake.hpp"
#include "vision/shot_analysis.hpp"

namespace {

using namespace collide;
using namespace collide::hw;

constexpr double kWarmupS = 1.0;
constexpr double kMeasureS = 10.0;

// A simulated shot (config/sim.toml, 640 x 480, 70 frames) for the vision
// workload, fired once.
const Shot& workloadShot() {
  static const Shot shot = [] {
    auto s = app::fireShot(*defaultRigProfile(), ShotRequest::atSpeeds(2.0, 2.2), "workload");
    if (!s) throw std::runtime_error(s.error().message);
    return std::move(*s);
  }();
  return shot;
}

// Analyses the workload shot until told to stop, on the last CPU.
class VisionWorkload {
 public:
  VisionWorkload() {
    const Shot& shot = workloadShot();
    thread_ = std::thread([this, &shot] {
      cpu_set_t set;
      CPU_ZERO(&set);
      CPU_SET(static_cast<int>(std::thread::hardware_concurrency()) - 1, &set);
      pthread_setaffinity_np(pthread_self(), sizeof(set), &set);
      const vision::AnalysisSettings settings = app::analysisSettingsFor(shot);
      const double cpu0 = threadCpuS();
      while (!stop_) {
        auto r = vision::analyzeBurst(shot.burst, settings);
        benchmark::DoNotOptimize(r);
        ++analyses_;
      }
      cpu_s_ = threadCpuS() - cpu0;
    });
  }
  ~VisionWorkload() { stop(); }
  std::uint64_t analyses() const { return analyses_; }
  /// CPU seconds the workload used (valid once it has stopped).
  double cpuS() const { return cpu_s_; }
  void stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }

 private:
  static double threadCpuS() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return t.tv_sec + t.tv_nsec * 1e-9;
  }
  double cpu_s_ = 0;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> analyses_{0};
  std::thread thread_;
};

double processCpuS() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec + t.tv_nsec * 1e-9;
}

void sleepS(double s) {
  std::this_thread::sleep_for(std::chrono::duration<double>(s));
}

// Args: width, height, frames/s, packet size (bytes), vision workload (0/1).
void BM_GigeAcquisition(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const double fps = static_cast<double>(state.range(2));
  CameraAravisSettings settings;
  settings.packet_size_bytes = static_cast<int>(state.range(3));
  settings.buffers = 256;
  const bool vision = state.range(4) != 0;
  if (vision) (void)workloadShot();  // fire it before the clock starts

  testing::GigeFake fake;
  if (!fake.ok()) {
    state.SkipWithError(fake.reason().c_str());
    return;
  }
  CameraAravis cam(testing::GigeFake::kAddress, settings);
  const CameraConfig config{0, 0, width, height, vision::PixelFormat::Mono8, fps, 100.0, 0.0};
  for (Status s : {cam.open(), cam.configure(config), cam.start()}) {
    if (!s) {
      state.SkipWithError(s.error().message.c_str());
      return;
    }
  }
  // Armed, never triggered: every frame is copied into the ring.
  if (Status s = cam.arm(64, 1); !s) {
    state.SkipWithError(s.error().message.c_str());
    return;
  }
  sleepS(kWarmupS);

  for (auto _ : state) {
    std::unique_ptr<VisionWorkload> workload;
    if (vision) workload = std::make_unique<VisionWorkload>();
    const AravisCounters a = cam.counters();
    const auto t0 = std::chrono::steady_clock::now();
    const double cpu0 = processCpuS();
    sleepS(kMeasureS);
    const AravisCounters b = cam.counters();
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::uint64_t analyses = workload ? workload->analyses() : 0;
    if (workload) workload->stop();
    // This process's CPU besides the vision workload: Aravis' receiving
    // thread and the acquisition thread (the simulator is another process).
    const double receive_cpu = processCpuS() - cpu0 - (workload ? workload->cpuS() : 0.0);
    workload.reset();

    const double sent = static_cast<double>(b.last_sequence - a.last_sequence);
    const double received = static_cast<double>(b.frames_good - a.frames_good);
    const double lost = static_cast<double>((b.frames_failed - a.frames_failed) +
                                            (b.frames_missing - a.frames_missing));
    state.counters["sent_fps"] = sent / dt;
    state.counters["recv_fps"] = received / dt;
    state.counters["recv_MB_s"] = static_cast<double>(b.bytes_good - a.bytes_good) / dt / 1e6;
    state.counters["lost"] = lost;
    state.counters["underruns"] = static_cast<double>(b.underruns - a.underruns);
    state.counters["miss_pkts"] = static_cast<double>(b.missing_packets - a.missing_packets);
    state.counters["resent"] = static_cast<double>(b.resent_packets - a.resent_packets);
    state.counters["analyses_s"] = static_cast<double>(analyses) / dt;
    state.counters["recv_cpu"] = receive_cpu / dt;  // cores
  }
  (void)cam.close();
}

}  // namespace

// Asked for: 512 x 512 Mono8 (262 kB a frame) at 200 frames/s, 52 MB/s;
// 1024 x 512 at 200, 105 MB/s; 1024 x 1024 at 100, 105 MB/s. The simulator
// sends what it manages (it computes its test pattern on the CPU); sent_fps
// says how many it did send. Jumbo packets (8192) as on a lab link with MTU
// 9000, and standard 1500-byte ones.
BENCHMARK(BM_GigeAcquisition)
    ->ArgNames({"w", "h", "fps", "packet", "vision"})
    ->Args({512, 512, 200, 8192, 0})
    ->Args({512, 512, 200, 8192, 1})
    ->Args({512, 512, 200, 1500, 1})
    ->Args({1024, 512, 200, 8192, 1})
    ->Args({1024, 1024, 100, 8192, 1})
    ->Iterations(1)
    ->Unit(benchmark::kSecond)
    ->UseRealTime();

BENCHMARK_MAIN();
