// A simulated collision through the real Aravis stream code: the rig is the
// simulated one (regulator, valves, world), but its camera is CameraAravis on
// Aravis' in-process fake camera, whose every frame is drawn by the simulated
// camera's renderer (CameraSim::renderFrame) through the fake's fill-pattern
// callback. The sequencer fires a shot; the burst that comes back through
// Aravis' stream must hold exactly the frames the simulator drew, in order,
// stamped at the instants they show, with the collision inside it.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <mutex>
#include <optional>

#include "analysis/flight.hpp"
#include "analysis/walton.hpp"
#include "aravis_profile.hpp"
#include "hw/camera_aravis.hpp"
#include "hw/camera_sim.hpp"
#include "hw/clock.hpp"
#include "hw/pressure_regulator_sim.hpp"
#include "hw/sequencer.hpp"
#include "hw/sim_world.hpp"
#include "hw/valve_bank_sim.hpp"
#include "vision/shot_analysis.hpp"

using namespace collide;
using namespace collide::hw;
using namespace collide::hw::testing;
using collide::vision::Burst;

namespace {

// What the fake camera was given to send, by its frame id.
struct Drawn {
  struct Frame {
    std::uint64_t fid;         // the fake's frame id (16 bits: wraps 65535 -> 1)
    std::int64_t drawn_at_ns;  // the exposure start the scene was drawn for
    cv::Mat image;
  };
  std::mutex mutex;
  std::deque<Frame> frames;  // oldest first
};

struct AravisSimRig {
  Rig rig;
  std::shared_ptr<SimWorld> world;
  std::unique_ptr<CameraSim> renderer;  // the simulated camera, used only to draw
  std::shared_ptr<Drawn> drawn = std::make_shared<Drawn>();
};

// sim.toml with the camera on Aravis' fake: 320 x 240 Mono8 at 1000 frames/s,
// half sim.toml's resolution over the same field of view (2.54 cm spheres
// ~60 px across), so the fake's stream thread can render every frame in real
// time, motion blur included, even on a loaded machine.
std::string profileText() {
  std::string text = aravisProfileText({"backend = \"aravis\"", "device = \"Fake_1\"",
                                        "roi = [0, 0, 320, 240]", "format = \"Mono8\"",
                                        "fps = 1000.0", "exposure_us = 100.0", "gain_db = 0.0",
                                        // The fake stamps a frame as it fills it.
                                        "timestamp_latency_us = 0"});
  text = withKey(text, "geometry", "pixel_size_m", "4.2334e-4");
  text = withKey(text, "geometry", "origin_px", "[159.5, 119.5]");
  // The right tube 10 mm higher: an oblique impact (about 23 degrees off
  // head-on), so the tangential restitution beta is measurable.
  return withKey(text, "launcher", "exit_m", "[0.085, 0.016, 0.0]", 2);
}

AravisSimRig makeAravisSimRig() {
  AravisSimRig a;
  auto profile = parseRigProfile(profileText(), "aravis-sim.toml");
  if (!profile) throw std::runtime_error(profile.error().message);
  a.rig.profile = *profile;
  a.rig.clock = monotonicClock();
  a.world = *SimWorld::create(a.rig.profile, a.rig.clock);
  RegulatorSimSettings rs;
  rs.noise_kPa = 0.05;
  a.rig.regulator = std::make_unique<PressureRegulatorSim>(a.world, rs, "sim-regulator");
  a.rig.valves =
      std::make_unique<ValveBankSim>(a.world, a.rig.clock, ValveSimSettings{}, "sim-valves");

  CameraSimSettings cs;
  cs.noise_grey = 1.5;  // also makes every frame unique, so matching is unambiguous
  a.renderer = std::make_unique<CameraSim>(a.world, cs, "renderer");
  if (!a.renderer->open() || !a.renderer->configure(a.rig.profile.camera_config))
    throw std::runtime_error("the simulated camera refused the profile's settings");

  SettingsReader r = a.rig.profile.camera.backendSettings();
  auto settings = CameraAravisSettings::read(r);
  if (!settings) throw std::runtime_error(settings.error().message);
  auto cam = std::make_unique<CameraAravis>("Fake_1", *settings);
  if (auto s = cam->open(); !s) throw std::runtime_error(s.error().message);
  const CameraSim* sim = a.renderer.get();
  const Status filled = cam->setFakeFill([sim, drawn = a.drawn](const FakeFrameRequest& q) {
    collide::vision::Frame f = sim->renderFrame(q.exposure_start_ns, q.frame_id);
    std::memcpy(q.data, f.image.data, f.image.total() * f.image.elemSize());
    std::lock_guard lock(drawn->mutex);
    drawn->frames.push_back({q.frame_id, q.exposure_start_ns, f.image});
    // Keep the newest few hundred (the burst is taken right after its last frame).
    if (drawn->frames.size() > 300) drawn->frames.pop_front();
  });
  if (!filled) throw std::runtime_error(filled.error().message);
  a.rig.camera = std::move(cam);
  return a;
}

}  // namespace

