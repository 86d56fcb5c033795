#include "hw/camera_aravis.hpp"

#include <arv.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <ctime>
#include <deque>
#include <limits>
#include <mutex>
#include <thread>

#include "hw/backend_registry.hpp"
#include "hw/clock.hpp"
#include "hw/format.hpp"
#include "hw/try.hpp"

namespace collide::hw {

namespace {

constexpr const char* kSetupDoc = "docs/camera-aravis.md";

// Set on this thread when message() saw a control request go unanswered
// after all of Aravis' retries (or the device was no longer connected):
// the camera is gone, not refusing a setting.
thread_local bool t_unanswered = false;

// The message of a GError (freed), or `fallback` when there is none.
std::string message(GError*& e, const std::string& fallback = "no reason given") {
  if (!e) return fallback;
  if (e->domain == ARV_DEVICE_ERROR &&
      (e->code == ARV_DEVICE_ERROR_TIMEOUT || e->code == ARV_DEVICE_ERROR_NOT_CONNECTED))
    t_unanswered = true;
  std::string m = e->message ? e->message : fallback;
  g_clear_error(&e);
  return m;
}

ArvPixelFormat toArv(vision::PixelFormat f) {
  switch (f) {
    case vision::PixelFormat::Mono8: return ARV_PIXEL_FORMAT_MONO_8;
    case vision::PixelFormat::Mono12: return ARV_PIXEL_FORMAT_MONO_12;
    case vision::PixelFormat::Mono16: return ARV_PIXEL_FORMAT_MONO_16;
  }
  return ARV_PIXEL_FORMAT_MONO_8;
}

std::optional<vision::PixelFormat> fromArv(ArvPixelFormat f) {
  if (f == ARV_PIXEL_FORMAT_MONO_8) return vision::PixelFormat::Mono8;
  if (f == ARV_PIXEL_FORMAT_MONO_12) return vision::PixelFormat::Mono12;
  if (f == ARV_PIXEL_FORMAT_MONO_16) return vision::PixelFormat::Mono16;
  return std::nullopt;
}

int bytesPerPixel(vision::PixelFormat f) {
  return f == vision::PixelFormat::Mono8 ? 1 : 2;
}

std::int64_t realtimeNowNs() {
  timespec t{};
  clock_gettime(CLOCK_REALTIME, &t);
  return static_cast<std::int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

// CLOCK_REALTIME minus CLOCK_MONOTONIC, now. Read between two real-time
// readings taken close together: a thread preempted between its readings
// would otherwise bias the result by however long it waited.
std::int64_t realtimeMinusMonotonicNs() {
  std::int64_t best = 0, best_spread = std::numeric_limits<std::int64_t>::max();
  for (int i = 0; i < 5; ++i) {
    const std::int64_t r1 = realtimeNowNs();
    const std::int64_t m = monotonicNowNs();
    const std::int64_t r2 = realtimeNowNs();
    if (r2 - r1 < best_spread) {
      best_spread = r2 - r1;
      best = r1 + (r2 - r1) / 2 - m;
    }
    if (best_spread < 20'000) break;
  }
  return best;
}

// The camera's clock against CLOCK_MONOTONIC. Every frame arrives some time
// after its exposure started; the fastest arrival is the best estimate of the
// fixed offset (plus the link's minimum latency). A minimum over a sliding
// window of frames follows slow drift between the two clocks.
class ClockMap {
 public:
  void add(std::int64_t arrival_minus_device) {
    current_ = std::min(current_, arrival_minus_device);
    if (++n_ == kWindow) {
      previous_ = current_;
      current_ = kNone;
      n_ = 0;
    }
  }
  bool known() const { return std::min(current_, previous_) != kNone; }
  std::int64_t offset() const { return std::min(current_, previous_); }

 private:
  static constexpr std::int64_t kNone = std::numeric_limits<std::int64_t>::max();
  static constexpr int kWindow = 256;
  std::int64_t current_ = kNone, previous_ = kNone;
  int n_ = 0;
};

/// Lets go of a lost camera's Aravis objects on a thread of its own. Aravis
/// still talks to the device while it tears them down (its stream channel's
/// port, then the release of control: each request 5 x 500 ms to a device
/// that is gone, hard-coded in Aravis 0.8), which made stop() wait 5 s and
/// close() 2.5 s on a camera that was already lost, holding up the shot's
/// safe stop and the GUI's control thread. Objects are let go in the order
/// given; open() waits until none is pending (a camera that answers again is
/// then free to be taken control of), and so does the process at exit.
class LostObjectReaper {
 public:
  static LostObjectReaper& instance() {
    static LostObjectReaper reaper;
    return reaper;
  }
  /// Unreferences `object` (a GObject) later, on the reaper's thread.
  void release(gpointer object) {
    std::lock_guard lock(mutex_);
    queue_.push_back(object);
    if (!thread_.joinable()) thread_ = std::thread([this] { run(); });
    changed_.notify_all();
  }
  /// Returns once every object given so far has been let go.
  void waitIdle() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [this] { return queue_.empty() && !busy_; });
  }
  ~LostObjectReaper() {
    {
      std::lock_guard lock(mutex_);
      done_ = true;
      changed_.notify_all();
    }
    if (thread_.joinable()) thread_.join();
  }

 private:
  void run() {
    std::unique_lock lock(mutex_);
    for (;;) {
      changed_.wait(lock, [this] { return done_ || !queue_.empty(); });
      if (queue_.empty()) return;  // done, nothing left
      gpointer object = queue_.front();
      queue_.pop_front();
      busy_ = true;
      lock.unlock();
      g_object_unref(object);
      lock.lock();
      busy_ = false;
      changed_.notify_all();
    }
  }

  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<gpointer> queue_;
  bool busy_ = false, done_ = false;
  std::thread thread_;
};

const char* toString(AravisTrigger t) {
  switch (t) {
    case AravisTrigger::FreeRun: return "free_run";
    case AravisTrigger::Software: return "software";
    case AravisTrigger::Line: return "line";
  }
  return "?";
}

}  // namespace

// ---------------------------------------------------------------- settings ---

Result<CameraAravisSettings> CameraAravisSettings::read(SettingsReader& r) {
  CameraAravisSettings s;
  COLLIDE_ASSIGN_OR_RETURN(const std::string trigger,
                           r.text("trigger", "free_run", {"free_run", "software", "line"}));
  s.trigger = trigger == "software" ? AravisTrigger::Software
              : trigger == "line"   ? AravisTrigger::Line
                                    : AravisTrigger::FreeRun;
  COLLIDE_ASSIGN_OR_RETURN(s.trigger_line, r.text("trigger_line", "Line0"));
  COLLIDE_ASSIGN_OR_RETURN(s.trigger_activation, r.text("trigger_activation", "RisingEdge"));
  COLLIDE_ASSIGN_OR_RETURN(const std::int64_t packet,
                           r.integer("packet_size_bytes", 0, {.ge = 0, .le = 65535}));
  if (packet != 0 && packet < 576)
    return r.invalid("packet_size_bytes",
                     "must be 0 (negotiate) or at least 576 bytes (1500 on a standard "
                     "Ethernet link, up to 9000 with jumbo frames)");
  s.packet_size_bytes = static_cast<int>(packet);
  COLLIDE_ASSIGN_OR_RETURN(s.packet_delay_ns,
                           r.integer("packet_delay_ns", 0, {.ge = 0, .le = 1e9}));
  COLLIDE_ASSIGN_OR_RETURN(const std::int64_t buffers,
                           r.integer("buffers", 64, {.ge = 4, .le = 100000}));
  s.buffers = static_cast<int>(buffers);
  COLLIDE_ASSIGN_OR_RETURN(const std::int64_t socket,
                           r.integer("socket_buffer_bytes", 0, {.ge = 0, .le = 1LL << 30}));
  s.socket_buffer_bytes = static_cast<int>(socket);
  COLLIDE_ASSIGN_OR_RETURN(s.packet_resend, r.boolean("packet_resend", true));
  COLLIDE_ASSIGN_OR_RETURN(s.packet_timeout_ms,
                           r.number("packet_timeout_ms", 0.0, {.ge = 0.0, .le = 10000.0}));
  COLLIDE_ASSIGN_OR_RETURN(s.frame_retention_ms,
                           r.number("frame_retention_ms", 0.0, {.ge = 0.0, .le = 60000.0}));
  if (r.table().has("timestamp_latency_us")) {
    COLLIDE_ASSIGN_OR_RETURN(s.timestamp_latency_us,
                             r.number("timestamp_latency_us", std::nullopt, {.ge = 0.0}));
  }
  COLLIDE_ASSIGN_OR_RETURN(s.stall_timeout_ms,
                           r.number("stall_timeout_ms", 0.0, {.ge = 0.0, .le = 3.6e6}));

  // [camera.features]: flattened to "features.<name>"; applied in file order.
  const std::string prefix = "features.";
  for (const auto& [key, value] : r.table().values) {
    if (key.rfind(prefix, 0) != 0) continue;
    const std::string name = key.substr(prefix.size());
    if (name.empty() || name.find('.') != std::string::npos)
      return r.invalid(key, "write each GenICam feature as `Name = value` under [camera.features]");
    if (std::holds_alternative<std::vector<double>>(value.value) ||
        std::holds_alternative<std::vector<std::string>>(value.value))
      return r.invalid(key,
                       "a GenICam feature takes one value: true/false, a number, or an "
                       "enumeration entry's name in quotes");
    r.markRead(key);
    s.features.push_back({name, value, r.where(key)});
  }
  std::stable_sort(
      s.features.begin(), s.features.end(),
      [](const GenicamFeature& a, const GenicamFeature& b) { return a.value.line < b.value.line; });
  COLLIDE_RETURN_IF_ERROR(r.finish("the aravis camera backend"));
  return s;
}

std::optional<std::uint64_t> CameraAravis::unwrapFrameId(std::uint64_t previous_raw,
                                                         std::uint64_t previous_counter,
                                                         std::uint64_t raw) {
  if (raw > previous_raw) return previous_counter + (raw - previous_raw);
  // A 16-bit id that went round: ..., 65534, 65535, 1, 2, ... (0 is never used).
  if (previous_raw <= 0xFFFF && previous_raw - raw > 0x8000)
    return previous_counter + (0xFFFF - previous_raw) + std::max<std::uint64_t>(raw, 1);
  return std::nullopt;
}

// -------------------------------------------------------------------- impl ---

struct CameraAravis::Impl {
  Impl(CameraAravis& owner, std::string device, CameraAravisSettings settings)
      : owner(owner), device(std::move(device)), settings(std::move(settings)) {}

