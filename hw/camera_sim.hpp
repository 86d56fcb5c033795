#pragma once
// CameraSim ("sim"): renders what the rig's camera would see of the simulated
// world (sim_world.hpp) — both spheres with their dots, at the configured
// region, frame rate, exposure (motion blur), bit depth, gain and sensor
// noise — through vision::Renderer. Like a real camera it streams on its own
// acquisition thread into the armed pre-trigger ring. With realtime = false
// it renders a burst as fast as it can once the valves have fired (the physics
// is then known), so a shot takes less wall time than real time. Fault knobs:
// lose every Nth frame, stop streaming after N post-trigger frames, or go
// silent after N bursts (silent_after_bursts, counted across every camera of
// that label in the process, see sim_silence.hpp): a silent camera delivers
// no frame at all, and the sequencer then marks it lost.
// An optional [camera.imaging] table makes the pictures realistic (lamps,
// perspective lens, sensor; docs/imaging.md).
//
// Runs on CLOCK_MONOTONIC (its frame timestamps are compared with the valves'
// times), so its rig must use the monotonic clock.
#include <array>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "hw/camera.hpp"
#include "hw/settings.hpp"
#include "hw/sim_silence.hpp"
#include "hw/sim_world.hpp"
#include "vision/render.hpp"
#include "vision/render_wall.hpp"

namespace collide::hw {

/// [camera.imaging]: how the simulated camera images the scene (lamps, lens,
/// sensor; vision/imaging.hpp, docs/imaging.md). The lens' pose and pixel
/// mapping follow from [geometry] and the region at configure time.
struct SimImagingSettings {
  vision::Imaging imaging;  ///< lighting, sensor (gain set at configure) and samples
  bool perspective = false;
  double focal_length_mm = 0;
  double pixel_pitch_um = 0;
  double working_distance_m = 0;                 ///< optical centre to the collision plane z = 0
  std::optional<Eigen::Vector2d> principal_px;   ///< none: the region's centre
  std::array<double, 4> distortion{0, 0, 0, 0};  ///< k1, k2, p1, p2

  /// Metres per pixel at the collision plane (perspective).
  double planePixelSizeM() const {
    return pixel_pitch_um * 1e-6 * working_distance_m / (focal_length_mm * 1e-3);
  }
  /// The lens for an image of `width` x `height` whose world origin appears at
  /// `origin_px` (ideal pixel) with `pixel_size_m` (orthographic).
  vision::Optics optics(int width, int height, Eigen::Vector2d origin_px,
                        double pixel_size_m) const;
  /// Reads the "imaging.*" keys of the [camera] table.
  static Result<SimImagingSettings> read(SettingsReader& r);
};

struct CameraSimSettings {
  int sensor_width = 640;
  int sensor_height = 480;
  bool realtime = false;       ///< deliver frames at the frame rate rather than as fast as possible
  double noise_grey = 0.0;     ///< sensor noise, std dev in grey levels of the format
  int drop_every = 0;          ///< fault: lose every Nth frame in transport (0: never)
  int stop_after_frames = -1;  ///< fault: stop after N post-trigger frames (-1: never)
  /// fault: deliver N bursts (in this process), then no frame at all (-1: never)
  int silent_after_bursts = -1;
  double max_fps = 100000.0;
  double max_gain_db = 24.0;
  /// [camera.imaging]; none: the evenly lit orthographic picture.
  std::optional<SimImagingSettings> imaging;

