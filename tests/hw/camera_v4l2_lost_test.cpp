// CameraV4l2 when its device goes away (unplugged, driver unbound), on the
// host without a VM: this program puts a small V4L2 capture driver of its own
// behind a memfd. It defines ioctl() itself, so the real V4l2Device code (the
// hw library is linked statically) talks to it; every other descriptor's
// ioctl goes to the kernel unchanged. Once "unplugged", the fake answers
// every ioctl with ENODEV, as the kernel does for a disconnected UVC camera.
// The real driver path (vivid's "disconnect" control) is in
// tests/vm/v4l2_vm_test.cpp.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdarg>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "hw/camera_v4l2.hpp"
#include "hw/clock.hpp"

using namespace collide::hw;
using collide::vision::PixelFormat;
using ::testing::HasSubstr;
using ::testing::StartsWith;

namespace {

constexpr int kWidth = 160, kHeight = 120;
constexpr std::size_t kFrameBytes = kWidth * kHeight;
constexpr std::size_t kSlot = 32768;  // per buffer in the memfd, page aligned, >= kFrameBytes

// The fake capture device: one GREY format, any size asked (160x120 here),
// frames at the rate last set, buffers in a memfd that mmap() maps as usual.
struct FakeV4l2 {
  int memfd = -1;
  ino_t inode = 0;
  std::atomic<bool> unplugged{false};
  std::atomic<int> calls{0};  // ioctls on the device (answered or not)
  std::mutex mutex;
  int buffers = 0;
  std::vector<int> queued;
  bool streaming = false;
  std::uint32_t sequence = 0;
  std::int64_t period_ns = 10'000'000;
  std::int64_t next_ns = 0;

