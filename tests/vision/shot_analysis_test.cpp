// analyzeBurst against simulated shots with known truth (analysis/flight.hpp
// flights drawn by vision/render.hpp, see shot_fixture.hpp), and bad input.
#include "vision/shot_analysis.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <random>

#include "shot_fixture.hpp"

namespace collide::vision {
namespace {

using testing::ShotSpec;
using testing::SimulatedShot;
using testing::simulateShot;

bool hasFlag(const ShotAnalysis& a, const std::string& f) {
  return std::find(a.quality_flags.begin(), a.quality_flags.end(), f) != a.quality_flags.end();
}

struct Pulls {
  double sum2 = 0;
  int n = 0;
  void add(double err, double sigma) {
    sum2 += (err / sigma) * (err / sigma);
    ++n;
  }
  double rms() const { return std::sqrt(sum2 / n); }
};

// Issue 4 §3 at 640 x 480, 120 px spheres with dots, noise 2: per shot
// |error of e| <= 0.005 and |error of beta| <= 0.03 when |v_n|, v_s >= 0.3 m/s;
// spins within 2 % for |omega| >= 50 rad/s; and uncertainties that match the
// errors actually made (pulls near 1).
TEST(AnalyzeBurst, SimulatedShotsAreMeasuredAccuratelyWithHonestUncertainties) {
  Pulls pe, pb, pbi, pv;
  for (int i = 0; i < 16; ++i) {
    ShotSpec spec;
    spec.seed = 500 + i;
    spec.contact_angle_rad = -0.7 + 1.4 * (i % 8) / 7.0;
    spec.spin_max_rad_s = 20;  // at launch, as config/sim.toml
    // Spheres meeting a little out of one plane and flying slightly out of it,
    // as the analysis assumes by default.
    spec.contact_z_sigma = 0.01;
    spec.out_of_plane_fraction = 0.005;
    spec.speed1_m_s = 1.6 + 0.1 * (i % 5);
    spec.speed2_m_s = 2.4 - 0.1 * (i % 3);
    const SimulatedShot shot = simulateShot(spec);
    auto r = analyzeBurst(shot.burst, shot.settings);
    ASSERT_TRUE(r.ok()) << "shot " << i << ": " << r.error().message;
    const CollisionProperties& c = r->collision;
    const double de = c.e.value - shot.truth.e, db = c.beta.value - shot.truth.beta;
    std::printf(
        "shot %2d: vn %.2f vs %.2f  e %+.5f (sigma %.5f)  beta %+.4f (sigma %.4f)  t %+.1e s\n", i,
        c.vn_m_s.value, c.vs_m_s.value, de, c.e.sigma, db, c.beta.sigma,
        c.t_collision_s.value - shot.t_collision_s);
    EXPECT_NEAR(c.vn_m_s.value, shot.truth.before.v_n_m_s, 5 * c.vn_m_s.sigma + 1e-4);
    EXPECT_NEAR(c.vs_m_s.value, shot.truth.before.v_s_m_s, 5 * c.vs_m_s.sigma + 1e-4);
    EXPECT_LE(std::abs(de), 0.005);
    EXPECT_LE(std::abs(db), 5 * c.beta.sigma + 1e-4);
    // The target where the geometry allows it: near head-on, the
    // unseen z offset of the line of centres (contact_z_sigma) limits beta,
    // and the stated uncertainty says so.
    if (std::abs(c.vn_m_s.value) >= 0.3 && c.vs_m_s.value >= 0.3 && c.beta.sigma < 0.01) {
      EXPECT_LE(std::abs(db), 0.03);
    }
    EXPECT_NEAR(c.t_collision_s.value, shot.t_collision_s, 5 * c.t_collision_s.sigma + 1e-7);
    EXPECT_NEAR(c.gamma_deg.value, shot.truth.before.gamma_rad * 180 / 3.14159265358979,
                5 * c.gamma_deg.sigma + 0.01);
    EXPECT_NEAR(c.f.value, shot.truth.f, 5 * c.f.sigma + 1e-3);
    EXPECT_FALSE(hasFlag(*r, "no_spin_before"));
    EXPECT_FALSE(hasFlag(*r, "no_spin_after"));
    EXPECT_FALSE(hasFlag(*r, "collision_instant_disagree"));
    EXPECT_FALSE(hasFlag(*r, "large_residuals"));
    EXPECT_FALSE(hasFlag(*r, "gravity_scale_mismatch"));
    pe.add(de, c.e.sigma);
    if (shot.truth.before.v_s_m_s > 0.3) {
      pb.add(db, c.beta.sigma);
      pbi.add(c.beta_from_impulse.value - shot.truth.beta, c.beta_from_impulse.sigma);
    }
    for (int s = 0; s < 2; ++s) {
      const SphereKinematics& k = r->sphere[s];
      for (const auto& [est, truth] : {std::pair{k.spin_before_rad_s, shot.before[s].spin_rad_s},
                                       std::pair{k.spin_after_rad_s, shot.after[s].spin_rad_s}})
        if (truth.norm() >= 50) {
          EXPECT_LT((est.value - truth).norm(), 0.02 * truth.norm());
        }
      for (int a = 0; a < 2; ++a) {
        pv.add(k.velocity_before_m_s.value[a] - shot.before[s].velocity_m_s[a],
               k.velocity_before_m_s.sigma[a]);
        pv.add(k.velocity_after_m_s.value[a] - shot.after[s].velocity_m_s[a],
               k.velocity_after_m_s.sigma[a]);
      }
    }
  }
  std::printf(
      "pull RMS: e %.2f (%d shots), beta %.2f, beta from impulse %.2f (%d), velocity %.2f\n",
      pe.rms(), pe.n, pb.rms(), pbi.rms(), pb.n, pv.rms());
  // 16 shots: a pull RMS is known to about +-20 %; an uncertainty off by a
  // factor 2 either way fails.
  for (const double p : {pe.rms(), pb.rms(), pbi.rms(), pv.rms()}) {
    EXPECT_GT(p, 0.55);
    EXPECT_LT(p, 1.6);
  }
}

TEST(AnalyzeBurst, ThesisImagingAndTwelveBitFrames) {
  for (int i = 0; i < 4; ++i) {
    ShotSpec spec;
    spec.seed = 700 + i;
    spec.width = 240, spec.height = 192;
    spec.pixel_size_m = 6.865e-4;  // 37 px spheres
    spec.noise_grey = 1.5;
    spec.frames_before = 35, spec.frames_after = 45;
    spec.contact_angle_rad = -0.5 + 0.33 * i;
    if (i % 2) {
      spec.format = PixelFormat::Mono12;
      spec.noise_grey = 1.5 * 16;
    }
    const SimulatedShot shot = simulateShot(spec);
    auto r = analyzeBurst(shot.burst, shot.settings);
    ASSERT_TRUE(r.ok()) << r.error().message;
    const CollisionProperties& c = r->collision;
    std::printf("thesis shot %d: e %+.4f (%.4f)  beta %+.4f (%.4f)  vs %.2f\n", i,
                c.e.value - shot.truth.e, c.e.sigma, c.beta.value - shot.truth.beta, c.beta.sigma,
                c.vs_m_s.value);
    // Three times better than the thesis' +-0.015 on e.
    EXPECT_LE(std::abs(c.e.value - shot.truth.e), 0.005);
    EXPECT_NEAR(c.e.value, shot.truth.e, 5 * c.e.sigma);
    EXPECT_NEAR(c.beta.value, shot.truth.beta, 5 * c.beta.sigma + 0.005);
  }
}

// ------------------------------------------------------------ bad input (§5)

ShotSpec quickSpec(std::uint64_t seed) {
  ShotSpec spec;
  spec.seed = seed;
  spec.exposure_us = 0;  // no blur: quicker to draw
  spec.frames_before = 20;
  spec.frames_after = 20;
  return spec;
}

TEST(AnalyzeBurstBadInput, NoUsableFrames) {
  Burst b;
  auto r = analyzeBurst(b, {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("no usable frame"), std::string::npos);
  SimulatedShot shot = simulateShot(quickSpec(1));
  for (Frame& f : shot.burst.frames) f.status = FrameStatus::Incomplete;
  r = analyzeBurst(shot.burst, shot.settings);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("no usable frame"), std::string::npos);
}

TEST(AnalyzeBurstBadInput, FramesWithoutSpheres) {
  SimulatedShot shot = simulateShot(quickSpec(2));
  for (Frame& f : shot.burst.frames) f.image.setTo(5);
  auto r = analyzeBurst(shot.burst, shot.settings);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("no sphere found"), std::string::npos) << r.error().message;
}

TEST(AnalyzeBurstBadInput, OnlyOneSphere) {
  SimulatedShot shot = simulateShot(quickSpec(3));
  // Paint over the right half: only sphere 1 (left) remains before impact.
  for (Frame& f : shot.burst.frames) f.image(cv::Rect(320, 0, 320, 480)).setTo(5);
  auto r = analyzeBurst(shot.burst, shot.settings);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("two separate spheres"), std::string::npos) << r.error().message;
}