  /// From the [camera] table (sensor_px, realtime, noise_grey, drop_every,
  /// stop_after_frames, silent_after_bursts, and [camera.imaging]); refuses
  /// unknown keys.
  static Result<CameraSimSettings> read(SettingsReader& r);
};

/// The lens a profile's simulated camera films through, as the analysis'
/// camera model: its [camera.imaging] perspective lens placed as the camera
/// places it (region size, geometry.origin_px). None: no simulated camera, or
/// an orthographic one (pixels are geometry.pixel_size_m apart everywhere).
/// Errors: the camera's settings do not parse.
Result<std::optional<PinholeCamera>> simulatedLens(const RigProfile& profile);

/// What a profile's simulated camera renders with (camera.roi, format,
/// exposure, gain, [camera.imaging] with its lens placed by [geometry]), e.g.
/// to draw calibration targets through its optics. Errors: not a simulated
/// camera, or its settings do not parse.
Result<vision::RenderSettings> simulatedRenderSettings(const RigProfile& profile);
/// Where a wall rig's plate face appears in the image: the profile's [wall]
/// on the collision plane z = 0, through the simulated camera's perspective
/// lens when it has one, else the orthographic geometry; none without a wall
/// or when the face is parallel to the image.
std::optional<vision::WallLine> wallInImage(const RigProfile& profile);
/// How the lens bends that face's image away from the straight `line`
/// (wallInImage's): empty without a lens or with an undistorted one. A
/// straight plate edge is a straight line only through an ideal pinhole.
vision::WallBend wallBendInImage(const RigProfile& profile, const vision::WallLine& line);

class CameraSim final : public Camera {
 public:
  CameraSim(std::shared_ptr<SimWorld> world, CameraSimSettings settings,
            std::string device = "sim");
  ~CameraSim() override;

  CameraInfo info() const override;
  std::shared_ptr<const TruthSource> groundTruth() const override { return world_; }

  /// The spheres in view at `t_ns` (CLOCK_MONOTONIC, mid-exposure), in image
  /// pixels of the configured region. Any thread.
  std::vector<vision::SphereView> sceneAt(const SimLaunch& launch, std::int64_t t_ns) const;
  /// The frame this camera delivers for an exposure starting at
  /// `exposure_start_ns` (CLOCK_MONOTONIC), frame counter `sequence` (seeds
  /// the noise): the current launch's scene, rendered with the configured
  /// region, format, exposure, gain and noise. Lets another backend show the
  /// simulated world (e.g. Aravis' fake camera in the peer tests). Configured;
  /// any thread.
  vision::Frame renderFrame(std::int64_t exposure_start_ns, std::uint64_t sequence) const;
  /// The same with the noise seeded by `noise_index` and the lamps' flicker
  /// phase counted from `time_origin_ns` (CLOCK_MONOTONIC).
  vision::Frame renderFrame(std::int64_t exposure_start_ns, std::uint64_t noise_index,
                            std::int64_t time_origin_ns) const;

 protected:
  Status onOpen() override { return Ok{}; }
  Status onConfigure(const CameraConfig& config) override;
  Status onStart() override;
  Status onStop() override;
  Status onClose() override { return Ok{}; }
  void onArm() override;
  void onTrigger(std::int64_t at_ns) override;
  void onLiveView(bool) override { wake(); }

 private:
  // The acquisition thread and what wakes it (arm, trigger, a launch, stop).
  struct Signal {
    std::mutex mutex;
    std::condition_variable cv;
    bool stop = false;
    std::uint64_t generation = 0;  // bumped on every wake-up reason
  };
  void run();
  void wake();
  // The acquisition thread's stages (camera_sim.cpp): the frame grid and the
  // burst it records; follow a new arming; record the armed burst's next
  // frame (nullopt: one handled or skipped, look again; else sleep until the
  // time returned, int64 max: until woken); a live-view frame when idle
  // (returns when the next is due).
  struct FrameGrid;
  struct BurstState;
  void followArming(FrameGrid& grid, BurstState& burst);
  std::optional<std::int64_t> recordStep(FrameGrid& grid, BurstState& burst);
  std::int64_t previewStep(FrameGrid& grid, std::int64_t& next_preview_ns);

  std::shared_ptr<SimWorld> world_;
  CameraSimSettings settings_;
  std::string device_;
  CameraConfig config_;  // a copy for the acquisition thread, set before it starts
  std::optional<vision::Renderer> renderer_;
  double wall_thickness_px_ = 40.0;  // the plate's band in the image
  std::shared_ptr<Signal> signal_ = std::make_shared<Signal>();
  std::shared_ptr<SimSilence> silence_;  ///< silent_after_bursts >= 0 only
  std::thread thread_;
};

}  // namespace collide::hw
