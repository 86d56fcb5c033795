#pragma once
// A small V4L2 capture driver behind a memfd, for running CameraV4l2 (and the
// real V4l2Device code: the hw library is linked statically) on a host
// without a camera or a VM. Including this header defines ioctl() for the
// whole program: include it in exactly one file of a test program. Every
// other descriptor's ioctl goes to the kernel unchanged. The fake answers
// what CameraV4l2 asks: one GREY format, any size up to kSlot bytes, frames
// at the rate last set, each stamped (CLOCK_MONOTONIC, start of exposure) on
// its own schedule from STREAMON, one period apart, and DQBUF blocking until
// the next one is due, as a blocking driver would. It lists no frame sizes,
// rates or controls (ENOTTY), as some drivers do, unless `with_controls` is set:
// then it has exposure_auto, exposure_time_absolute (100 us units, 1..10000)
// and gain (0..255 in steps of 4), and rounds and clamps a value it is given
// to its control's step and range without an error, as the kernel's control
// framework does (what the device holds is read back). Once `unplugged`, it
// answers every ioctl with ENODEV, as the kernel does for a disconnected
// UVC camera; `calls` counts the ioctls it was asked. Used by
// camera_v4l2_lost_test.cpp and camera_v4l2_conformance_test.cpp.
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdarg>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <string>
#include <vector>

#include "hw/camera_v4l2.hpp"
#include "hw/clock.hpp"

namespace collide::hw::testing {

constexpr int kWidth = 160, kHeight = 120;
constexpr std::size_t kFrameBytes = kWidth * kHeight;
constexpr std::size_t kSlot = 32768;  // per buffer in the memfd, page aligned, >= kFrameBytes

// The fake capture device: one GREY format, any size asked (160x120 here),
// frames at the rate last set, buffers in a memfd that mmap() maps as usual.
struct FakeControl {
  std::uint32_t id;
  const char* name;
  std::uint32_t type;
  std::int64_t minimum, maximum, step, value;
};

struct FakeV4l2 {
  int memfd = -1;
  bool with_controls = false;
  std::vector<FakeControl> controls{
      {V4L2_CID_EXPOSURE_AUTO, "Auto Exposure", V4L2_CTRL_TYPE_MENU, 0, 3, 1, 0},
      {V4L2_CID_EXPOSURE_ABSOLUTE, "Exposure Time, Absolute", V4L2_CTRL_TYPE_INTEGER, 1, 10000, 1,
       100},
      {V4L2_CID_GAIN, "Gain", V4L2_CTRL_TYPE_INTEGER, 0, 255, 4, 0}};
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
  int answerControls(unsigned long request, void* arg);
  FakeControl* controlById(std::uint32_t id) {
    for (FakeControl& c : controls)
      if (c.id == id) return &c;
    return nullptr;
  }
};

inline FakeV4l2& fake() {
  static FakeV4l2 f;
  return f;
}

inline int refuse(int err) {
  errno = err;
  return -1;
}

inline int FakeV4l2::answer(unsigned long request, void* arg) {
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
    case VIDIOC_QUERY_EXT_CTRL:
    case VIDIOC_S_EXT_CTRLS:
    case VIDIOC_G_EXT_CTRLS: return with_controls ? answerControls(request, arg) : refuse(ENOTTY);
    default: return refuse(ENOTTY);
  }
}

inline int FakeV4l2::answerControls(unsigned long request, void* arg) {
  if (request == VIDIOC_QUERY_EXT_CTRL) {
    auto* q = static_cast<v4l2_query_ext_ctrl*>(arg);
    const bool next = (q->id & V4L2_CTRL_FLAG_NEXT_CTRL) != 0;
    const std::uint32_t id = q->id & ~(V4L2_CTRL_FLAG_NEXT_CTRL | V4L2_CTRL_FLAG_NEXT_COMPOUND);
    const FakeControl* found = nullptr;
    for (const FakeControl& c : controls)  // the next by id, or this one
      if (next ? c.id > id && (!found || c.id < found->id) : c.id == id) found = &c;
    if (!found) return refuse(EINVAL);
    *q = {};
    q->id = found->id;
    q->type = found->type;
    std::strncpy(q->name, found->name, sizeof q->name - 1);
    q->minimum = found->minimum;
    q->maximum = found->maximum;
    q->step = static_cast<__u64>(found->step);
    q->default_value = found->value;
    return 0;
  }
  auto* cs = static_cast<v4l2_ext_controls*>(arg);
  for (__u32 i = 0; i < cs->count; ++i) {
    v4l2_ext_control& e = cs->controls[i];
    FakeControl* c = controlById(e.id);
    if (!c) return refuse(EINVAL);
    if (request == VIDIOC_G_EXT_CTRLS) {
      e.value = static_cast<__s32>(c->value);
    } else {  // clamped, then rounded to the step from the minimum
      const std::int64_t v = std::clamp<std::int64_t>(e.value, c->minimum, c->maximum);
      c->value = c->minimum + (v - c->minimum + c->step / 2) / c->step * c->step;
    }
  }
  return 0;
}

// The fake's node (/proc/self/fd/N of its memfd, created on first use), or
// an empty string if no memfd could be made (errno says why).
inline std::string fakeV4l2Path() {
  FakeV4l2& f = fake();
  if (f.memfd < 0) {
    const int fd = memfd_create("collide-fake-v4l2", MFD_CLOEXEC);
    if (fd < 0) return {};
    struct stat st {};
    if (fstat(fd, &st) != 0) return {};
    f.inode = st.st_ino;
    f.memfd = fd;
  }
  return "/proc/self/fd/" + std::to_string(f.memfd);
}

// Settings for a CameraV4l2 on the fake (plugged in): 160x120 GREY, 4
// buffers, exposure and gain left to the device (it has neither control).
inline CameraV4l2Settings fakeV4l2Settings() {
  fake().unplugged = false;
  CameraV4l2Settings s;
  s.path = fakeV4l2Path();
  s.frame_width = kWidth;
  s.frame_height = kHeight;
  s.buffers = 4;
  s.exposure_control = false;
  s.gain_raw_per_db = 0.0;
  return s;
}

}  // namespace collide::hw::testing

// Every ioctl of this program: the fake's, or the kernel's.
extern "C" int ioctl(int fd, unsigned long request, ...) noexcept {
  using collide::hw::testing::fake;
  va_list ap;
  va_start(ap, request);
  void* arg = va_arg(ap, void*);
  va_end(ap);
  if (fake().mine(fd)) return fake().answer(request, arg);
  return static_cast<int>(syscall(SYS_ioctl, fd, request, arg));
}