TEST(AnalyzeBurstBadInput, ThirdBlobIsIgnoredAndFlagged) {
  SimulatedShot shot = simulateShot(quickSpec(4));
  // A bright ball of another size, fixed in the corner, and a sphere-sized
  // one elsewhere in a few frames.
  int k = 0;
  for (Frame& f : shot.burst.frames) {
    cv::circle(f.image, {40, 40}, 25, cv::Scalar(200), cv::FILLED, cv::LINE_AA);
    if (k++ % 10 == 0)
      cv::circle(f.image, {320, 420}, 60, cv::Scalar(190), cv::FILLED, cv::LINE_AA);
  }
  auto r = analyzeBurst(shot.burst, shot.settings);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(hasFlag(*r, "extra_blobs_ignored"));
  EXPECT_NEAR(r->collision.e.value, shot.truth.e, 0.005);
}

TEST(AnalyzeBurstBadInput, SaturatedFramesAreSkippedAndFlagged) {
  SimulatedShot shot = simulateShot(quickSpec(5));
  for (std::size_t k = 0; k < shot.burst.frames.size(); k += 7)
    shot.burst.frames[k].image.setTo(255);
  auto r = analyzeBurst(shot.burst, shot.settings);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(hasFlag(*r, "saturated_frames"));
  EXPECT_NEAR(r->collision.e.value, shot.truth.e, 0.005);
  // Every frame saturated: nothing to analyse, and the message says why.
  for (Frame& f : shot.burst.frames) f.image.setTo(255);
  r = analyzeBurst(shot.burst, shot.settings);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("no sphere found"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("saturated"), std::string::npos) << r.error().message;
}