  CameraAravis& owner;
  const std::string device;
  const CameraAravisSettings settings;

  // Aravis' GenICam node tree is not thread-safe: every use of `camera`
  // (control thread, and the acquisition thread's software triggers and
  // liveness probes) holds this.
  mutable std::mutex arv_mutex;
  ArvCamera* camera = nullptr;
  ArvStream* stream = nullptr;  // while running
  gulong lost_handler = 0;
  bool gv = false;
  ArvFakeCamera* fake = nullptr;  // the in-process fake's simulator, if that is what we opened

  mutable std::mutex info_mutex;
  CameraInfo info;

  CameraConfig config;      // written by configure, read by the acquisition thread after start
  std::size_t payload = 0;  // bytes per buffer of the pool, set at start
  std::thread thread;
  std::atomic<bool> stop{false};
  std::atomic<bool> lost{false};

  mutable std::mutex counters_mutex;
  AravisCounters counters;
  AravisCounters at_arm;

  std::mutex fill_mutex;
  std::function<void(const FakeFrameRequest&)> fill;

  std::string label() const { return owner.label(); }

  // ---- open / close -------------------------------------------------------
  Status open();
  void close();
  Status configure(const CameraConfig& c);
  Status setRegion(const CameraConfig& c);  // configure()'s stages, arv_mutex held
  Status setPixelFormat(const CameraConfig& c);
  Status setExposure(const CameraConfig& c);
  Status setGain(const CameraConfig& c);
  Status setFrameRate(const CameraConfig& c);
  Status setTransport();
  Status applyFeature(const GenicamFeature& f);
  Status setTrigger();
  Status start();
  Status stopStream();
  void refreshInfoLocked();

  // ---- acquisition thread -------------------------------------------------
  void run();
  void refreshStreamCounters();
  void markLost(const std::string& why);
  // The stream has been silent for `silent_ns`: is the camera still there?
  // `frames_expected`: it should have sent frames (free run, software
  // trigger), so a silent camera that answers has a stalled stream.
  void checkStall(std::int64_t silent_ns, bool frames_expected);
  // run()'s stages, below it.
  struct StreamClock;
  struct Sequence;
  std::int64_t softwareTrigger(std::int64_t now, std::int64_t period, std::int64_t& next_trigger);
  vision::FrameStatus frameStatus(ArvBuffer* b, int& w, int& h) const;
  bool copyImage(ArvBuffer* b, int w, int h, vision::Frame& frame) const;
  void countFrame(std::uint64_t seq, std::uint64_t skipped, bool good, int w, int h);