TEST(AravisSimCollision, TheShotComesThroughAravisAsTheSimulatorDrewIt) {
  AravisSimRig a = makeAravisSimRig();
  Sequencer sequencer(a.rig);
  const Shot shot = sequencer.fire(ShotRequest::atSpeeds(2.0, 2.0));
  // The camera stops; nothing is drawn after this.
  (void)shutDown(a.rig);
  ASSERT_EQ(shot.status, ShotStatus::Ok) << shot.failure_reason;
  const Burst& b = shot.burst;
  const int pre = a.rig.profile.burst.pre_trigger_frames;
  const int post = a.rig.profile.burst.post_trigger_frames;
  ASSERT_TRUE(b.complete) << b.note;
  // Every post-trigger frame, none lost. The fake's stream thread is
  // software-timed: on a loaded machine it skips a frame slot now and then
  // (its ids stay consecutive), so between arming and the trigger it may
  // expose a few frames fewer than the sequencer planned for; the burst then
  // says so, and starts later.
  ASSERT_GE(b.frames.size(), static_cast<std::size_t>(post)) << b.note;
  EXPECT_EQ(b.frames.back().id, post - 1);
  EXPECT_EQ(b.frames.front().id, post - static_cast<std::int64_t>(b.frames.size()));
  if (b.frames.size() < static_cast<std::size_t>(pre + post)) {
    EXPECT_THAT(b.note, ::testing::HasSubstr("pre-trigger frames"));
  }
  EXPECT_EQ(b.stats.failed, 0u);
  EXPECT_EQ(b.stats.dropped, 0u);

  std::lock_guard lock(a.drawn->mutex);
  const std::int64_t period = a.rig.profile.camera_config.framePeriodNs();
  std::optional<std::uint64_t> previous_fid;
  const auto launch = a.world->currentLaunch();
  ASSERT_TRUE(launch);
  const std::int64_t half_exposure = std::llround(a.rig.profile.camera_config.exposure_us * 500.0);
  int seen = 0;  // spheres found where the truth puts them at the frame's timestamp
  std::vector<std::int64_t> in_view;  // timestamps of the frames showing a sphere
  for (const auto& f : b.frames) {
    ASSERT_TRUE(f.good()) << "frame " << f.id;
    // Find the drawn frame this is (each is unique: sensor noise).
    const Drawn::Frame* match = nullptr;
    for (const auto& d : a.drawn->frames)
      if (cv::norm(d.image, f.image, cv::NORM_INF) == 0) {
        match = &d;
        break;
      }
    ASSERT_NE(match, nullptr) << "frame " << f.id << " is not a frame the simulator drew";
    // In order, none skipped, and stamped when it was drawn (the scene it shows).
    if (previous_fid) {
      EXPECT_EQ(CameraAravis::unwrapFrameId(*previous_fid, 0, match->fid), 1u);
    }
    previous_fid = match->fid;
    const std::int64_t drawn_at = match->drawn_at_ns;
    EXPECT_NEAR(static_cast<double>(f.timestamp_ns - drawn_at), 0.0, 0.25 * period)
        << "frame " << f.id;
    // The picture shows the world at the frame's timestamp: a bright sphere
    // wherever the simulation has one (its dots cover ~5 %, so the median of
    // its middle is bright), and only background where it has none.
    const auto views = a.renderer->sceneAt(*launch, f.timestamp_ns + half_exposure);
    if (!views.empty()) in_view.push_back(f.timestamp_ns);
    for (const auto& v : views) {
      const double r = v.radius_px;
      if (v.centre_px.x() < r || v.centre_px.y() < r || v.centre_px.x() > f.image.cols - r ||
          v.centre_px.y() > f.image.rows - r)
        continue;  // partly outside the picture
      std::vector<int> middle;
      for (int y = int(v.centre_px.y() - r / 2); y <= int(v.centre_px.y() + r / 2); ++y)
        for (int x = int(v.centre_px.x() - r / 2); x <= int(v.centre_px.x() + r / 2); ++x)
          if (std::hypot(x - v.centre_px.x(), y - v.centre_px.y()) <= r / 2)
            middle.push_back(f.image.at<std::uint8_t>(y, x));
      std::nth_element(middle.begin(), middle.begin() + middle.size() / 2, middle.end());
      EXPECT_GT(middle[middle.size() / 2], 100)
          << "frame " << f.id << ": no sphere at (" << v.centre_px.x() << ", " << v.centre_px.y()
          << ") where the simulation has one";
      ++seen;
    }
    if (views.empty()) {
      double peak = 0;
      cv::minMaxLoc(f.image, nullptr, &peak);
      EXPECT_LT(peak, 100) << "frame " << f.id << " shows something the simulation does not have";
    }
  }
  EXPECT_GE(seen, 4) << "the spheres should be in view during the burst";

  // The collision happened inside the burst, as the simulator's truth says.
  const auto truth = a.world->truthFor(b);
  ASSERT_TRUE(truth);
  // (On the truth's clock: seconds after frame 0's mid-exposure; the frames'
  // own timestamps, which need not be evenly spaced.)
  const auto zero = std::find_if(b.frames.begin(), b.frames.end(),
                                 [](const collide::vision::Frame& f) { return f.id == 0; });
  ASSERT_NE(zero, b.frames.end());
  const double t_first = (b.frames.front().timestamp_ns - zero->timestamp_ns) * 1e-9;
  const double t_last = (b.frames.back().timestamp_ns - zero->timestamp_ns) * 1e-9;
  EXPECT_GT(truth->t_collision_s, t_first);
  EXPECT_LT(truth->t_collision_s, t_last);

  // Analysed to the right e and beta: vision's analysis of the frames that
  // came through Aravis, against Walton's inverse operator applied to the
  // simulation's exact states just before and after the contact.
  const Flight& flight = launch->flight;
  ASSERT_TRUE(flight.collides());
  const SpheresProfile& sp = a.rig.profile.spheres;
  auto spheresOf = [&](const std::array<SphereState, 2>& st) {
    std::array<Sphere, 2> out;
    for (int i = 0; i < 2; ++i)
      out[i] = {sp.mass_kg[i], sp.diameter_m[i], st[i].position_m, st[i].velocity_m_s,
                st[i].spin_rad_s};
    return out;
  };
  const auto exact =
      measureCollision(spheresOf(flight.justBefore()), spheresOf(flight.justAfter()));
  ASSERT_TRUE(exact) << exact.error().message;
  vision::AnalysisSettings settings;
  const GeometryProfile& g = a.rig.profile.geometry;
  settings.pixel_size_m = g.pixel_size_m;
  settings.diameter_m = sp.diameter_m;
  settings.mass_kg = sp.mass_kg;
  settings.origin_u_px = g.origin_u_px;
  settings.origin_v_px = g.origin_v_px;
  settings.fps = b.fps;
  // The fake's stream thread keeps its frame rate only when it gets a CPU in
  // time; on a loaded machine it skips frame slots (ids stay consecutive, the
  // timestamps jump by several periods; under CI's sanitizer pass 8-10 ms).
  // A real camera never does. The vision core's tracker expects a camera's
  // even frame spacing (it follows the spheres frame to frame with one frame
  // period, taken from the ids), so after skipped slots near the contact its
  // tracks cannot be trusted (CI's sanitizer pass once failed with a smaller
  // gap: "sphere 1 is seen in 0 frames after the collision"). The measurement
  // is checked only when every frame showing the spheres came on time; the
  // frames themselves (bit-exact, in order, stamped when drawn) are checked
  // above in every case.
  std::int64_t widest_gap = 0;  // between frames that show the spheres
  for (std::size_t i = 1; i < in_view.size(); ++i)
    widest_gap = std::max(widest_gap, in_view[i] - in_view[i - 1]);
  if (widest_gap > period + period / 2)
    GTEST_SKIP() << "frames arrived, bit-exact and aligned with the truth, but the fake camera "
                    "could not hold its frame rate on this loaded machine (a gap of "
                 << widest_gap / 1e6 << " ms between frames showing the spheres, " << period / 1e6
                 << " ms expected): e and beta not checked";
  const auto analysed = vision::analyzeBurst(b, settings);
  ASSERT_TRUE(analysed) << analysed.error().message;
  const vision::CollisionProperties& c = analysed->collision;
  std::printf(
      "e %.4f (sigma %.4f, true %.4f)  beta %.4f (sigma %.4f, true %.4f)  frames %zu, widest gap "
      "%.1f ms\n",
      c.e.value, c.e.sigma, exact->e, c.beta.value, c.beta.sigma, exact->beta, b.frames.size(),
      widest_gap / 1e6);
  // The accuracy the vision core promises per shot (issue 4: |error of e| <=
  // 0.005, |error of beta| <= 0.03 for |v_n|, v_s >= 0.3 m/s), here on frames
  // that crossed Aravis' stream code with host-mapped timestamps. (Its
  // uncertainties do not cover the timestamp jitter of a software-timed fake
  // on a loaded machine, so they are not the yardstick here.)
  ASSERT_GE(std::abs(c.vn_m_s.value), 0.3);
  ASSERT_GE(c.vs_m_s.value, 0.3);
  EXPECT_NEAR(c.e.value, exact->e, 0.005);
  EXPECT_NEAR(c.beta.value, exact->beta, 0.03);
}