TEST(AnalyzeBurstBadInput, WrongDiameter) {
  SimulatedShot shot = simulateShot(quickSpec(6));
  AnalysisSettings s = shot.settings;
  s.diameter_m = {0.0127, 0.0127};  // half the truth, pixel size given
  auto r = analyzeBurst(shot.burst, s);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("diameter"), std::string::npos) << r.error().message;
  // Pixel size from the radii (the --frames path): the scale is then wrong by
  // a factor 2, which gravity gives away.
  s.pixel_size_m = 0;
  r = analyzeBurst(shot.burst, s);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(hasFlag(*r, "gravity_scale_mismatch"));
  // Right diameter, pixel size from the radii: no flag, and the pixel size found.
  s.diameter_m = shot.settings.diameter_m;
  r = analyzeBurst(shot.burst, s);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_FALSE(hasFlag(*r, "gravity_scale_mismatch"));
  EXPECT_NEAR(r->pixel_size_m, shot.settings.pixel_size_m, 1e-3 * shot.settings.pixel_size_m);
}

TEST(AnalyzeBurstBadInput, FramesOfDifferentSizesOrDepths) {
  SimulatedShot shot = simulateShot(quickSpec(7));
  shot.burst.frames[5].image = cv::Mat(240, 320, CV_8UC1, cv::Scalar(5));
  auto r = analyzeBurst(shot.burst, shot.settings);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("different sizes"), std::string::npos) << r.error().message;
  SimulatedShot shot2 = simulateShot(quickSpec(7));
  shot2.burst.format = PixelFormat::Mono16;  // says 16 bit, holds 8
  r = analyzeBurst(shot2.burst, shot2.settings);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("Mono16"), std::string::npos) << r.error().message;
}

TEST(AnalyzeBurstBadInput, NoCollisionInTheBurst) {
  // Only the frames before the impact.
  SimulatedShot shot = simulateShot(quickSpec(8));
  shot.burst.frames.resize(15);
  auto r = analyzeBurst(shot.burst, shot.settings);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("collision"), std::string::npos) << r.error().message;
}

TEST(AnalyzeBurstBadInput, TimestampsMissing) {
  SimulatedShot shot = simulateShot(quickSpec(9));
  for (Frame& f : shot.burst.frames) f.timestamp_ns = 0;
  AnalysisSettings s = shot.settings;
  s.fps = 1000;  // ids and the frame rate give the clock
  auto r = analyzeBurst(shot.burst, s);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_NEAR(r->collision.e.value, shot.truth.e, 0.005);
  s.fps = 0;
  shot.burst.fps = 0;
  r = analyzeBurst(shot.burst, s);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("--fps"), std::string::npos) << r.error().message;
}