  static void onControlLost(ArvDevice*, gpointer self) {
    static_cast<Impl*>(self)->markLost("its control link stopped answering (heartbeat lost)");
  }
  static void fillTrampoline(ArvBuffer* buffer, void* self, guint32 exposure_us, guint32,
                             ArvPixelFormat format) {
    auto* impl = static_cast<Impl*>(self);
    std::lock_guard lock(impl->fill_mutex);
    if (!impl->fill || !buffer) return;
    const auto f = fromArv(format);
    if (!f) return;
    FakeFrameRequest q;
    q.frame_id = arv_buffer_get_frame_id(buffer);
    // The fake stamps frames with the host's real-time clock.
    const auto stamped = static_cast<std::int64_t>(arv_buffer_get_timestamp(buffer));
    q.exposure_start_ns = stamped > 0 ? stamped - realtimeMinusMonotonicNs() : monotonicNowNs();
    q.width = arv_buffer_get_image_width(buffer);
    q.height = arv_buffer_get_image_height(buffer);
    q.format = *f;
    q.exposure_us = exposure_us;
    std::size_t size = 0;
    // The fake fills its own buffer here; Aravis hands it out as const data.
    q.data = const_cast<void*>(arv_buffer_get_data(buffer, &size));
    if (q.data && q.width > 0 && q.height > 0) impl->fill(q);
  }
};

Status CameraAravis::Impl::open() {
  // A lost camera of earlier may still be letting go of the device.
  LostObjectReaper::instance().waitIdle();
  if (device.rfind("Fake_", 0) == 0) arv_enable_interface("Fake");
  GError* e = nullptr;
  std::lock_guard lock(arv_mutex);
  camera = arv_camera_new(device.c_str(), &e);
  if (!camera) {
    const std::string why = message(e, "not found");
    // Say what Aravis does see, so a typo in the id stands out.
    arv_update_device_list();
    std::string seen;
    for (unsigned i = 0; i < arv_get_n_devices(); ++i) {
      const char* id = arv_get_device_id(i);
      const char* address = arv_get_device_address(i);
      seen += std::string(seen.empty() ? "" : ", ") + "\"" + (id ? id : "?") + "\"" +
              (address && *address ? std::string(" at ") + address : std::string());
    }
    return fail("cannot open the camera (" + why + "); Aravis sees " +
                (seen.empty() ? std::string("no camera") : seen) +
                ": check camera.device (a device id, serial number or IP address; "
                "arv-tool-0.8 lists them), the cable and power, that a GigE camera's address "
                "is on the host's subnet, and " +
                kSetupDoc);
  }
  gv = arv_camera_is_gv_device(camera);
  // Refuse out-of-range and read-only writes instead of letting the camera
  // clamp or ignore them silently.
  arv_camera_set_range_check_policy(camera, ARV_RANGE_CHECK_POLICY_ENABLE);
  arv_camera_set_access_check_policy(camera, ARV_ACCESS_CHECK_POLICY_ENABLE);
  ArvDevice* dev = arv_camera_get_device(camera);
  fake = ARV_IS_FAKE_DEVICE(dev) ? arv_fake_device_get_fake_camera(ARV_FAKE_DEVICE(dev)) : nullptr;
  lost = false;
  lost_handler = g_signal_connect(dev, "control-lost", G_CALLBACK(&Impl::onControlLost), this);
  refreshInfoLocked();
  const std::string vendor = arv_camera_get_vendor_name(camera, nullptr)
                                 ? arv_camera_get_vendor_name(camera, nullptr)
                                 : "?";
  const std::string model =
      arv_camera_get_model_name(camera, nullptr) ? arv_camera_get_model_name(camera, nullptr) : "?";
  spdlog::info("{}: opened {} {} ({}), sensor {}x{}", label(), vendor, model,
               gv ? "GigE Vision" : "other transport", info.sensor_width, info.sensor_height);
  return Ok{};
}

void CameraAravis::Impl::refreshInfoLocked() {
  CameraInfo i;
  i.backend = "aravis";
  i.device = device;
  GError* e = nullptr;
  arv_camera_get_sensor_size(camera, &i.sensor_width, &i.sensor_height, &e);
  g_clear_error(&e);
  guint n = 0;
  gint64* formats = arv_camera_dup_available_pixel_formats(camera, &n, &e);
  g_clear_error(&e);
  for (guint k = 0; formats && k < n; ++k)
    if (auto f = fromArv(static_cast<ArvPixelFormat>(formats[k]))) i.formats.push_back(*f);
  g_free(formats);
  std::sort(i.formats.begin(), i.formats.end());
  double lo = 0, hi = 0;
  if (arv_camera_is_frame_rate_available(camera, nullptr)) {
    arv_camera_get_frame_rate_bounds(camera, &lo, &hi, &e);
    if (!e) i.max_fps = hi;
    g_clear_error(&e);
  }
  if (settings.trigger != AravisTrigger::FreeRun && i.max_fps <= 0.0) i.max_fps = 1e6;
  if (arv_camera_is_gain_available(camera, nullptr)) {
    arv_camera_get_gain_bounds(camera, &lo, &hi, &e);
    if (!e) i.max_gain_db = hi;
    g_clear_error(&e);
  }
  std::lock_guard lock(info_mutex);
  info = std::move(i);
}

void CameraAravis::Impl::close() {
  std::lock_guard lock(arv_mutex);
  if (fake) {
    arv_fake_camera_set_fill_pattern(fake, nullptr, nullptr);
    fake = nullptr;
  }
  {
    std::lock_guard f(fill_mutex);
    fill = nullptr;
  }
  if (camera) {
    if (lost_handler) g_signal_handler_disconnect(arv_camera_get_device(camera), lost_handler);
    lost_handler = 0;
    // Unreferencing the camera joins its heartbeat thread: no callback after
    // this (the handler is disconnected above either way). A lost camera's
    // is let go in the background: Aravis asks the dead device to release it.
    if (lost)
      LostObjectReaper::instance().release(camera);
    else
      g_object_unref(camera);
    camera = nullptr;
  }
}

Status CameraAravis::Impl::applyFeature(const GenicamFeature& f) {
  ArvDevice* dev = arv_camera_get_device(camera);
  GError* e = nullptr;
  const std::string at = f.where + " = " + f.value.text();
  ArvGcNode* node = arv_device_get_feature(dev, f.name.c_str());
  if (!node)
    return fail(at + ": the camera has no feature \"" + f.name +
                "\" (names are case-sensitive; arv-tool-0.8 features lists them)");
  const auto& v = f.value.value;
  auto number = [&]() -> std::optional<double> {
    if (const auto* i = std::get_if<std::int64_t>(&v)) return static_cast<double>(*i);
    if (const auto* d = std::get_if<double>(&v)) return *d;
    return std::nullopt;
  };
  std::string readback, wanted = f.value.text();
  bool matches = true;
  if (ARV_IS_GC_ENUMERATION(node) || ARV_IS_GC_STRING(node)) {
    const auto* s = std::get_if<std::string>(&v);
    if (!s) return fail(at + ": \"" + f.name + "\" takes a name in quotes, e.g. \"Off\"");
    arv_device_set_string_feature_value(dev, f.name.c_str(), s->c_str(), &e);
    if (e) return fail(at + ": the camera refused it (" + message(e) + ")");
    const char* got = arv_device_get_string_feature_value(dev, f.name.c_str(), &e);
    readback = got ? got : "";
    matches = !e && readback == *s;
    wanted = *s;
  } else if (ARV_IS_GC_BOOLEAN(node)) {
    const auto* b = std::get_if<bool>(&v);
    if (!b) return fail(at + ": \"" + f.name + "\" takes true or false");
    arv_device_set_boolean_feature_value(dev, f.name.c_str(), *b, &e);
    if (e) return fail(at + ": the camera refused it (" + message(e) + ")");
    const bool got = arv_device_get_boolean_feature_value(dev, f.name.c_str(), &e);
    readback = got ? "true" : "false";
    matches = !e && got == *b;
  } else if (ARV_IS_GC_FLOAT(node)) {
    const auto d = number();
    if (!d) return fail(at + ": \"" + f.name + "\" takes a number");
    arv_device_set_float_feature_value(dev, f.name.c_str(), *d, &e);
    if (e) return fail(at + ": the camera refused it (" + message(e) + ")");
    const double got = arv_device_get_float_feature_value(dev, f.name.c_str(), &e);
    readback = num(got);
    matches = !e && std::abs(got - *d) <= 1e-3 * std::max(1.0, std::abs(*d));
  } else if (ARV_IS_GC_INTEGER(node)) {
    const auto* i = std::get_if<std::int64_t>(&v);
    if (!i) return fail(at + ": \"" + f.name + "\" takes a whole number");
    arv_device_set_integer_feature_value(dev, f.name.c_str(), *i, &e);
    if (e) return fail(at + ": the camera refused it (" + message(e) + ")");
    const gint64 got = arv_device_get_integer_feature_value(dev, f.name.c_str(), &e);
    readback = std::to_string(got);
    matches = !e && got == *i;
  } else if (ARV_IS_GC_COMMAND(node)) {
    return fail(at + ": \"" + f.name +
                "\" is a command; the profile sets values only (commands are not run)");
  } else {
    return fail(at + ": \"" + f.name + "\" is not a value the profile can set");
  }
  g_clear_error(&e);
  if (!matches)
    return fail(at + ": the camera took it but reads back " + readback +
                " (check the feature's range and increment)");
  return Ok{};
}

Status CameraAravis::Impl::setTrigger() {
  ArvDevice* dev = arv_camera_get_device(camera);
  GError* e = nullptr;
  auto available = [&](const char* feature) {
    const bool a = arv_device_is_feature_available(dev, feature, &e);
    g_clear_error(&e);
    return a;
  };
  auto set = [&](const char* feature, const std::string& value,
                 const std::string& field) -> Status {
    arv_device_set_string_feature_value(dev, feature, value.c_str(), &e);
    if (e)
      return fail(std::string("cannot set ") + feature + " to \"" + value + "\" (" + message(e) +
                  "): check " + field);
    return Ok{};
  };
  const bool on = settings.trigger != AravisTrigger::FreeRun;
  if (!available("TriggerMode")) {
    if (on)
      return fail(std::string("trigger = \"") + toString(settings.trigger) +
                  "\": the camera has no TriggerMode feature: use trigger = \"free_run\"");
    return Ok{};
  }
  if (available("TriggerSelector"))
    COLLIDE_RETURN_IF_ERROR(set("TriggerSelector", "FrameStart", "camera.trigger"));
  if (!on) return set("TriggerMode", "Off", "camera.trigger");
  const std::string source =
      settings.trigger == AravisTrigger::Software ? std::string("Software") : settings.trigger_line;
  COLLIDE_RETURN_IF_ERROR(
      set("TriggerSource", source,
          settings.trigger == AravisTrigger::Software ? "camera.trigger" : "camera.trigger_line"));
  if (settings.trigger == AravisTrigger::Line && available("TriggerActivation"))
    COLLIDE_RETURN_IF_ERROR(
        set("TriggerActivation", settings.trigger_activation, "camera.trigger_activation"));
  return set("TriggerMode", "On", "camera.trigger");
}

// configure()'s stages, each with arv_mutex held: the region of interest.
Status CameraAravis::Impl::setRegion(const CameraConfig& c) {
  GError* e = nullptr;
  const std::string roi = std::to_string(c.width) + "x" + std::to_string(c.height) + " at (" +
                          std::to_string(c.roi_x) + ", " + std::to_string(c.roi_y) + ")";
  arv_camera_set_region(camera, c.roi_x, c.roi_y, c.width, c.height, &e);
  gint x = -1, y = -1, w = -1, h = -1;
  if (!e) arv_camera_get_region(camera, &x, &y, &w, &h, &e);
  if (e || x != c.roi_x || y != c.roi_y || w != c.width || h != c.height) {
    const std::string why = e ? " (" + message(e) + ")"
                              : ": it set " + std::to_string(w) + "x" + std::to_string(h) +
                                    " at (" + std::to_string(x) + ", " + std::to_string(y) + ")";
    const gint wi = arv_camera_get_width_increment(camera, nullptr);
    const gint hi = arv_camera_get_height_increment(camera, nullptr);
    return fail("the camera cannot take the region of interest " + roi + why +
                ": check camera.roi (width a multiple of " + std::to_string(std::max(1, wi)) +
                ", height a multiple of " + std::to_string(std::max(1, hi)) + ")");
  }

  return Ok{};
}

Status CameraAravis::Impl::setPixelFormat(const CameraConfig& c) {
  GError* e = nullptr;
  arv_camera_set_pixel_format(camera, toArv(c.format), &e);
  const ArvPixelFormat pf = e ? 0 : arv_camera_get_pixel_format(camera, &e);
  if (e || pf != toArv(c.format))
    return fail(std::string("the camera did not take pixel format ") + vision::toString(c.format) +
                (e ? " (" + message(e) + ")" : std::string()) + ": check camera.format");

  return Ok{};
}

// The exposure time, when the camera has the feature (a warning when not).
Status CameraAravis::Impl::setExposure(const CameraConfig& c) {
  GError* e = nullptr;
  if (arv_camera_is_exposure_time_available(camera, nullptr)) {
    double lo = 0, hi = 0;
    arv_camera_get_exposure_time_bounds(camera, &lo, &hi, &e);
    g_clear_error(&e);
    if (hi > 0 && (c.exposure_us < lo || c.exposure_us > hi))
      return fail("exposure " + num(c.exposure_us) + " us is outside the camera's " + num(lo) +
                  ".." + num(hi) + " us: check camera.exposure_us");
    arv_camera_set_exposure_time(camera, c.exposure_us, &e);
    const double got = e ? 0.0 : arv_camera_get_exposure_time(camera, &e);
    if (e || std::abs(got - c.exposure_us) > std::max(1.0, 0.01 * c.exposure_us))
      return fail("the camera did not take exposure " + num(c.exposure_us) + " us" +
                  (e ? " (" + message(e) + ")" : " (it reads back " + num(got) + " us)") +
                  ": check camera.exposure_us");
  } else {
    spdlog::warn("{}: the camera has no exposure time feature; camera.exposure_us is not applied",
                 label());
  }

  return Ok{};
}

// The gain, when the camera has the feature (else camera.gain_db must be 0).
Status CameraAravis::Impl::setGain(const CameraConfig& c) {
  GError* e = nullptr;
  if (arv_camera_is_gain_available(camera, nullptr)) {
    arv_camera_set_gain(camera, c.gain_db, &e);
    const double got = e ? 0.0 : arv_camera_get_gain(camera, &e);
    if (e || std::abs(got - c.gain_db) > std::max(0.05, 0.01 * c.gain_db))
      return fail("the camera did not take gain " + num(c.gain_db) +
                  (e ? " (" + message(e) + ")" : " (it reads back " + num(got) + ")") +
                  ": check camera.gain_db");
  } else if (c.gain_db != 0.0) {
    return fail("the camera has no gain feature: set camera.gain_db = 0");
  }

  return Ok{};
}

// The frame rate, in free run only (triggered frames come when triggered).
Status CameraAravis::Impl::setFrameRate(const CameraConfig& c) {
  GError* e = nullptr;
  if (settings.trigger != AravisTrigger::FreeRun) return Ok{};
  double lo = 0, hi = 0;
  arv_camera_get_frame_rate_bounds(camera, &lo, &hi, &e);
  if (e) return fail("cannot read the camera's frame rate range (" + message(e) + ")");
  if (c.fps < lo || c.fps > hi)
    return fail(num(c.fps) + " frames/s is outside what the camera does at this region, format " +
                "and exposure (" + num(lo) + ".." + num(hi) +
                " frames/s): check camera.fps, or shrink camera.roi");
  arv_camera_set_frame_rate(camera, c.fps, &e);
  const double got = e ? 0.0 : arv_camera_get_frame_rate(camera, &e);
  if (e || std::abs(got - c.fps) > 0.005 * c.fps)
    return fail("the camera did not take " + num(c.fps) + " frames/s" +
                (e ? " (" + message(e) + ")" : " (it runs at " + num(got) + ")") +
                ": check camera.fps (the camera may round it to its own steps)");
  return Ok{};
}

// GigE Vision's packet size (given or negotiated) and inter-packet delay.
Status CameraAravis::Impl::setTransport() {
  GError* e = nullptr;
  if (gv) {
    if (settings.packet_size_bytes > 0) {
      arv_camera_gv_set_packet_size(camera, settings.packet_size_bytes, &e);
      const guint got = e ? 0 : arv_camera_gv_get_packet_size(camera, &e);
      if (e || got != static_cast<guint>(settings.packet_size_bytes))
        return fail("the camera did not take packet size " +
                    std::to_string(settings.packet_size_bytes) + " bytes" +
                    (e ? " (" + message(e) + ")" : " (it reads back " + std::to_string(got) + ")") +
                    ": check camera.packet_size_bytes against the link's MTU (" + kSetupDoc + ")");
    } else {
      const guint got = arv_camera_gv_auto_packet_size(camera, &e);
      if (e)
        spdlog::warn("{}: packet size negotiation failed ({}); keeping {} bytes", label(),
                     message(e), arv_camera_gv_get_packet_size(camera, nullptr));
      else
        spdlog::info("{}: negotiated packet size {} bytes", label(), got);
    }
    if (settings.packet_delay_ns > 0) {
      arv_camera_gv_set_packet_delay(camera, settings.packet_delay_ns, &e);
      if (e)
        return fail("the camera did not take inter-packet delay " +
                    std::to_string(settings.packet_delay_ns) + " ns (" + message(e) +
                    "): check camera.packet_delay_ns");
    }
  } else if (settings.packet_size_bytes > 0 || settings.packet_delay_ns > 0) {
    return fail(
        "packet_size_bytes and packet_delay_ns apply to GigE Vision cameras only: remove them");
  }
  return Ok{};
}

Status CameraAravis::Impl::configure(const CameraConfig& c) {
  std::lock_guard lock(arv_mutex);
  // The profile's own features first, so that e.g. binning is in place
  // before the region is checked against the sensor.
  for (const GenicamFeature& f : settings.features) COLLIDE_RETURN_IF_ERROR(applyFeature(f));
  COLLIDE_RETURN_IF_ERROR(setRegion(c));
  COLLIDE_RETURN_IF_ERROR(setPixelFormat(c));
  COLLIDE_RETURN_IF_ERROR(setExposure(c));
  COLLIDE_RETURN_IF_ERROR(setGain(c));
  COLLIDE_RETURN_IF_ERROR(setFrameRate(c));
  COLLIDE_RETURN_IF_ERROR(setTrigger());
  COLLIDE_RETURN_IF_ERROR(setTransport());
  config = c;
  refreshInfoLocked();
  return Ok{};
}

Status CameraAravis::Impl::start() {
  // A camera lost earlier never gets here: Camera::start() refuses it.
  std::lock_guard lock(arv_mutex);
  GError* e = nullptr;
  payload = arv_camera_get_payload(camera, &e);
  if (e || payload == 0) return fail("cannot read the camera's payload size (" + message(e) + ")");
  stream = arv_camera_create_stream(camera, nullptr, nullptr, &e);
  if (!stream)
    return fail("cannot open the camera's stream (" + message(e) +
                "): check the firewall (GigE streams arrive on a UDP port) and " + kSetupDoc);
  if (ARV_IS_GV_STREAM(stream)) {
    g_object_set(stream, "packet-resend",
                 settings.packet_resend ? ARV_GV_STREAM_PACKET_RESEND_ALWAYS
                                        : ARV_GV_STREAM_PACKET_RESEND_NEVER,
                 nullptr);
    if (settings.packet_timeout_ms > 0)
      g_object_set(stream, "packet-timeout",
                   static_cast<guint>(std::llround(settings.packet_timeout_ms * 1000)), nullptr);
    if (settings.frame_retention_ms > 0)
      g_object_set(stream, "frame-retention",
                   static_cast<guint>(std::llround(settings.frame_retention_ms * 1000)), nullptr);
    if (settings.socket_buffer_bytes > 0)
      g_object_set(stream, "socket-buffer", ARV_GV_STREAM_SOCKET_BUFFER_FIXED, "socket-buffer-size",
                   static_cast<gint>(settings.socket_buffer_bytes), nullptr);
  }
  // The pool: allocated once here, recycled for every frame until stop().
  for (int i = 0; i < settings.buffers; ++i)
    arv_stream_push_buffer(stream, arv_buffer_new_allocate(payload));
  arv_camera_set_acquisition_mode(camera, ARV_ACQUISITION_MODE_CONTINUOUS, &e);
  g_clear_error(&e);  // some cameras have only one mode
  arv_camera_start_acquisition(camera, &e);
  if (e) {
    const std::string why = message(e);
    g_object_unref(stream);
    stream = nullptr;
    return fail("the camera refused to start acquisition (" + why +
                "): is another program streaming from it?");
  }
  {
    std::lock_guard c(counters_mutex);
    counters = {};
    at_arm = {};
  }
  stop = false;
  thread = std::thread(&Impl::run, this);
  return Ok{};
}

Status CameraAravis::Impl::stopStream() {
  stop = true;
  if (thread.joinable()) thread.join();
  std::lock_guard lock(arv_mutex);
  Status result = Ok{};
  if (camera && stream && !lost) {
    GError* e = nullptr;
    arv_camera_stop_acquisition(camera, &e);
    if (e) result = fail("could not stop acquisition (" + message(e) + ")");
  }
  if (stream) {
    refreshStreamCounters();
    // Frees the buffer pool; a lost camera's in the background (its stream
    // channel is closed with requests the dead device never answers).
    if (lost)
      LostObjectReaper::instance().release(stream);
    else
      g_object_unref(stream);
    stream = nullptr;
  }
  return result;
}

void CameraAravis::Impl::refreshStreamCounters() {
  guint64 completed = 0, failures = 0, underruns = 0, resent = 0, missing = 0;
  arv_stream_get_statistics(stream, &completed, &failures, &underruns);
  if (ARV_IS_GV_STREAM(stream))
    arv_gv_stream_get_statistics(ARV_GV_STREAM(stream), &resent, &missing);
  std::lock_guard lock(counters_mutex);
  counters.underruns = underruns;
  counters.resent_packets = resent;
  counters.missing_packets = missing;
}

void CameraAravis::Impl::markLost(const std::string& why) {
  if (lost.exchange(true)) return;
  // The camera's lifecycle refuses every later call at once (lostMessage),
  // and the armed burst ends with the same sentence.
  const std::string what =
      owner
          .markLost(why, "its power and cable, the network link (ping " + device +
                             "), and that no other program took control of it")
          .message;
  spdlog::error("{}; the frames that arrived are kept", what);
  if (auto r = owner.recorder()) r->endOfStream(what);
}

void CameraAravis::Impl::checkStall(std::int64_t silent_ns, bool frames_expected) {
  guint32 value = 0;
  GError* e = nullptr;
  bool answers = false;
  {
    std::lock_guard lock(arv_mutex);
    if (!camera) return;
    answers = arv_device_read_register(arv_camera_get_device(camera), 0, &value, &e);
  }
  const std::string silent = num(std::round(silent_ns / 1e6)) + " ms";
  if (!answers) {
    markLost("no frame for " + silent + " and it no longer answers (" + message(e) + ")");
    return;
  }
  g_clear_error(&e);
  if (!frames_expected) return;  // line trigger: simply no pulses
  const std::string what = "the stream stalled: no frame for " + silent +
                           " although the camera answers; check the packet size against the "
                           "link's MTU, the firewall (UDP), rp_filter and socket buffers (" +
                           kSetupDoc + ")";
  spdlog::warn("{}: {}", label(), what);
  if (auto r = owner.recorder()) r->endOfStream(what);
}

// Start of exposure on CLOCK_MONOTONIC from a buffer's device and host
// timestamps: the device clock mapped onto the host's (ClockMap), else the
// last frame's time plus whole periods, else the arrival; less the latency
// (the exposure, or timestamp_latency_us).
struct CameraAravis::Impl::StreamClock {
  std::int64_t period, latency;
  ClockMap clock_map;
  std::int64_t last_ts = 0;
  std::uint64_t last_ts_counter = 0;

