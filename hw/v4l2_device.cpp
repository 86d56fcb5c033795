#include "hw/v4l2_device.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>

#include "hw/format.hpp"

namespace collide::hw {

namespace {

int xioctl(int fd, unsigned long request, void* arg) {
  int r;
  do {
    r = ioctl(fd, request, arg);
  } while (r == -1 && errno == EINTR);
  return r;
}

std::string cString(const __u8* s, std::size_t n) {
  return std::string(reinterpret_cast<const char*>(s),
                     strnlen(reinterpret_cast<const char*>(s), n));
}

}  // namespace

std::string fourccText(std::uint32_t f) {
  std::string s;
  for (int i = 0; i < 4; ++i) {
    const char c = static_cast<char>((f >> (8 * i)) & 0xff);
    s += (c >= 32 && c < 127) ? c : '?';
  }
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

std::uint32_t fourccFromText(const std::string& text) {
  if (text.empty() || text.size() > 4) return 0;
  std::string t = text;
  t.resize(4, ' ');
  return v4l2_fourcc(t[0], t[1], t[2], t[3]);
}

std::string v4l2ControlKey(const std::string& name) {
  std::string key;
  for (const char c : name) {
    if (std::isalnum(static_cast<unsigned char>(c)))
      key += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    else if (!key.empty() && key.back() != '_')
      key += '_';
  }
  while (!key.empty() && key.back() == '_') key.pop_back();
  return key;
}

Error V4l2Device::errnoError(const std::string& what, int err) const {
  if (err == ENODEV || err == ENXIO || err == EIO) {
    std::lock_guard lock(gone_mutex_);
    if (!gone_)
      gone_ = (err == EIO ? "its driver failed the stream for good (" : "the device went away (") +
              what + ": " + std::strerror(err) + ")";
  }
  if (err == EBUSY)
    return fail(path_ + " is busy: another program is streaming from it (close it; `fuser " +
                path_ + "` shows which), or another camera in this profile uses it");
  if (err == ENODEV || err == ENXIO)
    return fail(path_ + ": the device went away (" + what +
                "): check its cable and `v4l2-ctl --list-devices`");
  if (err == EIO)
    return fail(path_ + ": the driver stopped the stream with a fatal error (" + what +
                "); the device went away or failed: check its cable and the kernel log "
                "(dmesg)");
  return fail(path_ + ": " + what + " failed: " + std::strerror(err));
}

Result<std::unique_ptr<V4l2Device>> V4l2Device::open(const std::string& path) {
  std::unique_ptr<V4l2Device> d(new V4l2Device());
  d->path_ = path;
  d->fd_ = ::open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (d->fd_ < 0) {
    const int err = errno;
    if (err == ENOENT)
      return fail("no camera at " + path +
                  ": check camera.device (`v4l2-ctl --list-devices` lists the cameras)");
    if (err == EACCES || err == EPERM)
      return fail("no permission to open " + path +
                  ": add yourself to the collide (or video) group and install "
                  "udev/60-collide.rules (README, Lab set-up)");
    return d->errnoError("open", err);
  }
  v4l2_capability cap{};
  if (xioctl(d->fd_, VIDIOC_QUERYCAP, &cap) != 0)
    return fail(path + " is not a V4L2 video device (" + std::strerror(errno) +
                "): check camera.device");
  d->driver_ = cString(cap.driver, sizeof cap.driver);
  d->card_ = cString(cap.card, sizeof cap.card);
  const std::uint32_t caps =
      (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (!(caps & V4L2_CAP_VIDEO_CAPTURE)) {
    std::string hint = (caps & V4L2_CAP_VIDEO_CAPTURE_MPLANE)
                           ? "it captures multi-planar only, which Collide does not read"
                           : "it has no video capture (an output, metadata or radio node?)";
    return fail(d->name() + " is not a video capture device: " + hint +
                "; check camera.device (`v4l2-ctl --list-devices`)");
  }
  if (!(caps & V4L2_CAP_STREAMING))
    return fail(d->name() + " cannot stream with memory-mapped buffers: Collide needs that");
  return d;
}

std::optional<std::string> V4l2Device::gone() const {
  std::lock_guard lock(gone_mutex_);
  return gone_;
}

V4l2Device::~V4l2Device() {
  (void)stopStreaming();
  if (fd_ >= 0) ::close(fd_);
}

std::string V4l2Device::name() const {
  return path_ + " (\"" + card_ + "\", driver " + driver_ + ")";
}

std::vector<std::uint32_t> V4l2Device::pixelFormats() const {
  std::vector<std::uint32_t> out;
  for (std::uint32_t i = 0;; ++i) {
    v4l2_fmtdesc f{};
    f.index = i;
    f.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (xioctl(fd_, VIDIOC_ENUM_FMT, &f) != 0) {
      if (errno != EINVAL) (void)errnoError("listing its pixel formats", errno);  // gone()?
      break;
    }
    out.push_back(f.pixelformat);
  }
  return out;
}

std::vector<std::string> V4l2Device::frameSizes(std::uint32_t fourcc) const {
  std::vector<std::string> out;
  for (std::uint32_t i = 0;; ++i) {
    v4l2_frmsizeenum s{};
    s.index = i;
    s.pixel_format = fourcc;
    if (xioctl(fd_, VIDIOC_ENUM_FRAMESIZES, &s) != 0) break;
    if (s.type == V4L2_FRMSIZE_TYPE_DISCRETE) {
      out.push_back(std::to_string(s.discrete.width) + "x" + std::to_string(s.discrete.height));
    } else {
      const auto& w = s.stepwise;
      out.push_back(std::to_string(w.min_width) + "x" + std::to_string(w.min_height) + ".." +
                    std::to_string(w.max_width) + "x" + std::to_string(w.max_height) + " step " +
                    std::to_string(w.step_width) + "x" + std::to_string(w.step_height));
      break;
    }
  }
  return out;
}

bool V4l2Device::offersSize(std::uint32_t fourcc, int width, int height) const {
  bool enumerated = false;
  for (std::uint32_t i = 0;; ++i) {
    v4l2_frmsizeenum s{};
    s.index = i;
    s.pixel_format = fourcc;
    if (xioctl(fd_, VIDIOC_ENUM_FRAMESIZES, &s) != 0) break;
    enumerated = true;
    if (s.type == V4L2_FRMSIZE_TYPE_DISCRETE) {
      if (static_cast<int>(s.discrete.width) == width &&
          static_cast<int>(s.discrete.height) == height)
        return true;
    } else {
      const auto& w = s.stepwise;
      const auto fits = [](int v, __u32 lo, __u32 hi, __u32 step) {
        return v >= static_cast<int>(lo) && v <= static_cast<int>(hi) &&
               (step <= 1 || (v - static_cast<int>(lo)) % static_cast<int>(step) == 0);
      };
      return fits(width, w.min_width, w.max_width, w.step_width) &&
             fits(height, w.min_height, w.max_height, w.step_height);
    }
  }
  // A driver that cannot enumerate sizes: VIDIOC_S_FMT will tell.
  return !enumerated;
}

std::vector<double> V4l2Device::frameRates(std::uint32_t fourcc, int width, int height) const {
  std::vector<double> out;
  for (std::uint32_t i = 0;; ++i) {
    v4l2_frmivalenum f{};
    f.index = i;
    f.pixel_format = fourcc;
    f.width = static_cast<__u32>(width);
    f.height = static_cast<__u32>(height);
    if (xioctl(fd_, VIDIOC_ENUM_FRAMEINTERVALS, &f) != 0) break;
    if (f.type == V4L2_FRMIVAL_TYPE_DISCRETE) {
      if (f.discrete.numerator > 0)
        out.push_back(static_cast<double>(f.discrete.denominator) / f.discrete.numerator);
    } else {
      // Continuous or stepwise: the fastest and slowest rates.
      if (f.stepwise.min.numerator > 0)
        out.push_back(static_cast<double>(f.stepwise.min.denominator) / f.stepwise.min.numerator);
      if (f.stepwise.max.numerator > 0)
        out.push_back(static_cast<double>(f.stepwise.max.denominator) / f.stepwise.max.numerator);
      break;
    }
  }
  return out;
}

Result<V4l2Format> V4l2Device::setFormat(std::uint32_t fourcc, int width, int height) {
  v4l2_format f{};
  f.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  f.fmt.pix.pixelformat = fourcc;
  f.fmt.pix.width = static_cast<__u32>(width);
  f.fmt.pix.height = static_cast<__u32>(height);
  f.fmt.pix.field = V4L2_FIELD_NONE;
  if (xioctl(fd_, VIDIOC_S_FMT, &f) != 0) return errnoError("setting the format", errno);
  V4l2Format out;
  out.fourcc = f.fmt.pix.pixelformat;
  out.width = static_cast<int>(f.fmt.pix.width);
  out.height = static_cast<int>(f.fmt.pix.height);
  out.bytes_per_line = static_cast<int>(f.fmt.pix.bytesperline);
  out.size_image = f.fmt.pix.sizeimage;
  return out;
}

Result<double> V4l2Device::setFrameRate(double fps) {
  v4l2_streamparm p{};
  p.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(fd_, VIDIOC_G_PARM, &p) != 0 && errno != EINVAL && errno != ENOTTY)
    return errnoError("reading the frame rate", errno);
  if (!(p.parm.capture.capability & V4L2_CAP_TIMEPERFRAME))
    return fail(name() + " does not let its frame rate be set (no V4L2_CAP_TIMEPERFRAME)");
  // 1/fps as a fraction with microsecond-level precision (29.97 -> 1000/29970).
  p.parm.capture.timeperframe.numerator = 1000;
  p.parm.capture.timeperframe.denominator = static_cast<__u32>(std::llround(fps * 1000.0));
  if (xioctl(fd_, VIDIOC_S_PARM, &p) != 0) return errnoError("setting the frame rate", errno);
  const auto& t = p.parm.capture.timeperframe;
  if (t.numerator == 0) return fail(name() + " reported a frame interval of 0");
  return static_cast<double>(t.denominator) / t.numerator;
}

std::vector<V4l2Control> V4l2Device::controls() const {
  std::vector<V4l2Control> out;
  v4l2_query_ext_ctrl q{};
  q.id = V4L2_CTRL_FLAG_NEXT_CTRL;
  while (xioctl(fd_, VIDIOC_QUERY_EXT_CTRL, &q) == 0) {
    if (q.type != V4L2_CTRL_TYPE_CTRL_CLASS && !(q.flags & V4L2_CTRL_FLAG_DISABLED)) {
      V4l2Control c;
      c.id = q.id;
      c.name = cString(reinterpret_cast<const __u8*>(q.name), sizeof q.name);
      c.key = v4l2ControlKey(c.name);
      c.type = q.type;
      c.minimum = q.minimum;
      c.maximum = q.maximum;
      c.step = q.step ? static_cast<std::int64_t>(q.step) : 1;
      c.default_value = q.default_value;
      c.read_only = (q.flags & V4L2_CTRL_FLAG_READ_ONLY) != 0;
      out.push_back(c);
    }
    q.id |= V4L2_CTRL_FLAG_NEXT_CTRL;
  }
  return out;
}

std::optional<V4l2Control> V4l2Device::control(std::uint32_t id) const {
  for (const V4l2Control& c : controls())
    if (c.id == id) return c;
  return std::nullopt;
}

std::optional<V4l2Control> V4l2Device::control(const std::string& key) const {
  for (const V4l2Control& c : controls())
    if (c.key == key) return c;
  return std::nullopt;
}

Status V4l2Device::setControl(const V4l2Control& c, std::int64_t value) {
  if (c.read_only) return fail(name() + ": control " + c.key + " is read-only");
  // A button acts when written; its value means nothing (its range is 0..0).
  if (c.type != V4L2_CTRL_TYPE_BUTTON && (value < c.minimum || value > c.maximum))
    return fail(name() + ": control " + c.key + " = " + std::to_string(value) + " is outside " +
                std::to_string(c.minimum) + ".." + std::to_string(c.maximum));
  v4l2_ext_control e{};
  e.id = c.id;
  if (c.type == V4L2_CTRL_TYPE_INTEGER64)
    e.value64 = value;
  else
    e.value = static_cast<__s32>(value);
  v4l2_ext_controls cs{};
  cs.which = V4L2_CTRL_WHICH_CUR_VAL;
  cs.count = 1;
  cs.controls = &e;
  if (xioctl(fd_, VIDIOC_S_EXT_CTRLS, &cs) != 0)
    return errnoError("setting control " + c.key + " = " + std::to_string(value), errno);
  return Ok{};
}

Result<std::int64_t> V4l2Device::getControl(const V4l2Control& c) const {
  v4l2_ext_control e{};
  e.id = c.id;
  v4l2_ext_controls cs{};
  cs.which = V4L2_CTRL_WHICH_CUR_VAL;
  cs.count = 1;
  cs.controls = &e;
  if (xioctl(fd_, VIDIOC_G_EXT_CTRLS, &cs) != 0)
    return errnoError("reading control " + c.key, errno);
  return c.type == V4L2_CTRL_TYPE_INTEGER64 ? e.value64 : static_cast<std::int64_t>(e.value);
}

Status V4l2Device::startStreaming(int count) {
  v4l2_requestbuffers req{};
  req.count = static_cast<__u32>(count);
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  if (xioctl(fd_, VIDIOC_REQBUFS, &req) != 0) return errnoError("allocating buffers", errno);
  if (req.count < 2) {
    (void)stopStreaming();
    return fail(name() + " gave " + std::to_string(req.count) + " buffers; streaming needs 2");
  }
  for (__u32 i = 0; i < req.count; ++i) {
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    b.index = i;
    if (xioctl(fd_, VIDIOC_QUERYBUF, &b) != 0) {
      const int err = errno;
      (void)stopStreaming();
      return errnoError("querying buffer " + std::to_string(i), err);
    }
    void* addr = mmap(nullptr, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, b.m.offset);
    if (addr == MAP_FAILED) {
      const int err = errno;
      (void)stopStreaming();
      return errnoError("mapping buffer " + std::to_string(i), err);
    }
    maps_.push_back({addr, b.length});
  }
  for (int i = 0; i < static_cast<int>(maps_.size()); ++i) {
    if (Status s = queue(i); !s) {
      (void)stopStreaming();
      return s;
    }
  }
  v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(fd_, VIDIOC_STREAMON, &type) != 0) {
    const int err = errno;
    (void)stopStreaming();
    return errnoError("starting the stream", err);
  }
  streaming_ = true;
  return Ok{};
}

Status V4l2Device::stopStreaming() {
  Status result = Ok{};
  if (streaming_) {
    v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (xioctl(fd_, VIDIOC_STREAMOFF, &type) != 0)
      result = errnoError("stopping the stream", errno);
    streaming_ = false;
  }
  for (const Map& m : maps_) munmap(m.addr, m.length);
  if (!maps_.empty()) {
    maps_.clear();
    v4l2_requestbuffers req{};
    req.count = 0;
    req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    req.memory = V4L2_MEMORY_MMAP;
    if (xioctl(fd_, VIDIOC_REQBUFS, &req) != 0 && result)
      result = errnoError("freeing the buffers", errno);
  }
  return result;
}

Status V4l2Device::queue(int index) {
  v4l2_buffer b{};
  b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  b.memory = V4L2_MEMORY_MMAP;
  b.index = static_cast<__u32>(index);
  if (xioctl(fd_, VIDIOC_QBUF, &b) != 0) return errnoError("queueing a buffer", errno);
  return Ok{};
}

Result<std::optional<V4l2Capture>> V4l2Device::dequeue(int timeout_ms, int wake_fd) {
  pollfd fds[2] = {{fd_, POLLIN, 0}, {wake_fd, POLLIN, 0}};
  const int n = poll(fds, wake_fd >= 0 ? 2 : 1, timeout_ms);
  if (n < 0) {
    if (errno == EINTR) return std::optional<V4l2Capture>{};
    return errnoError("waiting for a frame", errno);
  }
  if (n == 0 || (wake_fd >= 0 && (fds[1].revents & POLLIN))) return std::optional<V4l2Capture>{};
  if (fds[0].revents & (POLLERR | POLLHUP | POLLNVAL)) {
    if (!(fds[0].revents & POLLIN)) return errnoError("waiting for a frame", ENODEV);
  }
  v4l2_buffer b{};
  b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  b.memory = V4L2_MEMORY_MMAP;
  if (xioctl(fd_, VIDIOC_DQBUF, &b) != 0) {
    if (errno == EAGAIN) return std::optional<V4l2Capture>{};
    return errnoError("taking a frame", errno);
  }
  V4l2Capture c;
  c.index = static_cast<int>(b.index);
  c.sequence = b.sequence;
  c.timestamp_ns =
      static_cast<std::int64_t>(b.timestamp.tv_sec) * 1'000'000'000 + b.timestamp.tv_usec * 1000;
  c.monotonic = (b.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC;
  c.start_of_exposure = (b.flags & V4L2_BUF_FLAG_TSTAMP_SRC_MASK) == V4L2_BUF_FLAG_TSTAMP_SRC_SOE;
  c.error = (b.flags & V4L2_BUF_FLAG_ERROR) != 0;
  c.data = static_cast<const std::uint8_t*>(maps_.at(b.index).addr);
  c.bytes_used = b.bytesused;
  return std::optional<V4l2Capture>(c);
}

Result<cv::Mat> v4l2ToMono(std::uint32_t fourcc, const std::uint8_t* data, std::size_t bytes,
                           int width, int height, int bytes_per_line, const cv::Rect& roi) {
  int bpp = 0;  // bytes per pixel in the source
  switch (fourcc) {
    case V4L2_PIX_FMT_GREY: bpp = 1; break;
    case V4L2_PIX_FMT_YUYV:
    case V4L2_PIX_FMT_Y12:
    case V4L2_PIX_FMT_Y16: bpp = 2; break;
    default:
      return fail("pixel format " + fourccText(fourcc) +
                  " cannot be read as grey (Collide reads GREY, YUYV, Y12, Y16)");
  }
  if (bytes_per_line <= 0) bytes_per_line = width * bpp;
  if (roi.x < 0 || roi.y < 0 || roi.x + roi.width > width || roi.y + roi.height > height ||
      roi.width <= 0 || roi.height <= 0)
    return fail("region " + std::to_string(roi.width) + "x" + std::to_string(roi.height) + " at (" +
                std::to_string(roi.x) + ", " + std::to_string(roi.y) + ") is outside the " +
                std::to_string(width) + "x" + std::to_string(height) + " frame");
  const std::size_t need =
      static_cast<std::size_t>(bytes_per_line) * static_cast<std::size_t>(height - 1) +
      static_cast<std::size_t>(width) * static_cast<std::size_t>(bpp);
  if (bytes < need)
    return fail("short frame: " + std::to_string(bytes) + " bytes, " + fourccText(fourcc) + " " +
                std::to_string(width) + "x" + std::to_string(height) + " needs " +
                std::to_string(need));
  if (fourcc == V4L2_PIX_FMT_GREY) {
    // Wrap without copying, then copy only the region.
    const cv::Mat all(height, width, CV_8UC1, const_cast<std::uint8_t*>(data),
                      static_cast<std::size_t>(bytes_per_line));
    return all(roi).clone();
  }
  if (fourcc == V4L2_PIX_FMT_YUYV) {
    // Y0 U Y1 V: the luma is every other byte.
    cv::Mat out(roi.height, roi.width, CV_8UC1);
    for (int y = 0; y < roi.height; ++y) {
      const std::uint8_t* src =
          data + static_cast<std::size_t>(roi.y + y) * static_cast<std::size_t>(bytes_per_line) +
          static_cast<std::size_t>(roi.x) * 2;
      std::uint8_t* dst = out.ptr<std::uint8_t>(y);
      for (int x = 0; x < roi.width; ++x) dst[x] = src[2 * x];
    }
    return out;
  }
  // Y12 and Y16: little-endian 16-bit words.
  cv::Mat out(roi.height, roi.width, CV_16UC1);
  const std::uint16_t mask = fourcc == V4L2_PIX_FMT_Y12 ? 0x0fff : 0xffff;
  for (int y = 0; y < roi.height; ++y) {
    const std::uint8_t* src =
        data + static_cast<std::size_t>(roi.y + y) * static_cast<std::size_t>(bytes_per_line) +
        static_cast<std::size_t>(roi.x) * 2;
    std::uint16_t* dst = out.ptr<std::uint16_t>(y);
    for (int x = 0; x < roi.width; ++x)
      dst[x] = static_cast<std::uint16_t>((src[2 * x] | (src[2 * x + 1] << 8)) & mask);
  }
  return out;
}

}  // namespace collide::hw