TEST(AnalyzeBurst, ProgressAndPerFrameRecord) {
  SimulatedShot shot = simulateShot(quickSpec(10));
  int calls = 0, last = 0;
  shot.settings.progress = [&](int done, int total) {
    ++calls;
    EXPECT_GT(done, last) << "progress went back";
    last = done;
    EXPECT_EQ(total, static_cast<int>(shot.burst.frames.size()));
  };
  auto r = analyzeBurst(shot.burst, shot.settings);
  ASSERT_TRUE(r.ok()) << r.error().message;
  // Frames are detected in parallel: counts may be skipped, never repeated.
  EXPECT_GE(calls, 1);
  EXPECT_LE(calls, static_cast<int>(shot.burst.frames.size()));
  EXPECT_EQ(last, static_cast<int>(shot.burst.frames.size()));
  ASSERT_EQ(r->frames.size(), shot.burst.frames.size());
  const double px = shot.settings.pixel_size_m;
  for (std::size_t k = 0; k < r->frames.size(); ++k) {
    const FrameDetections& fd = r->frames[k];
    EXPECT_EQ(fd.frame_id, shot.burst.frames[k].id);
    for (int s = 0; s < 2; ++s) {
      if (!fd.sphere[s]) continue;
      const Vec3& p = shot.states[k][s].position_m;
      EXPECT_NEAR(fd.sphere[s]->u_px, shot.settings.origin_u_px + p.x() / px, 0.2);
      EXPECT_NEAR(fd.sphere[s]->v_px, shot.settings.origin_v_px - p.y() / px, 0.2);
    }
  }
  // Sphere 1 is the left one before the impact.
  EXPECT_GT(r->sphere[0].velocity_before_m_s.value.x(), 0);
  EXPECT_LT(r->sphere[1].velocity_before_m_s.value.x(), 0);
  ASSERT_TRUE(r->trajectory[0][0].has_value());
  // The acceleration is not fitted: gravity, and the air's drag at the fit's
  // velocity (against sphere 1's motion to the right), as the fit's last pass
  // had it (1e-7 of the drag from the final velocity's; a fitted acceleration
  // would be off by ~0.1 m/s^2 with this noise).
  const TrajectoryFit& f = *r->trajectory[0][0];
  const AirDrag air{shot.settings.diameter_m[0], shot.settings.mass_kg[0], kAirDensity_kg_m3};
  const Vec3 drag = air.acceleration(f.velocityAt_m_s(f.tRef_s()).value);
  EXPECT_LT(drag.x(), -0.01);
  EXPECT_NEAR(f.acceleration_m_s2().value.x(), drag.x(), 1e-6);
  EXPECT_NEAR(f.acceleration_m_s2().value.y(), -9.80665 + drag.y(), 1e-6);
}

// ------------------------------------------------- flags, both ways (issue 12)

// Moves the clock of every frame from the impact on (id >= 0) by shift_ns, or
// runs it `rate` times as fast: a glitch the truth knows exactly.
void retimeAfterImpact(Burst& b, std::int64_t shift_ns, double rate = 1.0) {
  std::int64_t t0 = 0;
  for (const Frame& f : b.frames)
    if (f.id == 0) t0 = f.timestamp_ns;
  for (Frame& f : b.frames)
    if (f.id >= 0) f.timestamp_ns = t0 + shift_ns + std::llround((f.timestamp_ns - t0) / rate);
}

TEST(AnalyzeBurstFlags, CollisionInstantDisagreeOnlyWhenTheInstantsDisagree) {
  const SimulatedShot shot = simulateShot(quickSpec(21));
  auto r = analyzeBurst(shot.burst, shot.settings);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_FALSE(hasFlag(*r, "collision_instant_disagree"));
  const double sigma_honest = r->collision.t_collision_s.sigma;
  ASSERT_GT(sigma_honest, 0);
  // The post-impact frames 60 us late: the two instants 60 us apart, as a
  // contact that lasts 60 us makes them. Not a disagreement, and the combined
  // instant's sigma is not widened for it (it is many times that sigma).
  Burst b = shot.burst;
  retimeAfterImpact(b, 60000);
  r = analyzeBurst(b, shot.settings);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_NEAR(r->collision.t_collision_after_s - r->collision.t_collision_before_s, 60e-6, 20e-6);
  EXPECT_FALSE(hasFlag(*r, "collision_instant_disagree"));
  ASSERT_GT(60e-6, 5 * sigma_honest);
  EXPECT_LT(r->collision.t_collision_s.sigma, 1.5 * sigma_honest);
  // 800 us late, or 400 us early: beyond any contact's duration and the
  // instants' uncertainties.
  for (const std::int64_t shift_ns : {800000, -400000}) {
    b = shot.burst;
    retimeAfterImpact(b, shift_ns);
    r = analyzeBurst(b, shot.settings);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_NEAR(r->collision.t_collision_after_s - r->collision.t_collision_before_s,
                shift_ns * 1e-9, 20e-6);
    EXPECT_TRUE(hasFlag(*r, "collision_instant_disagree")) << shift_ns;
    // Then the combined instant is uncertain by a good part of their disagreement.
    EXPECT_GT(r->collision.t_collision_s.sigma, 0.1 * std::abs(shift_ns) * 1e-9) << shift_ns;
  }
}

