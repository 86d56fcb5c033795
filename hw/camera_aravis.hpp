#pragma once
// CameraAravis ("aravis"): a GigE Vision or USB3 Vision camera through Aravis
// 0.8. Opens the camera by device id, serial number, MAC or IP address (what
// Aravis' arv_camera_new() accepts; "Fake_1" is Aravis' in-process fake
// camera); sets the region of interest, pixel format (Mono8, Mono12 in 16-bit
// words, Mono16), exposure, gain, frame rate, trigger mode (free run, software
// triggers paced by the host at the frame rate, or a hardware line), GigE
// packet size and inter-packet delay, and any other GenICam feature the
// profile names in [camera.features].
//
// While running, Aravis' stream thread fills a pool of buffers allocated once
// at start(); this backend's own acquisition thread takes each filled buffer,
// copies a good frame into the armed pre-trigger ring (burst_recorder.hpp),
// counts a failed or incomplete one (marked FrameStatus::Failed/Incomplete,
// with no image, so vision never sees it as good) and gives the buffer back.
// Frame numbering comes from the camera's block ids (16-bit GigE Vision ids
// wrap 65535 -> 1 and are unwrapped), so frames lost in transport show as gaps.
// Timestamps: the camera's clock, mapped to CLOCK_MONOTONIC through the
// fastest frame's arrival (see docs/camera-aravis.md).
//
// With the live view on (Camera::setLiveView) every good frame is also
// published, armed or not.
//
// A camera lost mid-burst (the control link's heartbeat fails, or the
// stream falls silent and the camera no longer answers) ends the burst: it keeps
// the frames that arrived, is marked incomplete, and the camera is marked
// lost (Camera::markLost): the burst's note and every later call (arm,
// trigger, configure, start) carry lostMessage(), refused at once; the
// sequencer fails the shot with that reason, stores the frames and refuses
// the next shot. A control request of configure() or start() that goes
// unanswered after Aravis' retries loses it too. Closing and opening the
// camera again clears it.
//
// Aravis and GLib types stay in camera_aravis.cpp (pimpl).
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hw/camera.hpp"
#include "hw/settings.hpp"

namespace collide::hw {

enum class AravisTrigger {
  FreeRun,   ///< the camera exposes at its own frame rate (AcquisitionFrameRate)
  Software,  ///< TriggerSource = Software; the backend sends TriggerSoftware at the frame rate
  Line,      ///< TriggerSource = a hardware line (trigger_line), pulses from outside
};

/// One GenICam feature from [camera.features], applied in file order.
struct GenicamFeature {
  std::string name;    ///< GenICam feature name, e.g. "BinningHorizontal"
  SettingValue value;  ///< bool, integer, float or string (enumeration entries by name)
  std::string where;   ///< "<file>:<line>: camera.features.<name>" for messages
};

struct CameraAravisSettings {
  AravisTrigger trigger = AravisTrigger::FreeRun;
  std::string trigger_line = "Line0";             ///< TriggerSource for AravisTrigger::Line
  std::string trigger_activation = "RisingEdge";  ///< TriggerActivation for AravisTrigger::Line
  int packet_size_bytes = 0;         ///< GigE stream packet size; 0: let Aravis negotiate it
  std::int64_t packet_delay_ns = 0;  ///< GigE inter-packet delay (GevSCPD), ns
  int buffers = 64;                  ///< preallocated stream buffers
  int socket_buffer_bytes = 0;       ///< GigE receive socket buffer; 0: Aravis' automatic size
  bool packet_resend = true;         ///< GigE: ask the camera to resend lost packets
  double packet_timeout_ms = 0.0;    ///< GigE: wait before asking a resend; 0: Aravis default
  double frame_retention_ms = 0.0;   ///< GigE: give up on an incomplete frame; 0: Aravis default
  /// Start of exposure to arrival of the fastest frame, us; < 0: the exposure time.
  double timestamp_latency_us = -1.0;
  /// A stream silent this long is checked: a camera that no longer answers is
  /// lost; in free run / software trigger one that answers has a stalled
  /// stream (with a hardware line it simply had no pulses). 0: max(1 s, 20
  /// frame periods).
  double stall_timeout_ms = 0.0;
  std::vector<GenicamFeature> features;