  std::int64_t exposureStart(ArvBuffer* b, std::uint64_t seq, std::int64_t now) {
    const auto device_ts = static_cast<std::int64_t>(arv_buffer_get_timestamp(b));
    const auto system_ts = static_cast<std::int64_t>(arv_buffer_get_system_timestamp(b));
    const std::int64_t arrival = system_ts > 0 ? system_ts - realtimeMinusMonotonicNs() : now;
    std::int64_t ts = 0;
    if (device_ts > 0) {
      clock_map.add(arrival - device_ts);
      ts = device_ts + clock_map.offset() - latency;
    } else if (last_ts != 0) {
      ts = last_ts + static_cast<std::int64_t>(seq - last_ts_counter) * period;
    } else {
      ts = arrival - latency;
    }
    last_ts = ts;
    last_ts_counter = seq;
    return ts;
  }
};

// The camera's frame ids unwrapped into a running sequence number.
struct CameraAravis::Impl::Sequence {
  std::optional<std::uint64_t> previous_raw;
  std::uint64_t counter = 0;

  // The frame's sequence number and how many were skipped before it; nullopt
  // for a duplicate or late frame (the recorder could not place it anyway).
  std::optional<std::uint64_t> place(std::uint64_t raw, std::uint64_t& skipped) {
    std::optional<std::uint64_t> seq =
        previous_raw ? unwrapFrameId(*previous_raw, counter, raw) : std::optional(raw);
    if (!seq) return std::nullopt;
    skipped = previous_raw ? *seq - counter - 1 : 0;
    previous_raw = raw;
    counter = *seq;
    return seq;
  }
};

// Fires the software trigger when due; returns how long the stream may be
// waited on before the next is due, ns.
std::int64_t CameraAravis::Impl::softwareTrigger(std::int64_t now, std::int64_t period,
                                                 std::int64_t& next_trigger) {
  if (now >= next_trigger) {
    GError* e = nullptr;
    {
      std::lock_guard lock(arv_mutex);
      arv_camera_software_trigger(camera, &e);
    }
    if (e) spdlog::warn("{}: software trigger failed ({})", label(), message(e));
    next_trigger += period;
    if (next_trigger < now) next_trigger = now + period;  // fell behind: resynchronise
  }
  return next_trigger - now;
}

// Good: a whole image of the configured size and format (w, h set); else
// Incomplete (packets missing, timed out, aborted) or Failed.
vision::FrameStatus CameraAravis::Impl::frameStatus(ArvBuffer* b, int& w, int& h) const {
  const ArvBufferStatus status = arv_buffer_get_status(b);
  bool good = status == ARV_BUFFER_STATUS_SUCCESS &&
              arv_buffer_get_payload_type(b) == ARV_BUFFER_PAYLOAD_TYPE_IMAGE;
  if (good) {
    w = arv_buffer_get_image_width(b);
    h = arv_buffer_get_image_height(b);
    good = w == config.width && h == config.height &&
           arv_buffer_get_image_pixel_format(b) == toArv(config.format);
  }
  if (good) return vision::FrameStatus::Good;
  return status == ARV_BUFFER_STATUS_MISSING_PACKETS || status == ARV_BUFFER_STATUS_TIMEOUT ||
                 status == ARV_BUFFER_STATUS_ABORTED
             ? vision::FrameStatus::Incomplete
             : vision::FrameStatus::Failed;
}

// Copies a good buffer's w x h image into `frame`; false (frame marked
// Failed) when the buffer holds less than that.
bool CameraAravis::Impl::copyImage(ArvBuffer* b, int w, int h, vision::Frame& frame) const {
  std::size_t size = 0;
  const auto* data = static_cast<const std::uint8_t*>(arv_buffer_get_image_data(b, &size));
  const std::size_t row = static_cast<std::size_t>(w) * bytesPerPixel(config.format);
  // Aravis' in-process fake leaves the received size at 0 when a custom fill
  // pattern drew the frame; its buffers are ours, `payload` bytes.
  if (fake && size == 0 && arv_buffer_get_status(b) == ARV_BUFFER_STATUS_SUCCESS) size = payload;
  if (!data || size < row * h) {
    frame.status = vision::FrameStatus::Failed;
    return false;
  }
  frame.image.create(h, w, vision::cvType(config.format));
  if (frame.image.isContinuous())
    std::memcpy(frame.image.data, data, row * h);
  else
    for (int r = 0; r < h; ++r) std::memcpy(frame.image.ptr(r), data + r * row, row);
  return true;
}

void CameraAravis::Impl::countFrame(std::uint64_t seq, std::uint64_t skipped, bool good, int w,
                                    int h) {
  std::lock_guard lock(counters_mutex);
  if (counters.frames_good + counters.frames_failed == 0) counters.first_sequence = seq;
  counters.last_sequence = seq;
  counters.frames_missing += skipped;
  if (good) {
    ++counters.frames_good;
    counters.bytes_good += static_cast<std::uint64_t>(w) * h * bytesPerPixel(config.format);
  } else {
    ++counters.frames_failed;
  }
}

void CameraAravis::Impl::run() {
  const std::int64_t period = config.framePeriodNs();
  StreamClock clock{period,
                    std::llround((settings.timestamp_latency_us >= 0 ? settings.timestamp_latency_us
                                                                     : config.exposure_us) *
                                 1e3)};
  const std::int64_t stall = settings.stall_timeout_ms > 0
                                 ? std::llround(settings.stall_timeout_ms * 1e6)
                                 : std::max<std::int64_t>(1'000'000'000, 20 * period);
  // With a hardware line the camera only sends frames when pulsed: silence is
  // then only checked for a lost camera.
  const bool frames_expected = settings.trigger != AravisTrigger::Line;
  const bool software = settings.trigger == AravisTrigger::Software;

  Sequence sequence;
  std::int64_t last_frame_at = monotonicNowNs();
  std::int64_t next_trigger = monotonicNowNs();
  std::shared_ptr<BurstRecorder> finished;  // complete or ended: wants no more frames

  while (!stop) {
    std::int64_t now = monotonicNowNs();
    std::int64_t wait_ns = 20'000'000;
    if (software && !lost)
      wait_ns = std::clamp<std::int64_t>(softwareTrigger(now, period, next_trigger), 0, wait_ns);
    ArvBuffer* b = arv_stream_timeout_pop_buffer(
        stream, static_cast<guint64>(std::max<std::int64_t>(wait_ns / 1000, 1)));
    refreshStreamCounters();
    now = monotonicNowNs();
    if (!b) {
      if (!lost && now - last_frame_at > stall) {
        checkStall(now - last_frame_at, frames_expected);
        last_frame_at = now;
      }
      continue;
    }
    last_frame_at = now;

    const ArvBufferStatus status = arv_buffer_get_status(b);
    const std::uint64_t raw = arv_buffer_get_frame_id(b);
    if (gv && raw == 0) {
      // GigE Vision never uses block id 0: Aravis gives it to a frame it
      // could not identify (e.g. one that timed out with its leader lost).
      // It cannot be placed in the sequence: count it, nothing more.
      arv_stream_push_buffer(stream, b);
      std::lock_guard lock(counters_mutex);
      ++counters.frames_failed;
      continue;
    }
    std::uint64_t skipped = 0;
    const std::optional<std::uint64_t> seq = sequence.place(raw, skipped);
    if (!seq) {
      arv_stream_push_buffer(stream, b);
      continue;
    }

    vision::Frame frame;
    frame.timestamp_ns = clock.exposureStart(b, *seq, now);
    int w = 0, h = 0;
    frame.status = frameStatus(b, w, h);
    bool good = frame.status == vision::FrameStatus::Good;
    // Every frame goes into the armed ring until the burst is complete: the
    // ring keeps the newest, and which of them fall before the trigger is
    // decided by frame ids, not by time (a stalling camera or irregular line
    // pulses expose at no steady rate).
    std::shared_ptr<BurstRecorder> rec = owner.recorder();
    if (rec == finished) rec.reset();
    const bool live = owner.liveView();
    if (good && (rec || live)) good = copyImage(b, w, h, frame);
    arv_stream_push_buffer(stream, b);  // back to the pool before the slower bookkeeping
    countFrame(*seq, skipped, good, w, h);
    if (!good && status != ARV_BUFFER_STATUS_SUCCESS)
      spdlog::debug("{}: frame {} failed in transport (Aravis buffer status {})", label(), *seq,
                    static_cast<int>(status));
    // A failed frame is handed on without an image, marked, so the burst
    // counts it where it belongs; vision never sees it as good.
    if (live && good) owner.publishFrame(frame);  // shares the image; nobody writes it again
    if (rec && !rec->push(*seq, std::move(frame))) finished = rec;
  }
}

// ------------------------------------------------------------ CameraAravis ---

CameraAravis::CameraAravis(std::string device, CameraAravisSettings settings)
    : Camera("camera \"" + device + "\""),
      impl_(std::make_unique<Impl>(*this, std::move(device), std::move(settings))) {
  std::lock_guard lock(impl_->info_mutex);
  impl_->info.backend = "aravis";
  impl_->info.device = impl_->device;
}

CameraAravis::~CameraAravis() {
  (void)impl_->stopStream();
  impl_->close();
}

CameraInfo CameraAravis::info() const {
  std::lock_guard lock(impl_->info_mutex);
  return impl_->info;
}

AravisCounters CameraAravis::counters() const {
  std::lock_guard lock(impl_->counters_mutex);
  return impl_->counters;
}

Result<std::string> CameraAravis::feature(const std::string& name) const {
  std::lock_guard lock(impl_->arv_mutex);
  if (!impl_->camera) return fail(label() + ": feature() refused: open() the camera first");
  ArvDevice* dev = arv_camera_get_device(impl_->camera);
  ArvGcNode* node = arv_device_get_feature(dev, name.c_str());
  if (!node) return fail(label() + ": the camera has no feature \"" + name + "\"");
  GError* e = nullptr;
  std::string value;
  if (ARV_IS_GC_ENUMERATION(node) || ARV_IS_GC_STRING(node)) {
    const char* v = arv_device_get_string_feature_value(dev, name.c_str(), &e);
    value = v ? v : "";
  } else if (ARV_IS_GC_BOOLEAN(node)) {
    value = arv_device_get_boolean_feature_value(dev, name.c_str(), &e) ? "true" : "false";
  } else if (ARV_IS_GC_FLOAT(node)) {
    value = num(arv_device_get_float_feature_value(dev, name.c_str(), &e));
  } else if (ARV_IS_GC_INTEGER(node)) {
    value = std::to_string(arv_device_get_integer_feature_value(dev, name.c_str(), &e));
  } else {
    return fail(label() + ": feature \"" + name +
                "\" has no value to read (a command or category)");
  }
  if (e) return fail(label() + ": cannot read feature \"" + name + "\" (" + message(e) + ")");
  return value;
}

Result<std::string> CameraAravis::genicamXml() const {
  std::lock_guard lock(impl_->arv_mutex);
  if (!impl_->camera) return fail(label() + ": genicamXml() refused: open() the camera first");
  std::size_t size = 0;
  const char* xml = arv_device_get_genicam_xml(arv_camera_get_device(impl_->camera), &size);
  if (!xml) return fail(label() + ": the camera gave no GenICam description");
  return std::string(xml, size);
}

Status CameraAravis::setFakeFill(std::function<void(const FakeFrameRequest&)> fill) {
  std::lock_guard lock(impl_->arv_mutex);
  if (!impl_->camera) return fail(label() + ": setFakeFill() refused: open() the camera first");
  if (!impl_->fake)
    return fail(label() +
                ": setFakeFill() works only with Aravis' in-process fake camera (\"Fake_1\")");
  const bool any = static_cast<bool>(fill);
  {
    std::lock_guard f(impl_->fill_mutex);
    impl_->fill = std::move(fill);
  }
  if (any)
    arv_fake_camera_set_fill_pattern(impl_->fake, &Impl::fillTrampoline, impl_.get());
  else
    arv_fake_camera_set_fill_pattern(impl_->fake, nullptr, nullptr);
  return Ok{};
}

Status CameraAravis::onOpen() {
  return impl_->open();
}

Status CameraAravis::lostIfUnanswered(const std::function<Status()>& call) {
  t_unanswered = false;
  Status s = call();
  if (s || !t_unanswered) return s;
  // A control request went unanswered (Aravis' 5 x 500 ms): the camera is
  // gone, and asking it again would only wait as long once more.
  impl_->markLost(s.error().message);
  if (std::optional<DeviceLoss> l = loss()) return fail(lostMessage(*l));
  return s;
}

Status CameraAravis::onConfigure(const CameraConfig& config) {
  return lostIfUnanswered([&] { return impl_->configure(config); });
}

Status CameraAravis::onStart() {
  return lostIfUnanswered([&] { return impl_->start(); });
}

Status CameraAravis::onStop() {
  return impl_->stopStream();
}

Status CameraAravis::onClose() {
  impl_->close();
  return Ok{};
}

void CameraAravis::onArm() {
  std::lock_guard lock(impl_->counters_mutex);
  impl_->at_arm = impl_->counters;
}

void CameraAravis::onTakeBurst(vision::Burst& burst) {
  AravisCounters now, then;
  {
    std::lock_guard lock(impl_->counters_mutex);
    now = impl_->counters;
    then = impl_->at_arm;
  }
  vision::BurstStats& st = burst.stats;
  st.underruns = now.underruns - then.underruns;
  st.missing_packets = now.missing_packets - then.missing_packets;
  st.resent_packets = now.resent_packets - then.resent_packets;
  if (st.failed > 0 || st.dropped > 0 || st.underruns > 0) {
    if (!burst.note.empty()) burst.note += "; ";
    burst.note += std::to_string(st.failed) + " frames failed and " + std::to_string(st.dropped) +
                  " were lost in transport (" + std::to_string(st.missing_packets) +
                  " packets missing, " + std::to_string(st.resent_packets) + " resent, " +
                  std::to_string(st.underruns) +
                  " frames with no free buffer): check the link, packet size, socket buffers "
                  "and camera.buffers (" +
                  kSetupDoc + ")";
  }
}

// ----------------------------------------------------------------- factory ---

namespace {

Result<std::unique_ptr<Camera>> makeAravis(BackendContext& ctx) {
  SettingsReader r = ctx.device.backendSettings();
  COLLIDE_ASSIGN_OR_RETURN(CameraAravisSettings settings, CameraAravisSettings::read(r));
  if (ctx.device.device == ctx.device.backend)
    return r.invalid("device",
                     "name the camera: its device id, serial number or IP address "
                     "(e.g. device = \"192.168.10.20\"; arv-tool-0.8 lists them)");
  return std::unique_ptr<Camera>(
      std::make_unique<CameraAravis>(ctx.device.device, std::move(settings)));
}

const bool registered = BackendRegistry<Camera>::instance().add("aravis", &makeAravis);

}  // namespace

}  // namespace collide::hw