TEST(AnalyzeBurstFlags, UnphysicalOnlyWhenPhysicsIsBroken) {
  // An honest shot: no flag.
  const SimulatedShot shot = simulateShot(quickSpec(22));
  auto r = analyzeBurst(shot.burst, shot.settings);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_FALSE(hasFlag(*r, "unphysical"));
  EXPECT_LT(r->collision.kinetic_energy_change_J.value, 0);
  // The post-impact clock running 20 % slow: the spheres seem to part 25 %
  // faster, e about 1.2 and kinetic energy gained.
  Burst b = shot.burst;
  retimeAfterImpact(b, 0, 1.25);
  r = analyzeBurst(b, shot.settings);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_GT(r->collision.e.value, 1.1);
  EXPECT_GT(r->collision.kinetic_energy_change_J.value, 0);
  EXPECT_TRUE(hasFlag(*r, "unphysical"));
  // At the bounds but not beyond: a perfectly elastic, frictionless impact
  // (e = 1, beta = -1, no energy lost) is physics, and measured within its
  // noise of the bounds.
  for (std::uint64_t seed : {23, 24, 25}) {
    ShotSpec spec = quickSpec(seed);
    spec.material = Material{1.0, 0.0, 0.44};
    const SimulatedShot elastic = simulateShot(spec);
    r = analyzeBurst(elastic.burst, elastic.settings);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_NEAR(r->collision.e.value, 1, 0.005);
    EXPECT_FALSE(hasFlag(*r, "unphysical"))
        << "e " << r->collision.e.value << " +- " << r->collision.e.sigma << ", beta "
        << r->collision.beta.value << " +- " << r->collision.beta.sigma << ", dKE "
        << r->collision.kinetic_energy_change_J.value << " +- "
        << r->collision.kinetic_energy_change_J.sigma;
  }
}

// Every flag of a clean shot is off; each of these turns on with its cause.
TEST(AnalyzeBurstFlags, EachFlagFiresWithItsCauseAndOnlyThen) {
  const SimulatedShot clean = simulateShot(quickSpec(31));
  auto r = analyzeBurst(clean.burst, clean.settings);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(r->quality_flags.empty()) << r->quality_flags.front();

  // Few frames on one side (4 < 5), then 8 (not few).
  for (const int side : {0, 1}) {
    ShotSpec spec = quickSpec(32);
    (side == 0 ? spec.frames_before : spec.frames_after) = 4;
    SimulatedShot shot = simulateShot(spec);
    r = analyzeBurst(shot.burst, shot.settings);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(hasFlag(*r, "few_frames_before"), side == 0);
    EXPECT_EQ(hasFlag(*r, "few_frames_after"), side == 1);
    (side == 0 ? spec.frames_before : spec.frames_after) = 8;
    shot = simulateShot(spec);
    r = analyzeBurst(shot.burst, shot.settings);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_FALSE(hasFlag(*r, "few_frames_before"));
    EXPECT_FALSE(hasFlag(*r, "few_frames_after"));
  }

  // A frame lost in transfer, or frames dropped by the camera.
  {
    Burst b = clean.burst;
    b.frames[7].status = FrameStatus::Incomplete;
    r = analyzeBurst(b, clean.settings);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_TRUE(hasFlag(*r, "frames_lost"));
    b = clean.burst;
    b.stats.dropped = 2;
    r = analyzeBurst(b, clean.settings);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_TRUE(hasFlag(*r, "frames_lost"));
  }

  // Spheres without dots: no spin on either side.
  {
    ShotSpec spec = quickSpec(33);
    spec.dots = false;
    const SimulatedShot shot = simulateShot(spec);
    r = analyzeBurst(shot.burst, shot.settings);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_TRUE(hasFlag(*r, "no_spin_before"));
    EXPECT_TRUE(hasFlag(*r, "no_spin_after"));
    // Spin-dependent results unavailable, never guessed; e still measured.
    const CollisionProperties& c = r->collision;
    EXPECT_TRUE(std::isnan(c.beta.value)) << c.beta.value;
    EXPECT_TRUE(std::isnan(c.beta_from_impulse.value)) << c.beta_from_impulse.value;
    EXPECT_TRUE(std::isnan(c.vs_after_m_s.value)) << c.vs_after_m_s.value;
    EXPECT_NEAR(c.e.value, shot.truth.e, 5 * c.e.sigma + 1e-3);
  }

  // Every other frame displaced by one pixel (a shaking camera): the centres
  // scatter by +-0.5 px about any smooth track.
  {
    Burst b = clean.burst;
    for (std::size_t k = 0; k < b.frames.size(); k += 2) {
      cv::Mat moved;
      const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 1, 0, 1, 0);
      cv::warpAffine(b.frames[k].image, moved, shift, b.frames[k].image.size(), cv::INTER_NEAREST,
                     cv::BORDER_REPLICATE);
      b.frames[k].image = moved;
    }
    r = analyzeBurst(b, clean.settings);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_TRUE(hasFlag(*r, "large_residuals"));
  }

  // Each frame displaced by a random whole pixel or not at all (independent
  // scatter of about 0.5 px, as a badly mounted camera might give): no order in
  // the residuals, so no large_residuals; the fits' chi^2 widens the sigmas
  // instead, and e stays within them of the truth.
  {
    Burst b = clean.burst;
    std::mt19937_64 rng(7);
    std::uniform_int_distribution<int> step(-1, 1);
    for (auto& frame : b.frames) {
      const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, step(rng), 0, 1, step(rng));
      cv::Mat moved;
      cv::warpAffine(frame.image, moved, shift, frame.image.size(), cv::INTER_NEAREST,
                     cv::BORDER_REPLICATE);
      frame.image = moved;
    }
    r = analyzeBurst(b, clean.settings);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_FALSE(hasFlag(*r, "large_residuals"));
    const auto& e = r->collision.e;
    EXPECT_LE(std::abs(e.value - clean.truth.e), 3 * e.sigma) << e.value << " +- " << e.sigma;
    const auto unshifted = analyzeBurst(clean.burst, clean.settings);
    ASSERT_TRUE(unshifted.ok()) << unshifted.error().message;
    EXPECT_GT(e.sigma, 3 * unshifted->collision.e.sigma) << "the scatter did not widen e's sigma";
  }

  // Head-on without spin or vertical motion: v_s is zero, so beta cannot be
  // told (SPEC eq. 5.1); e can.
  {
    ShotSpec spec = quickSpec(34);
    spec.contact_angle_rad = 0;
    spec.spin_max_rad_s = 0;
    spec.vy_spread_m_s = 0;
    const SimulatedShot shot = simulateShot(spec);
    r = analyzeBurst(shot.burst, shot.settings);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_LT(shot.truth.before.v_s_m_s, 1e-9);
    EXPECT_TRUE(hasFlag(*r, "beta_untrustworthy_geometry"));
    EXPECT_FALSE(hasFlag(*r, "e_untrustworthy_geometry"));
  }

  // Near-grazing at the thesis' imaging (37 px spheres, 10 frames a side):
  // the line of centres 1.7 degrees off vertical, no vertical relative
  // motion, 1 m/s apart horizontally, so |v_n| = 0.03 m/s, below what eq. 5.1
  // lets 37 px and 10 frames tell to 5 %; v_s (1 m/s) is fine.
  {
    ShotSpec spec = quickSpec(36);
    spec.width = 240, spec.height = 192;
    spec.pixel_size_m = 6.865e-4;
    spec.noise_grey = 1.5;
    spec.frames_before = spec.frames_after = 10;
    spec.speed1_m_s = spec.speed2_m_s = 0.5;
    spec.contact_angle_rad = 0.5 * 3.14159265358979 - 0.03;
    spec.spin_max_rad_s = 0;
    spec.vy_spread_m_s = 0;
    const SimulatedShot shot = simulateShot(spec);
    r = analyzeBurst(shot.burst, shot.settings);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_NEAR(shot.truth.before.v_n_m_s, -0.03, 0.002);
    EXPECT_TRUE(hasFlag(*r, "e_untrustworthy_geometry"));
    EXPECT_FALSE(hasFlag(*r, "beta_untrustworthy_geometry"));
  }
}

