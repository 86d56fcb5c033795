#include "hw/camera_v4l2.hpp"

#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>

#include "hw/backend_registry.hpp"
#include "hw/clock.hpp"
#include "hw/format.hpp"
#include "hw/try.hpp"

namespace collide::hw {

namespace {

using vision::PixelFormat;

// The driver formats Collide reads, in order of preference per camera.format.
std::vector<std::uint32_t> candidates(PixelFormat f) {
  switch (f) {
    case PixelFormat::Mono8: return {V4L2_PIX_FMT_GREY, V4L2_PIX_FMT_YUYV};
    case PixelFormat::Mono12: return {V4L2_PIX_FMT_Y12};
    case PixelFormat::Mono16: return {V4L2_PIX_FMT_Y16};
  }
  return {};
}

std::optional<PixelFormat> monoOf(std::uint32_t fourcc) {
  switch (fourcc) {
    case V4L2_PIX_FMT_GREY:
    case V4L2_PIX_FMT_YUYV: return PixelFormat::Mono8;
    case V4L2_PIX_FMT_Y12: return PixelFormat::Mono12;
    case V4L2_PIX_FMT_Y16: return PixelFormat::Mono16;
    default: return std::nullopt;
  }
}

std::string listFourccs(const std::vector<std::uint32_t>& v) {
  std::string s;
  for (auto f : v) s += (s.empty() ? "" : ", ") + fourccText(f);
  return s.empty() ? "none" : s;
}

template <class T>
std::string listOf(const std::vector<T>& v) {
  std::string s;
  for (const auto& x : v) {
    if constexpr (std::is_same_v<T, double>)
      s += (s.empty() ? "" : ", ") + num(x);
    else
      s += (s.empty() ? "" : ", ") + x;
  }
  return s.empty() ? "none listed" : s;
}

}  // namespace

Result<CameraV4l2Settings> CameraV4l2Settings::read(SettingsReader& r, const CameraConfig& role) {
  CameraV4l2Settings s;
  COLLIDE_ASSIGN_OR_RETURN(s.path, r.text("device"));
  if (s.path.empty() || s.path == "v4l2")
    return r.invalid("device",
                     "name the camera's node, e.g. \"/dev/video0\" (`v4l2-ctl "
                     "--list-devices` lists them)");
  COLLIDE_ASSIGN_OR_RETURN(const std::string pf,
                           r.text("pixel_format", "", {"", "GREY", "YUYV", "Y12", "Y16"}));
  if (!pf.empty()) {
    s.pixel_format = fourccFromText(pf);
    if (monoOf(s.pixel_format) != role.format)
      return r.invalid("pixel_format", pf + " gives " + vision::toString(*monoOf(s.pixel_format)) +
                                           " frames but camera.format is " +
                                           vision::toString(role.format));
  }
  COLLIDE_ASSIGN_OR_RETURN(
      const std::vector<double> frame,
      r.numbers("frame_px", 2,
                std::vector<double>{static_cast<double>(role.roi_x + role.width),
                                    static_cast<double>(role.roi_y + role.height)},
                {.ge = 1, .le = 65536}));
  if (std::floor(frame[0]) != frame[0] || std::floor(frame[1]) != frame[1])
    return r.invalid("frame_px", "must be whole numbers of pixels");
  s.frame_width = static_cast<int>(frame[0]);
  s.frame_height = static_cast<int>(frame[1]);
  COLLIDE_ASSIGN_OR_RETURN(s.buffers, r.integer("buffers", 8, {.ge = 2, .le = 64}));
  COLLIDE_ASSIGN_OR_RETURN(s.exposure_control, r.boolean("exposure_control", true));
  COLLIDE_ASSIGN_OR_RETURN(s.gain_raw_per_db, r.number("gain_raw_per_db", 1.0, {.ge = 0.0}));
  for (const auto& [key, value] : r.table().values) {
    if (key.rfind("controls.", 0) != 0) continue;
    r.markRead(key);
    const std::string name = key.substr(9);
    if (const auto* i = std::get_if<std::int64_t>(&value.value))
      s.controls.emplace_back(name, *i);
    else if (const auto* b = std::get_if<bool>(&value.value))
      s.controls.emplace_back(name, *b ? 1 : 0);
    else
      return r.invalid(key, "a V4L2 control takes a whole number (or true/false)");
  }
  COLLIDE_RETURN_IF_ERROR(r.finish("the v4l2 camera backend"));
  return s;
}

CameraV4l2::CameraV4l2(CameraV4l2Settings settings)
    : Camera("camera \"" + settings.path + "\""), settings_(std::move(settings)) {
  info_.backend = "v4l2";
  info_.device = settings_.path;
}

CameraV4l2::~CameraV4l2() {
  stopThread();
}

CameraInfo CameraV4l2::info() const {
  return info_;
}

Status CameraV4l2::onOpen() {
  COLLIDE_ASSIGN_OR_RETURN(device_, V4l2Device::open(settings_.path));
  const int w = settings_.frame_width, h = settings_.frame_height;
  CameraInfo i;
  i.backend = "v4l2";
  i.device = settings_.path;
  i.sensor_width = w;
  i.sensor_height = h;
  const std::vector<std::uint32_t> offered = device_->pixelFormats();
  std::vector<std::uint32_t> usable;
  if (settings_.pixel_format) {
    // Asked for explicitly: configure() says so if the device lacks it.
    usable = {settings_.pixel_format};
  } else {
    for (std::uint32_t f : offered)
      if (monoOf(f)) usable.push_back(f);
  }
  for (std::uint32_t f : usable) {
    const PixelFormat m = *monoOf(f);
    if (std::find(i.formats.begin(), i.formats.end(), m) == i.formats.end()) i.formats.push_back(m);
    for (double fps : device_->frameRates(f, w, h)) i.max_fps = std::max(i.max_fps, fps);
  }
  // A driver that does not list its rates: configure() checks what it sets.
  if (i.max_fps <= 0) i.max_fps = 1e6;
  if (settings_.gain_raw_per_db > 0)
    if (auto gain = device_->control(V4L2_CID_GAIN))
      i.max_gain_db = static_cast<double>(gain->maximum) / settings_.gain_raw_per_db;
  info_ = i;
  return Ok{};
}

Status CameraV4l2::lostIfGone(Status s) {
  if (s || !device_) return s;
  std::optional<std::string> gone = device_->gone();
  if (!gone) return s;
  return markLost(*gone, "the camera's cable and power, that " + settings_.path +
                             " is still there (`v4l2-ctl --list-devices`), and the kernel log "
                             "(dmesg)");
}

Status CameraV4l2::onConfigure(const CameraConfig& c) {
  return lostIfGone(configureDevice(c));
}

Status CameraV4l2::configureDevice(const CameraConfig& c) {
  const int w = settings_.frame_width, h = settings_.frame_height;
  const std::vector<std::uint32_t> offered = device_->pixelFormats();
  std::uint32_t fourcc = 0;
  const std::vector<std::uint32_t> wanted = settings_.pixel_format
                                                ? std::vector<std::uint32_t>{settings_.pixel_format}
                                                : candidates(c.format);
  for (std::uint32_t f : wanted)
    if (std::find(offered.begin(), offered.end(), f) != offered.end()) {
      fourcc = f;
      break;
    }
  if (!fourcc)
    return fail(device_->name() + " does not offer pixel format " + listFourccs(wanted) + " for " +
                vision::toString(c.format) + " frames (it offers " + listFourccs(offered) +
                "; Collide reads GREY, YUYV, Y12, Y16): change camera.format or "
                "camera.pixel_format");
  if (!device_->offersSize(fourcc, w, h))
    return fail(device_->name() + " does not capture " + std::to_string(w) + "x" +
                std::to_string(h) + " in " + fourccText(fourcc) + " (sizes: " +
                listOf(device_->frameSizes(fourcc)) + "): set camera.frame_px to one of them");
  COLLIDE_ASSIGN_OR_RETURN(const V4l2Format f, device_->setFormat(fourcc, w, h));
  if (f.fourcc != fourcc || f.width != w || f.height != h)
    return fail(device_->name() + " chose " + fourccText(f.fourcc) + " " + std::to_string(f.width) +
                "x" + std::to_string(f.height) + " when asked for " + fourccText(fourcc) + " " +
                std::to_string(w) + "x" + std::to_string(h) +
                ": set camera.frame_px and camera.pixel_format to what it offers");
  COLLIDE_ASSIGN_OR_RETURN(const double fps, device_->setFrameRate(c.fps));
  if (std::abs(fps - c.fps) > 1e-3 * c.fps)
    return fail(device_->name() + " cannot run at " + num(c.fps) + " frames/s at " +
                std::to_string(w) + "x" + std::to_string(h) + " " + fourccText(fourcc) +
                " (it chose " + num(fps) + "; it offers " +
                listOf(device_->frameRates(fourcc, w, h)) + "): set camera.fps to one of them");
  COLLIDE_RETURN_IF_ERROR(applyControls(c));
  format_ = f;
  config_ = c;
  return Ok{};
}

namespace {

// Sets a control and reads back what the device holds: a driver may round a
// value to its step, or clamp it, without an error, and a shot must record
// what the camera really ran with.
Result<std::int64_t> setAndReadBack(V4l2Device& d, const V4l2Control& c, std::int64_t value) {
  COLLIDE_RETURN_IF_ERROR(d.setControl(c, value));
  return d.getControl(c);
}

}  // namespace

Status CameraV4l2::applyControls(const CameraConfig& c) {
  V4l2Device& d = *device_;
  if (settings_.exposure_control) {
    const auto exposure = d.control(V4L2_CID_EXPOSURE_ABSOLUTE);
    if (!exposure)
      return fail(d.name() +
                  " has no exposure control (exposure_time_absolute): set "
                  "camera.exposure_control = false to leave exposure to the device");
    if (auto mode = d.control(V4L2_CID_EXPOSURE_AUTO))
      COLLIDE_RETURN_IF_ERROR(d.setControl(*mode, V4L2_EXPOSURE_MANUAL));
    // exposure_time_absolute counts 100 us steps.
    const double steps = c.exposure_us / 100.0;
    const std::int64_t value = std::llround(steps);
    if (std::abs(steps - static_cast<double>(value)) > 1e-6 || value < exposure->minimum ||
        value > exposure->maximum)
      return fail(d.name() + " sets exposure in steps of 100 us from " +
                  std::to_string(exposure->minimum * 100) + " to " +
                  std::to_string(exposure->maximum * 100) +
                  " us: set camera.exposure_us to one "
                  "of those (not " +
                  num(c.exposure_us) + ")");
    COLLIDE_ASSIGN_OR_RETURN(const std::int64_t held, setAndReadBack(d, *exposure, value));
    if (held != value)
      return fail(d.name() + " took exposure " + num(held * 100.0) + " us when asked for " +
                  num(c.exposure_us) + " us (its control's step is " +
                  std::to_string(exposure->step * 100) +
                  " us): set camera.exposure_us to a value it keeps");
  }
  if (settings_.gain_raw_per_db > 0) {
    if (auto gain = d.control(V4L2_CID_GAIN)) {
      if (auto autogain = d.control(V4L2_CID_AUTOGAIN))
        COLLIDE_RETURN_IF_ERROR(d.setControl(*autogain, 0));
      const std::int64_t raw = std::llround(c.gain_db * settings_.gain_raw_per_db);
      if (raw < gain->minimum || raw > gain->maximum)
        return fail(d.name() + ": gain " + num(c.gain_db) + " dB is raw " + std::to_string(raw) +
                    ", outside the control's " + std::to_string(gain->minimum) + ".." +
                    std::to_string(gain->maximum) +
                    ": check camera.gain_db and "
                    "camera.gain_raw_per_db");
      COLLIDE_ASSIGN_OR_RETURN(const std::int64_t held, setAndReadBack(d, *gain, raw));
      if (held != raw)
        return fail(d.name() + " took gain raw " + std::to_string(held) + " (" +
                    num(static_cast<double>(held) / settings_.gain_raw_per_db) +
                    " dB) when asked for raw " + std::to_string(raw) + " (" + num(c.gain_db) +
                    " dB; its control's step is " + std::to_string(gain->step) +
                    "): set camera.gain_db to a value it keeps");
    }
  }
  for (const auto& [key, value] : settings_.controls) {
    const auto control = d.control(key);
    if (!control) {
      std::string known;
      for (const V4l2Control& k : d.controls())
        if (!k.read_only) known += (known.empty() ? "" : ", ") + k.key;
      return fail(d.name() + " has no control \"" + key + "\" (camera.controls." + key +
                  "); it has: " + known);
    }
    if (Status s = d.setControl(*control, value); !s)
      return fail(s.error().message + " (camera.controls." + key + ")");
  }
  return Ok{};
}

Status CameraV4l2::onStart() {
  dropped_ = 0;
  captured_ = 0;
  COLLIDE_RETURN_IF_ERROR(lostIfGone(device_->startStreaming(settings_.buffers)));
  wake_fd_ = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (wake_fd_ < 0) {
    (void)device_->stopStreaming();
    return fail("cannot create an eventfd for the acquisition thread");
  }
  thread_ = std::thread(&CameraV4l2::run, this);
  return Ok{};
}

void CameraV4l2::stopThread() {
  if (thread_.joinable()) {
    const std::uint64_t one = 1;
    (void)!write(wake_fd_, &one, sizeof one);
    thread_.join();
  }
  if (wake_fd_ >= 0) {
    ::close(wake_fd_);
    wake_fd_ = -1;
  }
}

Status CameraV4l2::onStop() {
  stopThread();
  return device_ ? lostIfGone(device_->stopStreaming()) : Status(Ok{});
}

Status CameraV4l2::onClose() {
  stopThread();
  device_.reset();
  return Ok{};
}

void CameraV4l2::run() {
  const std::int64_t exposure_ns = std::llround(config_.exposure_us * 1000.0);
  const cv::Rect roi(config_.roi_x, config_.roi_y, config_.width, config_.height);
  bool first = true;
  std::uint32_t last32 = 0;
  std::uint64_t seq = 0;
  for (;;) {
    auto got = device_->dequeue(500, wake_fd_);
    if (!got) {
      // The device went away: lost, so the next call is refused at once; the
      // burst ends with the same sentence and keeps what arrived.
      const std::string why = lostIfGone(got.error()).error().message;
      if (auto rec = recorder()) rec->endOfStream(why);
      return;
    }
    std::uint64_t wake = 0;
    if (read(wake_fd_, &wake, sizeof wake) == sizeof wake) return;  // stop()
    if (!*got) continue;
    const V4l2Capture& c = **got;
    // The driver's 32-bit counter, widened; a gap is frames it lost.
    if (first) {
      seq = c.sequence;
      first = false;
    } else {
      const std::uint32_t delta = c.sequence - last32;
      if (delta >= 1 && delta < 0x80000000u) {
        seq += delta;
        dropped_ += delta - 1;
      } else {
        ++seq;  // a driver that restarted or repeated its count
      }
    }
    last32 = c.sequence;
    ++captured_;
    const std::int64_t stamped = c.monotonic ? c.timestamp_ns : monotonicNowNs();
    const std::int64_t start = c.monotonic && c.start_of_exposure ? stamped : stamped - exposure_ns;
    if (auto rec = recorder(); rec && rec->wants(start)) {
      vision::Frame frame;
      frame.timestamp_ns = start;
      auto image =
          v4l2ToMono(format_.fourcc, c.data, c.bytes_used ? c.bytes_used : format_.size_image,
                     format_.width, format_.height, format_.bytes_per_line, roi);
      if (image) {
        frame.image = std::move(image).value();
        frame.status = c.error ? vision::FrameStatus::Failed : vision::FrameStatus::Good;
      } else {
        frame.image = cv::Mat::zeros(roi.height, roi.width, vision::cvType(config_.format));
        frame.status = vision::FrameStatus::Incomplete;
      }
      rec->push(seq, std::move(frame));
    }
    if (Status s = lostIfGone(device_->queue(c.index)); !s) {
      if (auto rec = recorder()) rec->endOfStream(s.error().message);
      return;
    }
  }
}

namespace {

Result<std::unique_ptr<Camera>> makeV4l2(BackendContext& ctx) {
  SettingsReader r = ctx.device.backendSettings();
  COLLIDE_ASSIGN_OR_RETURN(CameraV4l2Settings s,
                           CameraV4l2Settings::read(r, ctx.profile.camera_config));
  if (ctx.clock != monotonicClock())
    return fail(
        "camera \"" + ctx.device.device +
        "\": V4L2 timestamps are on CLOCK_MONOTONIC; build its rig without RigHooks::clock");
  return std::unique_ptr<Camera>(std::make_unique<CameraV4l2>(std::move(s)));
}

const bool registered = BackendRegistry<Camera>::instance().add("v4l2", &makeV4l2);

}  // namespace

}  // namespace collide::hw