  bool mine(int fd) const {
    struct stat st {};
    return memfd >= 0 && fstat(fd, &st) == 0 && st.st_ino == inode;
  }
  int answer(unsigned long request, void* arg);
};

FakeV4l2& fake() {
  static FakeV4l2 f;
  return f;
}

int refuse(int err) {
  errno = err;
  return -1;
}

int FakeV4l2::answer(unsigned long request, void* arg) {
  calls.fetch_add(1);
  if (unplugged.load()) return refuse(ENODEV);
  std::unique_lock lock(mutex);
  switch (request) {
    case VIDIOC_QUERYCAP: {
      auto* c = static_cast<v4l2_capability*>(arg);
      *c = {};
      std::strcpy(reinterpret_cast<char*>(c->driver), "fake");
      std::strcpy(reinterpret_cast<char*>(c->card), "lost test");
      c->device_caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;
      c->capabilities = c->device_caps | V4L2_CAP_DEVICE_CAPS;
      return 0;
    }
    case VIDIOC_ENUM_FMT: {
      auto* f = static_cast<v4l2_fmtdesc*>(arg);
      if (f->index != 0) return refuse(EINVAL);
      f->pixelformat = V4L2_PIX_FMT_GREY;
      return 0;
    }
    case VIDIOC_S_FMT: {
      auto* f = static_cast<v4l2_format*>(arg);
      f->fmt.pix.pixelformat = V4L2_PIX_FMT_GREY;
      f->fmt.pix.bytesperline = f->fmt.pix.width;
      f->fmt.pix.sizeimage = f->fmt.pix.width * f->fmt.pix.height;
      return f->fmt.pix.sizeimage <= kSlot ? 0 : refuse(EINVAL);
    }
    case VIDIOC_G_PARM:
    case VIDIOC_S_PARM: {
      auto* p = static_cast<v4l2_streamparm*>(arg);
      auto& t = p->parm.capture.timeperframe;
      if (request == VIDIOC_S_PARM && t.denominator > 0)
        period_ns = static_cast<std::int64_t>(1e9 * t.numerator / t.denominator);
      p->parm.capture.capability = V4L2_CAP_TIMEPERFRAME;
      return 0;
    }
    case VIDIOC_REQBUFS: {
      auto* r = static_cast<v4l2_requestbuffers*>(arg);
      buffers = static_cast<int>(std::min<__u32>(r->count, 4));
      r->count = static_cast<__u32>(buffers);
      queued.clear();
      return ftruncate(memfd, static_cast<off_t>(kSlot * std::max(buffers, 1)));
    }
    case VIDIOC_QUERYBUF: {
      auto* b = static_cast<v4l2_buffer*>(arg);
      if (static_cast<int>(b->index) >= buffers) return refuse(EINVAL);
      b->length = kFrameBytes;
      b->m.offset = static_cast<__u32>(b->index * kSlot);
      return 0;
    }
    case VIDIOC_QBUF:
      queued.push_back(static_cast<int>(static_cast<v4l2_buffer*>(arg)->index));
      return 0;
    case VIDIOC_STREAMON:
      streaming = true;
      next_ns = monotonicNowNs();
      return 0;
    case VIDIOC_STREAMOFF:
      streaming = false;
      queued.clear();
      return 0;
    case VIDIOC_DQBUF: {
      if (!streaming || queued.empty()) return refuse(EAGAIN);
      // The next frame ends its exposure at next_ns: wait for it (outside
      // the lock), as a blocking driver would.
      const std::int64_t due = next_ns;
      lock.unlock();
      const timespec until{static_cast<time_t>(due / 1'000'000'000),
                           static_cast<long>(due % 1'000'000'000)};
      while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &until, nullptr) == EINTR) {
      }
      lock.lock();
      if (unplugged.load()) return refuse(ENODEV);
      if (!streaming || queued.empty()) return refuse(EAGAIN);
      auto* b = static_cast<v4l2_buffer*>(arg);
      b->index = static_cast<__u32>(queued.front());
      queued.erase(queued.begin());
      b->sequence = sequence++;
      b->bytesused = kFrameBytes;
      b->flags = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_SOE;
      b->timestamp.tv_sec = static_cast<time_t>(due / 1'000'000'000);
      b->timestamp.tv_usec = static_cast<suseconds_t>((due % 1'000'000'000) / 1000);
      next_ns = due + period_ns;
      return 0;
    }
    default: return refuse(ENOTTY);
  }
}

}  // namespace

// Every ioctl of this program: the fake's, or the kernel's.
extern "C" int ioctl(int fd, unsigned long request, ...) noexcept {
  va_list ap;
  va_start(ap, request);
  void* arg = va_arg(ap, void*);
  va_end(ap);
  if (fake().mine(fd)) return fake().answer(request, arg);
  return static_cast<int>(syscall(SYS_ioctl, fd, request, arg));
}

namespace {

class V4l2Lost : public ::testing::Test {
 protected:
  void SetUp() override {
    FakeV4l2& f = fake();
    f.unplugged = false;
    if (f.memfd < 0) {
      f.memfd = memfd_create("collide-fake-v4l2", MFD_CLOEXEC);
      ASSERT_GE(f.memfd, 0) << std::strerror(errno);
      struct stat st {};
      ASSERT_EQ(fstat(f.memfd, &st), 0);
      f.inode = st.st_ino;
    }
    settings_.path = "/proc/self/fd/" + std::to_string(f.memfd);
    settings_.frame_width = kWidth;
    settings_.frame_height = kHeight;
    settings_.buffers = 4;
    settings_.exposure_control = false;
    settings_.gain_raw_per_db = 0.0;
  }

  static CameraConfig config() {
    return {0, 0, kWidth, kHeight, PixelFormat::Mono8, 100.0, 1000.0, 0.0};
  }

  CameraV4l2Settings settings_;
};

}  // namespace

TEST_F(V4l2Lost, TheFakeDriverStreamsFrames) {
  // The bench itself: without a loss, bursts arrive whole.
  CameraV4l2 cam(settings_);
  ASSERT_TRUE(cam.open());
  ASSERT_TRUE(cam.configure(config()));
  ASSERT_TRUE(cam.start());
  ASSERT_TRUE(cam.arm(2, 5));
  ASSERT_TRUE(cam.trigger(monotonicNowNs() + 50'000'000));
  const auto done = cam.waitBurst(monotonicNowNs() + 10'000'000'000);
  ASSERT_TRUE(done && *done);
  const auto b = cam.takeBurst();
  ASSERT_TRUE(b) << b.error().message;
  EXPECT_TRUE(b->complete) << b->note;
  EXPECT_EQ(b->frames.size(), 7u);
  EXPECT_FALSE(cam.loss());
  ASSERT_TRUE(cam.close());
}

TEST_F(V4l2Lost, ADeviceUnpluggedMidBurstIsLostAndTheNextShotIsRefusedWithoutAskingIt) {
  CameraV4l2 cam(settings_);
  ASSERT_TRUE(cam.open());
  ASSERT_TRUE(cam.configure(config()));
  ASSERT_TRUE(cam.start());
  ASSERT_TRUE(cam.arm(2, 100000));
  ASSERT_TRUE(cam.trigger(monotonicNowNs() + 50'000'000));
  (void)cam.waitBurst(monotonicNowNs() + 200'000'000);  // some frames arrive
  fake().unplugged = true;
  const auto ended = cam.waitBurst(monotonicNowNs() + 30'000'000'000);
  ASSERT_TRUE(ended);
  ASSERT_TRUE(*ended) << "the burst never learned that the device was gone";
  const auto b = cam.takeBurst();
  ASSERT_TRUE(b) << b.error().message;  // what arrived is handed back
  EXPECT_FALSE(b->complete);
  EXPECT_FALSE(b->frames.empty());

  ASSERT_TRUE(cam.loss()) << "the camera did not mark itself lost";
  const std::string lost = lostMessage(*cam.loss());
  std::printf("the user reads: %s\n", lost.c_str());
  EXPECT_THAT(lost, StartsWith("camera \"" + settings_.path +
                               "\" is lost (the device went away (taking a frame: "));
  EXPECT_THAT(lost, HasSubstr("retrying will not help"));
  EXPECT_THAT(lost, HasSubstr("v4l2-ctl --list-devices"));
  EXPECT_THAT(b->note, HasSubstr(lost));

  // The next shot: refused at once, and the device is not asked anything.
  const int asked = fake().calls.load();
  const auto armed = cam.arm(2, 10);
  ASSERT_FALSE(armed);
  EXPECT_EQ(armed.error().message, lost);
  EXPECT_EQ(fake().calls.load(), asked) << "arm() asked the lost device";
  (void)cam.stop();  // stopping is never refused (it may fail: the device is gone)
  const int asked_before_start = fake().calls.load();
  const auto restart = cam.start();
  ASSERT_FALSE(restart);
  EXPECT_EQ(restart.error().message, lost);
  EXPECT_EQ(fake().calls.load(), asked_before_start) << "start() asked the lost device";
  (void)cam.close();
}

TEST_F(V4l2Lost, ADeviceUnpluggedBetweenShotsIsLostAtTheNextStart) {
  CameraV4l2 cam(settings_);
  ASSERT_TRUE(cam.open());
  ASSERT_TRUE(cam.configure(config()));
  fake().unplugged = true;
  const auto s = cam.start();  // the first call to ask it finds it gone
  ASSERT_FALSE(s);
  ASSERT_TRUE(cam.loss());
  EXPECT_EQ(s.error().message, lostMessage(*cam.loss()));
  EXPECT_THAT(s.error().message, HasSubstr("allocating buffers"));
  const int asked = fake().calls.load();
  EXPECT_EQ(cam.start().error().message, s.error().message);
  EXPECT_EQ(cam.configure(config()).error().message, s.error().message);
  EXPECT_EQ(fake().calls.load(), asked) << "the lost device was asked again";
  // Reopening looks for it again: while it is gone that fails too.
  ASSERT_TRUE(cam.close());
  EXPECT_FALSE(cam.open());
  fake().unplugged = false;  // plugged back in: reopening finds it
  ASSERT_TRUE(cam.open());
  EXPECT_FALSE(cam.loss());
  ASSERT_TRUE(cam.configure(config()));
  ASSERT_TRUE(cam.start());
  ASSERT_TRUE(cam.close());
}

TEST_F(V4l2Lost, AnErrorThatIsNotAGoneDeviceDoesNotLoseIt) {
  CameraV4l2Settings s = settings_;
  s.frame_width = 640;  // more than the fake's buffers hold: it refuses the format (EINVAL)
  s.frame_height = 480;
  CameraV4l2 cam(s);
  ASSERT_TRUE(cam.open());
  const auto c = cam.configure({0, 0, 640, 480, PixelFormat::Mono8, 100.0, 1000.0, 0.0});
  ASSERT_FALSE(c);
  EXPECT_FALSE(cam.loss()) << c.error().message;
  EXPECT_THAT(c.error().message, HasSubstr("setting the format"));
}