// Angular momentum about the contact point: sphere 1's spin after the impact
// 25 rad/s (0.3 m/s at its surface) more than the impulse gave it, as a dot
// mistaken for another would make it seem. beta read from the spins is then
// wrong, beta from the impulse is not, and the shot is flagged; the same
// shots drawn honestly are not.
TEST(AnalyzeBurstFlags, SpinImpulseDisagreeWhenASpinBreaksAngularMomentum) {
  for (const std::uint64_t seed : {41, 42, 43}) {
    ShotSpec spec = quickSpec(seed);
    const SimulatedShot honest = simulateShot(spec);
    auto r = analyzeBurst(honest.burst, honest.settings);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_FALSE(hasFlag(*r, "spin_impulse_disagree"))
        << "seed " << seed << ": beta " << r->collision.beta.value << ", from the impulse "
        << r->collision.beta_from_impulse.value;
    spec.spin_kick_after_rad_s = 25;
    const SimulatedShot kicked = simulateShot(spec);
    r = analyzeBurst(kicked.burst, kicked.settings);
    ASSERT_TRUE(r.ok()) << r.error().message;
    const CollisionProperties& c = r->collision;
    EXPECT_NEAR(c.beta_from_impulse.value, kicked.truth.beta, 5 * c.beta_from_impulse.sigma + 1e-3)
        << "seed " << seed;
    EXPECT_TRUE(hasFlag(*r, "spin_impulse_disagree"))
        << "seed " << seed << ": beta " << c.beta.value << ", from the impulse "
        << c.beta_from_impulse.value << " (true " << kicked.truth.beta << ")";
  }
}