  /// From the [camera] table (trigger, trigger_line, trigger_activation,
  /// packet_size_bytes, packet_delay_ns, buffers, socket_buffer_bytes,
  /// packet_resend, packet_timeout_ms, frame_retention_ms,
  /// timestamp_latency_us, stall_timeout_ms, and [camera.features]); refuses
  /// unknown keys.
  static Result<CameraAravisSettings> read(SettingsReader& r);
};

/// Running totals since start(), for live view and benchmarks.
struct AravisCounters {
  std::uint64_t frames_good = 0;      ///< complete frames delivered by the stream
  std::uint64_t frames_failed = 0;    ///< frames the stream marked failed or incomplete
  std::uint64_t frames_missing = 0;   ///< frame ids skipped (never seen at all)
  std::uint64_t bytes_good = 0;       ///< image bytes in the good frames
  std::uint64_t underruns = 0;        ///< Aravis: no free buffer when a frame arrived
  std::uint64_t missing_packets = 0;  ///< Aravis (GigE): packets never received
  std::uint64_t resent_packets = 0;   ///< Aravis (GigE): packets received after a resend request
  std::uint64_t first_sequence = 0;   ///< unwrapped frame id of the first frame seen
  std::uint64_t last_sequence = 0;    ///< unwrapped frame id of the latest frame seen
};

/// What a fill callback of Aravis' in-process fake camera is asked to draw.
struct FakeFrameRequest {
  std::uint64_t frame_id = 0;  ///< the fake camera's frame id (16-bit, wraps 65535 -> 1)
  /// The frame's timestamp (start of exposure) as the fake stamped it, on
  /// CLOCK_MONOTONIC (the fake uses the host's clock).
  std::int64_t exposure_start_ns = 0;
  int width = 0, height = 0;
  vision::PixelFormat format = vision::PixelFormat::Mono8;
  double exposure_us = 0.0;
  void* data = nullptr;  ///< width * height pixels, 1 or 2 bytes each (little-endian)
};

class CameraAravis final : public Camera {
 public:
  /// `device`: what arv_camera_new() opens (device id, serial, MAC, IP
  /// address; "Fake_1" enables Aravis' in-process fake interface).
  CameraAravis(std::string device, CameraAravisSettings settings);
  ~CameraAravis() override;

  CameraInfo info() const override;
  /// Totals since the last start(). Any thread.
  AravisCounters counters() const;

  /// The current value of GenICam feature `name` as text ("2", "Off",
  /// "true", "199.5"). Errors: not open, no such feature. Control thread.
  Result<std::string> feature(const std::string& name) const;
  /// The camera's GenICam description (XML). Errors: not open. Control thread.
  Result<std::string> genicamXml() const;

  /// Only for Aravis' in-process fake camera ("Fake_N"), open: `fill` draws
  /// each frame the fake camera streams (on the fake's stream thread), in
  /// place of its diagonal ramp; an empty function restores the ramp.
  /// Errors: not open, or not the in-process fake. Control thread.
  Status setFakeFill(std::function<void(const FakeFrameRequest&)> fill);

  /// 16-bit GigE Vision block ids wrap from 65535 to 1 (0 is never used):
  /// the running frame counter after `raw`, given the previous raw id and the
  /// previous counter; nullopt for an id that is not newer (a duplicate or a
  /// late frame). Ids above 65535 (GigE Vision 2 / USB3 Vision) never wrap.
  static std::optional<std::uint64_t> unwrapFrameId(std::uint64_t previous_raw,
                                                    std::uint64_t previous_counter,
                                                    std::uint64_t raw);

 protected:
  Status onOpen() override;
  Status onConfigure(const CameraConfig& config) override;
  Status onStart() override;
  Status onStop() override;
  Status onClose() override;
  void onArm() override;
  void onTakeBurst(vision::Burst& burst) override;

 private:
  // Runs a control-thread call; if one of its requests went unanswered,
  // marks the camera lost and returns lostMessage().
  Status lostIfUnanswered(const std::function<Status()>& call);

  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace collide::hw