// Spheres flying out of the image plane at ~0.1 m/s, seen by a camera 0.5 m
// away: their images grow or shrink, and the velocity towards the camera
// comes out of the radii. Without the camera's distance, nothing is claimed.
TEST(AnalyzeBurst, VelocityTowardsTheCameraFromTheApparentSize) {
  ShotSpec spec = quickSpec(51);
  spec.out_of_plane_fraction = 0.05;
  spec.camera_distance_m = 0.5;
  SimulatedShot shot = simulateShot(spec);
  // v_z's sigma carries a radius bias that may change by radius_systematic_px
  // over a track (Z0 sigma_r / (r T)); with this even light the detector's
  // radius is steady to a few hundredths of a pixel.
  shot.settings.radius_systematic_px = 0.02;
  auto r = analyzeBurst(shot.burst, shot.settings);
  ASSERT_TRUE(r.ok()) << r.error().message;
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side) {
      const auto& vz = r->sphere[s].vz_from_size_m_s[side];
      ASSERT_TRUE(vz.has_value()) << s << " " << side;
      const double truth = (side == 0 ? shot.before : shot.after)[s].velocity_m_s.z();
      std::printf("sphere %d %s: v_z %+.4f +- %.4f m/s (truth %+.4f)\n", s + 1,
                  side == 0 ? "before" : "after ", vz->value, vz->sigma, truth);
      EXPECT_GT(vz->sigma, 0);
      EXPECT_LT(vz->sigma, 0.02);
      EXPECT_NEAR(vz->value, truth, 5 * vz->sigma + 0.002);
    }
  // The line of centres' z part, from the sizes and as the inverse found it.
  const double nz_truth = (shot.before[0].position_m - shot.before[1].position_m).normalized().z();
  const auto& nz_size = r->collision.line_of_centres_z_from_size;
  ASSERT_TRUE(nz_size.has_value());
  std::printf("n_z: truth %+.4f, from size %+.4f +- %.4f, analysis %+.4f +- %.4f\n", nz_truth,
              nz_size->value, nz_size->sigma, r->collision.line_of_centres_z.value,
              r->collision.line_of_centres_z.sigma);
  EXPECT_NEAR(nz_size->value, nz_truth, 4 * nz_size->sigma + 0.002);
  EXPECT_NEAR(r->collision.line_of_centres_z.value, nz_truth,
              4 * r->collision.line_of_centres_z.sigma + 0.002);
  AnalysisSettings unknown = shot.settings;
  unknown.camera_distance_m = 0;
  r = analyzeBurst(shot.burst, unknown);
  ASSERT_TRUE(r.ok()) << r.error().message;
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side) EXPECT_FALSE(r->sphere[s].vz_from_size_m_s[side]);
  EXPECT_FALSE(r->collision.line_of_centres_z_from_size);
}

// The radii's frame-to-frame scatter the analysis reports, against the truth
// (an orthographic camera: every frame's true radius is the sphere's over the
// pixel size), and the radius bias it then allows for: the profile's where
// the outlines are steady, 0.75 times the scatter, with a note, where the
// sensor's noise makes them scatter more.
TEST(AnalyzeBurst, RadiusScatterIsMeasuredAndWidensTheRadiusBiasOnlyWhenLarger) {
  for (const double noise : {2.0, 40.0}) {
    ShotSpec spec = quickSpec(61);
    spec.noise_grey = noise;
    SimulatedShot shot = simulateShot(spec);
    shot.settings.radius_systematic_px = 0.05;
    auto r = analyzeBurst(shot.burst, shot.settings);
    ASSERT_TRUE(r.ok()) << r.error().message;
    // The truth's scatter: each track's radius errors about their own mean,
    // pooled (a track's mean bias is not scatter).
    const double r_true = 0.5 * spec.diameter_m / spec.pixel_size_m;
    double ss = 0;
    int n = 0;
    for (int s = 0; s < 2; ++s)
      for (int side = 0; side < 2; ++side) {
        std::vector<double> err;
        for (const FrameDetections& f : r->frames) {
          const auto& d = f.sphere[s];
          if (!d || d->touching || d->cut_by_border) continue;
          if ((f.t_s > r->collision.t_collision_s.value) != (side == 1)) continue;
          err.push_back(d->radius_px - r_true);
        }
        if (err.size() < 5) continue;
        double mean = 0;
        for (const double e : err) mean += e / err.size();
        for (const double e : err) ss += (e - mean) * (e - mean);
        n += static_cast<int>(err.size()) - 1;
      }
    ASSERT_GT(n, 40);
    const double truth = std::sqrt(ss / n);
    std::printf("noise %.0f: radius scatter %.4f px (truth %.4f), bias allowed %.4f px\n", noise,
                r->radius_scatter_px, truth, r->radius_systematic_px);
    EXPECT_GT(r->radius_scatter_px, 0.7 * truth);
    EXPECT_LT(r->radius_scatter_px, 1.4 * truth);
    const bool raised = 0.75 * r->radius_scatter_px > 0.05;
    EXPECT_EQ(raised, noise > 10) << "the clean shot's outlines should be steadier than 0.067 px";
    EXPECT_DOUBLE_EQ(r->radius_systematic_px, raised ? 0.75 * r->radius_scatter_px : 0.05);
    const bool noted = std::any_of(r->notes.begin(), r->notes.end(), [](const std::string& note) {
      return note.find("radii scatter") != std::string::npos;
    });
    EXPECT_EQ(noted, raised);
  }
}

// The profile's centre_offset_px reaches the Monte Carlo (each track's
// centres off by it, per axis, drawn for each track on its own): the same
// shot's instant and e are stated less precisely with it, and measured the
// same (the instant's weights rest on the fits' own errors).
TEST(AnalyzeBurst, ACentreOffsetPerTrackWidensTheInstantAndEOnly) {
  ShotSpec spec = quickSpec(71);
  spec.contact_angle_rad = 1.2;  // about 70 degrees from head-on
  const SimulatedShot shot = simulateShot(spec);
  AnalysisSettings with = shot.settings;
  with.centre_offset_px = 0.05;
  const auto a = analyzeBurst(shot.burst, shot.settings);
  const auto b = analyzeBurst(shot.burst, with);
  ASSERT_TRUE(a.ok()) << a.error().message;
  ASSERT_TRUE(b.ok()) << b.error().message;
  EXPECT_DOUBLE_EQ(b->collision.e.value, a->collision.e.value);
  EXPECT_DOUBLE_EQ(b->collision.t_collision_s.value, a->collision.t_collision_s.value);
  std::printf("t_c sigma %.2f -> %.2f us, e sigma %.5f -> %.5f\n",
              1e6 * a->collision.t_collision_s.sigma, 1e6 * b->collision.t_collision_s.sigma,
              a->collision.e.sigma, b->collision.e.sigma);
  EXPECT_GT(b->collision.t_collision_s.sigma, 1.2 * a->collision.t_collision_s.sigma);
  EXPECT_GT(b->collision.e.sigma, 1.1 * a->collision.e.sigma);
}

// e_untrustworthy_geometry by v_n's own sigma: near grazing incidence the
// line of centres' direction, set by the instant, leaves v_n (and e) far
// less certain than the tracks' scatter alone (SPEC eq. 5.1) says. The flag
// fires where v_n's stated sigma passes 5 % of it and not where it does not;
// where it fires e's error is still within its (large) sigma.
TEST(AnalyzeBurstFlags, ENotTrustedWhereVnIsUncertainNearGrazingIncidence) {
  for (const double angle : {1.0, 1.3, 1.45, 1.5, 1.53, 1.55, 1.56}) {
    ShotSpec spec = quickSpec(81);
    spec.contact_angle_rad = angle;
    spec.vy_spread_m_s = 0;
    const SimulatedShot shot = simulateShot(spec);
    const auto r = analyzeBurst(shot.burst, shot.settings);
    ASSERT_TRUE(r.ok()) << r.error().message;
    const Measured& vn = r->collision.vn_m_s;
    const bool flagged = hasFlag(*r, "e_untrustworthy_geometry");
    std::printf("angle %.2f: v_n %.4f +- %.4f m/s (truth %.4f), e err %+.4f +- %.4f, flag %d\n",
                angle, vn.value, vn.sigma, shot.truth.before.v_n_m_s,
                r->collision.e.value - shot.truth.e, r->collision.e.sigma, flagged);
    if (vn.sigma > 0.05 * std::abs(vn.value)) {
      EXPECT_TRUE(flagged);
    }
    if (angle <= 1.3) {
      EXPECT_FALSE(flagged);
    }
    EXPECT_LE(std::abs(r->collision.e.value - shot.truth.e), 4 * r->collision.e.sigma);
  }
}

// The profile's blur term (blur_offset_onset_px, blur_offset_per_px2)
// widens the sigmas of a shot whose spheres smear beyond the onset over the
// exposure, by the offset it says, and leaves a shot that smears less alone;
// the values stay (the instant's weights rest on the fits' own errors).
TEST(AnalyzeBurst, TheBlurTermWidensOnlyShotsSmearedBeyondItsOnset) {
  for (const double exposure_us : {50.0, 400.0}) {
    ShotSpec spec = quickSpec(72);
    spec.contact_angle_rad = 1.2;
    spec.exposure_us = exposure_us;  // 2 m/s: 0.5 and 3.8 px of smear
    const SimulatedShot shot = simulateShot(spec);
    AnalysisSettings with = shot.settings;
    with.blur_offset_onset_px = 2.0;
    with.blur_offset_per_px2 = 0.04;
    const auto a = analyzeBurst(shot.burst, shot.settings);
    const auto b = analyzeBurst(shot.burst, with);
    ASSERT_TRUE(a.ok()) << a.error().message;
    ASSERT_TRUE(b.ok()) << b.error().message;
    EXPECT_DOUBLE_EQ(b->collision.e.value, a->collision.e.value);
    std::printf("%.0f us: t_c sigma %.2f -> %.2f us, e sigma %.5f -> %.5f\n", exposure_us,
                1e6 * a->collision.t_collision_s.sigma, 1e6 * b->collision.t_collision_s.sigma,
                a->collision.e.sigma, b->collision.e.sigma);
    if (exposure_us < 100) {
      EXPECT_DOUBLE_EQ(b->collision.e.sigma, a->collision.e.sigma);
    } else {
      EXPECT_GT(b->collision.t_collision_s.sigma, 1.2 * a->collision.t_collision_s.sigma);
      EXPECT_GT(b->collision.e.sigma, 1.1 * a->collision.e.sigma);
    }
  }
}

}  // namespace
}  // namespace collide::vision
