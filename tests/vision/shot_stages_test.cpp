// analyzeBurst's image stages on their own (vision/shot_tracking.hpp,
// shot_fits.hpp, shot_spins.hpp), against simulated shots with known truth
// (shot_fixture.hpp).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "shot_fixture.hpp"
#include "vision/shot_fits.hpp"
#include "vision/shot_spins.hpp"
#include "vision/shot_tracking.hpp"

namespace collide::vision {
namespace {

using ::testing::HasSubstr;
using testing::ShotSpec;
using testing::SimulatedShot;
using testing::simulateShot;

ShotSpec quick(std::uint64_t seed) {
  ShotSpec spec;
  spec.seed = seed;
  spec.exposure_us = 0;
  spec.frames_before = 20;
  spec.frames_after = 20;
  return spec;
}

TEST(PrepareFrames, ClockFromTimestampsOrFromIdsAndRate) {
  SimulatedShot shot = simulateShot(quick(41));
  auto bf = prepareFrames(shot.burst, 0);
  ASSERT_TRUE(bf.ok()) << bf.error().message;
  ASSERT_EQ(bf->data.size(), shot.burst.frames.size());
  EXPECT_NEAR(bf->frame_dt, 1e-3, 1e-9);
  for (std::size_t k = 0; k < bf->data.size(); ++k) EXPECT_NEAR(bf->data[k].t, 1e-3 * k, 1e-9);
  // A bad frame is skipped; no timestamps: ids over the frame rate.
  shot.burst.frames[3].status = FrameStatus::Incomplete;
  for (Frame& f : shot.burst.frames) f.timestamp_ns = 0;
  bf = prepareFrames(shot.burst, 500);
  ASSERT_TRUE(bf.ok()) << bf.error().message;
  ASSERT_EQ(bf->data.size(), shot.burst.frames.size() - 1);
  EXPECT_EQ(bf->data[3].index, 4u);
  EXPECT_NEAR(bf->data[3].t, 4 * 2e-3, 1e-12);
  EXPECT_NEAR(bf->frame_dt, 2e-3, 1e-12);
}

struct Staged {
  SimulatedShot shot;
  BurstFrames frames;
  std::array<double, 2> r_med;
  PixelScale scale;
};

Staged detectAndTrack(const ShotSpec& spec) {
  Staged s{simulateShot(spec), {}, {}, {}};
  auto bf = prepareFrames(s.shot.burst, 0);
  EXPECT_TRUE(bf.ok());
  s.frames = *bf;
  const auto& set = s.shot.settings;
  detectSpheres(s.shot.burst, s.frames.data, set.diameter_m, set.pixel_size_m, s.frames.max_value,
                {});
  auto blobs = selectSphereBlobs(s.frames.data, set.diameter_m, set.pixel_size_m);
  EXPECT_TRUE(blobs.ok());
  EXPECT_TRUE(trackSpheres(s.frames.data, *blobs, set.diameter_m).ok());
  s.r_med = trackRadii(s.frames.data);
  s.scale = {set.pixel_size_m, set.origin_u_px, set.origin_v_px};
  return s;
}

Staged detectAndTrack(std::uint64_t seed) {
  return detectAndTrack(quick(seed));
}

TEST(TrackSpheres, EachTrackFollowsItsSphere) {
  const Staged s = detectAndTrack(42);
  const double px = s.scale.px, r_true = 0.5 * s.shot.settings.diameter_m[0] / px;
  int seen = 0;
  for (std::size_t k = 0; k < s.frames.data.size(); ++k)
    for (int i = 0; i < 2; ++i) {
      const SphereMeasurement* m = trackAt(s.frames.data[k], i);
      if (!m) continue;
      ++seen;
      const Vec3& p = s.shot.states[k][i].position_m;
      EXPECT_NEAR(m->circle.u, s.scale.ou + p.x() / px, 0.2) << k << " " << i;
      EXPECT_NEAR(m->circle.v, s.scale.ov - p.y() / px, 0.2) << k << " " << i;
    }
  // Spheres merged at contact may be missed in a frame or two, no more.
  EXPECT_GE(seen, 2 * int(s.frames.data.size()) - 4);
  for (const double r : s.r_med) EXPECT_NEAR(r, r_true, 0.1);
}

TEST(RemeasureCutOutlines, CutSpheresGetTheirTracksRadiusAndCentresNoWorse) {
  // The spheres leave the frame at the ends of the burst: those outlines are
  // measured again with the radius their track's whole outlines give. Against
  // the simulation's centres: each within its stated sigma's reach, and no
  // worse than the free fits over all of them.
  ShotSpec spec = quick(43);
  spec.frames_before = 30;
  spec.frames_after = 45;
  Staged s = detectAndTrack(spec);
  std::vector<FrameData> again = s.frames.data;
  const auto& set = s.shot.settings;
  const int n = remeasureCutOutlines(s.shot.burst, again, set.diameter_m, set.pixel_size_m,
                                     s.frames.max_value, set.polarity, set.camera);
  const double px = s.scale.px, r_true = 0.5 * set.diameter_m[0] / px;
  double free_ss = 0, held_ss = 0;
  int held = 0;
  for (std::size_t k = 0; k < again.size(); ++k)
    for (int i = 0; i < 2; ++i) {
      const SphereMeasurement *before = trackAt(s.frames.data[k], i), *m = trackAt(again[k], i);
      if (!m || !m->radius_held) continue;
      ++held;
      ASSERT_TRUE(before->cut_by_border);
      EXPECT_NEAR(m->circle.radius, r_true, 0.1) << "frame " << k << " sphere " << i;
      const Vec3& p = s.shot.states[k][i].position_m;
      const double du = m->circle.u - (s.scale.ou + p.x() / px);
      const double dv = m->circle.v - (s.scale.ov - p.y() / px);
      EXPECT_LT(std::abs(du), 4 * m->circle.sigma_u + 0.02) << "frame " << k << " sphere " << i;
      EXPECT_LT(std::abs(dv), 4 * m->circle.sigma_v + 0.02) << "frame " << k << " sphere " << i;
      held_ss += du * du + dv * dv;
      free_ss += std::pow(before->circle.u - (s.scale.ou + p.x() / px), 2) +
                 std::pow(before->circle.v - (s.scale.ov - p.y() / px), 2);
    }
  EXPECT_EQ(held, n);
  ASSERT_GE(held, 5) << "the shot must have outlines cut by the border";
  std::printf("%d cut outlines: centre RMS %.4f px free, %.4f px radius held\n", held,
              std::sqrt(free_ss / held), std::sqrt(held_ss / held));
  EXPECT_LE(held_ss, free_ss);
}

// Two spheres as the detector reports them, frame by frame (no images): each
// moves at constant velocity in the image and takes its new velocity at
// frame `contact`. Candidates are listed left to right, as the detector does.
std::vector<FrameData> straightTracks(const std::array<double, 2>& r_px,
                                      const std::array<Eigen::Vector2d, 2>& start_px,
                                      const std::array<Eigen::Vector2d, 2>& before_px_frame,
                                      const std::array<Eigen::Vector2d, 2>& after_px_frame,
                                      int contact, int frames) {
  std::vector<FrameData> data(frames);
  for (int k = 0; k < frames; ++k) {
    FrameData& f = data[k];
    f.index = k;
    f.t = 1e-3 * k;
    for (int s = 0; s < 2; ++s) {
      const Eigen::Vector2d at = start_px[s] + before_px_frame[s] * std::min(k, contact) +
                                 after_px_frame[s] * std::max(0, k - contact);
      SphereMeasurement m;
      m.circle.u = at.x(), m.circle.v = at.y(), m.circle.radius = r_px[s];
      f.found.spheres.push_back(m);
    }
    if (f.found.spheres[0].circle.u > f.found.spheres[1].circle.u)
      std::swap(f.found.spheres[0], f.found.spheres[1]);
    f.candidates = {0, 1};
  }
  return data;
}

// Where each track should be in frame k: the sphere of that radius.
void expectFollowed(const std::vector<FrameData>& data, const std::array<double, 2>& r_px) {
  for (const FrameData& f : data)
    for (int s = 0; s < 2; ++s) {
      const SphereMeasurement* m = trackAt(f, s);
      ASSERT_TRUE(m) << "sphere " << s + 1 << " lost in frame " << f.index;
      EXPECT_EQ(m->circle.radius, r_px[s]) << "tracks swapped in frame " << f.index;
    }
}

// The unequal preset's lost shots: a 19 mm sphere (45 px) meeting a 25 mm one
// (60 px) almost head-on rebounds at 17 px per frame, 25 px from where its old
// velocity put it: more than half its radius, the ordinary gate. Contact
// changes a velocity by up to twice the relative velocity, and the gate near
// contact allows it.
TEST(TrackSpheres, ASphereThatReboundsAtContactIsFollowed) {
  const std::array<double, 2> r{60, 45};
  const std::array<Eigen::Vector2d, 2> start{Eigen::Vector2d(-62, 201), Eigen::Vector2d(689, 262)};
  const std::array<Eigen::Vector2d, 2> before{Eigen::Vector2d(11.05, 1.16),
                                              Eigen::Vector2d(-11.17, 1.16)};
  const std::array<Eigen::Vector2d, 2> after{Eigen::Vector2d(1.5, -3.1),
                                             Eigen::Vector2d(11.5, 13.2)};
  std::vector<FrameData> data = straightTracks(r, start, before, after, 30, 46);
  SphereBlobs blobs;
  blobs.r_expect_px = r;
  ASSERT_TRUE(trackSpheres(data, blobs, {0.0254, 0.01905}).ok());
  expectFollowed(data, r);
  EXPECT_EQ(blobs.third_blobs, 0);
}

// Equal spheres head-on exchange their velocities (e = 1): each is found
// where the other was heading, and the tracks must not swap.
TEST(TrackSpheres, EqualSpheresExchangingVelocitiesHeadOnKeepTheirTracks) {
  const std::array<double, 2> r{60, 60};
  const std::array<Eigen::Vector2d, 2> start{Eigen::Vector2d(20, 240), Eigen::Vector2d(620, 240)};
  const std::array<Eigen::Vector2d, 2> before{Eigen::Vector2d(9, 0), Eigen::Vector2d(-9, 0)};
  const std::array<Eigen::Vector2d, 2> after{Eigen::Vector2d(-9, 0), Eigen::Vector2d(9, 0)};
  // Different radii in the data only to tell the spheres apart in the check.
  const std::array<double, 2> tag{60, 59.5};
  std::vector<FrameData> data = straightTracks(tag, start, before, after, 27, 50);
  SphereBlobs blobs;
  blobs.r_expect_px = r;
  ASSERT_TRUE(trackSpheres(data, blobs, {0.0254, 0.0254}).ok());
  expectFollowed(data, tag);
}

// The tracks as a 640 x 480 camera sees them: a sphere wholly outside is not
// found, one crossing the border is cut by it; candidates left to right.
void throughAFrame(std::vector<FrameData>& data) {
  for (FrameData& f : data) {
    std::vector<SphereMeasurement> kept;
    for (SphereMeasurement m : f.found.spheres) {
      const CircleFit& c = m.circle;
      if (c.u + c.radius < 0 || c.u - c.radius > 639 || c.v + c.radius < 0 || c.v - c.radius > 479)
        continue;
      m.cut_by_border =
          c.u - c.radius < 0 || c.u + c.radius > 639 || c.v - c.radius < 0 || c.v + c.radius > 479;
      kept.push_back(m);
    }
    std::sort(kept.begin(), kept.end(),
              [](const auto& a, const auto& b) { return a.circle.u < b.circle.u; });
    f.found.spheres = kept;
    f.candidates.clear();
    for (int i = 0; i < static_cast<int>(kept.size()); ++i) f.candidates.push_back(i);
  }
}

// In every frame, whatever a track holds is its own sphere (told by radius),
// and each sphere whose outline is whole is on its track.
void expectNoSwapAndWholeOnTrack(const std::vector<FrameData>& data,
                                 const std::array<double, 2>& tag) {
  for (const FrameData& f : data)
    for (int s = 0; s < 2; ++s) {
      if (const SphereMeasurement* m = trackAt(f, s)) {
        EXPECT_EQ(m->circle.radius, tag[s]) << "sphere " << s + 1 << " frame " << f.index;
      }
      for (const SphereMeasurement& m : f.found.spheres) {
        if (m.circle.radius == tag[s] && !m.cut_by_border) {
          EXPECT_EQ(trackAt(f, s), &m) << "sphere " << s + 1 << " off its track, frame " << f.index;
        }
      }
    }
}

// Noisy lab imaging (4000 e- well, accuracy_bench on a sim-lab variant): a
// sphere entering through the border was read as one or two cut circles up to
// 30 px from where it was, the track was seeded on them and its velocity set
// by them, and the sphere's whole frames were lost to it ("sphere 1 is seen
// in 0 frames after the collision"), or the second readings were counted as
// third objects (extra_blobs_ignored).
TEST(TrackSpheres, ASphereEnteringThroughANoisyBorderIsFollowedFromItsWholeOutlines) {
  const std::array<double, 2> tag{60, 59.5};
  std::vector<FrameData> data =
      straightTracks(tag, {Eigen::Vector2d(-40, 215), Eigen::Vector2d(560, 260)},
                     {Eigen::Vector2d(4.5, 0.3), Eigen::Vector2d(-3.5, 0.4)},
                     {Eigen::Vector2d(-1.0, -1.5), Eigen::Vector2d(2.5, 3.0)}, 60, 90);
  throughAFrame(data);
  int cut = 0, doubled = 0;
  for (FrameData& f : data) {
    const std::vector<SphereMeasurement> as_seen = f.found.spheres;
    for (const SphereMeasurement& m : as_seen) {
      if (m.circle.radius != tag[0] || !m.cut_by_border) continue;
      // Misread, and every other frame read a second time elsewhere on the
      // sphere.
      SphereMeasurement& mine =
          *std::find_if(f.found.spheres.begin(), f.found.spheres.end(),
                        [&](const auto& x) { return x.circle.radius == tag[0]; });
      // Pseudo-random offsets in [-20, 20] px per axis; every fourth frame a
      // radius off by a quarter (not a candidate: a gap in the track).
      const std::uint32_t h = static_cast<std::uint32_t>(f.index) * 2654435761u;
      mine.circle.u += static_cast<double>(h % 41) - 20;
      mine.circle.v += static_cast<double>((h >> 8) % 41) - 20;
      if (f.index % 4 == 3) mine.circle.radius *= 0.75;
      ++cut;
      if (f.index % 2 == 0) {
        SphereMeasurement again = m;
        again.circle.u += 20;
        again.circle.v -= 15;
        f.found.spheres.push_back(again);
        ++doubled;
      }
    }
    // Candidates as selectSphereBlobs makes them: within 15 % of the radius.
    f.candidates.clear();
    for (int i = 0; i < static_cast<int>(f.found.spheres.size()); ++i)
      if (std::abs(f.found.spheres[i].circle.radius / 60 - 1) < 0.15) f.candidates.push_back(i);
  }
  ASSERT_GE(cut, 15) << "sphere 1 must enter through the border";
  SphereBlobs blobs;
  blobs.r_expect_px = {60, 60};
  ASSERT_TRUE(trackSpheres(data, blobs, {0.0254, 0.0254}).ok());
  expectNoSwapAndWholeOnTrack(data, tag);
  EXPECT_EQ(blobs.third_blobs, 0) << doubled << " second readings counted as third objects";
}

// Sim-lab, noisy: a sphere cut by the bottom border from the contact on, until
// it leaves the view. Its last whole outlines are from before the contact;
// the gate that widens after a contact must not let its track, once the
// sphere has gone, take the other sphere.
TEST(TrackSpheres, ASphereLeavingThroughTheBorderAfterContactDoesNotTakeTheOther) {
  const std::array<double, 2> tag{60, 59.5};
  std::vector<FrameData> data =
      straightTracks(tag, {Eigen::Vector2d(250, 280), Eigen::Vector2d(380, 400)},
                     {Eigen::Vector2d(2.8, 1.5), Eigen::Vector2d(-3.0, 1.5)},
                     {Eigen::Vector2d(2.1, 0.1), Eigen::Vector2d(-2.0, 3.5)}, 15, 80);
  throughAFrame(data);
  int gone = 0;
  for (const FrameData& f : data) gone += f.found.spheres.size() == 1;
  ASSERT_GE(gone, 10) << "sphere 2 must leave the view";
  SphereBlobs blobs;
  blobs.r_expect_px = {60, 60};
  ASSERT_TRUE(trackSpheres(data, blobs, {0.0254, 0.0254}).ok());
  expectNoSwapAndWholeOnTrack(data, tag);
  EXPECT_EQ(blobs.third_blobs, 0);
}

// Blobs on neither track are counted as third objects, but for a second
// reading centred on a tracked sphere; each rule both ways.
TEST(TrackSpheres, OnlyBlobsAwayFromBothTracksCountAsThirdObjects) {
  const std::array<double, 2> r{60, 60};
  std::vector<FrameData> data =
      straightTracks(r, {Eigen::Vector2d(100, 240), Eigen::Vector2d(540, 240)},
                     {Eigen::Vector2d(5, 0), Eigen::Vector2d(-5, 0)},
                     {Eigen::Vector2d(-5, 0), Eigen::Vector2d(5, 0)}, 32, 40);
  auto addBlob = [&](int k, double u, double v, double radius) {
    SphereMeasurement m;
    m.circle.u = u, m.circle.v = v, m.circle.radius = radius;
    data[k].found.spheres.push_back(m);
    if (std::abs(radius / 60 - 1) < 0.15)
      data[k].candidates.push_back(static_cast<int>(data[k].found.spheres.size()) - 1);
  };
  addBlob(5, 320, 420, 60);                 // sphere-sized, far from both: counted
  addBlob(8, 40, 40, 25);                   // another size, far from both: counted
  addBlob(10, 100 + 5 * 10 + 25, 255, 58);  // centred on sphere 1: a second reading
  addBlob(12, 540 - 5 * 12 - 30, 230, 40);  // on sphere 2, another size: a second reading
  addBlob(14, 100 + 5 * 14 + 65, 240, 59);  // just off sphere 1's disc: counted
  SphereBlobs blobs;
  blobs.r_expect_px = r;
  ASSERT_TRUE(trackSpheres(data, blobs, {0.0254, 0.0254}).ok());
  EXPECT_EQ(blobs.third_blobs, 3);
  auto noted = [&](int k, const std::string& what) {
    for (const std::string& n : data[k].found.notes)
      if (n.find(what) != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(noted(10, "second reading of it"));
  EXPECT_TRUE(noted(12, "centred on sphere 2"));
  EXPECT_TRUE(noted(5, "off both tracks"));
  EXPECT_TRUE(noted(8, "not a sphere of this shot"));
}

// Gravity and the air the fixture's spheres fly through, as analyzeBurst
// takes them (shot_fixture.hpp: room air, the masses given).
FreeFlight flightOf(const SimulatedShot& shot) {
  FreeFlight f;
  for (int s = 0; s < 2; ++s)
    f.drag[s] = AirDrag{shot.settings.diameter_m[s], shot.settings.mass_kg[s],
                        shot.settings.air_density_kg_m3};
  return f;
}

TEST(FitCollision, BothInstantsFindTheTrueContact) {
  for (const std::uint64_t seed : {43, 44, 45}) {
    const Staged s = detectAndTrack(seed);
    const double contact = s.shot.settings.diameter_m[0];
    auto fits = fitCollision(s.frames.data, s.scale, contact, 0.0, flightOf(s.shot), 0.0,
                             s.frames.frame_dt);
    ASSERT_TRUE(fits.ok()) << fits.error().message;
    EXPECT_NEAR(fits->t_before, s.shot.t_collision_s, 5 * fits->sigma_before + 1e-6);
    EXPECT_NEAR(fits->t_after, s.shot.t_collision_s, 5 * fits->sigma_after + 1e-6);
    for (int i = 0; i < 2; ++i)
      for (int side = 0; side < 2; ++side) {
        const SideFit& f = *fits->fit[i][side];
        EXPECT_GE(f.frames.size(), 17u);
        EXPECT_GE(f.inflation, 1.0);
        const Vec3& v_true = (side == 0 ? s.shot.before : s.shot.after)[i].velocity_m_s;
        const Estimate3 v = f.fit.velocityAt_m_s(s.shot.t_collision_s);
        for (int a = 0; a < 2; ++a)
          EXPECT_NEAR(v.value[a], v_true[a], 5 * std::sqrt(f.inflation) * v.sigma[a] + 2e-4);
      }
    // A free fit falls at g.
    const auto fall = fallAlongGravity(s.frames.data, *fits, s.scale, Eigen::Vector2d(0, 1));
    ASSERT_TRUE(fall.has_value());
    EXPECT_NEAR((*fall)[0], 9.80665, 5 * (*fall)[1] + 0.05);
  }
}

// A nearly grazing impact (83 degrees) whose fits are told a contact
// distance 1 % short of the diameter: the relative path passes d sin(83 deg)
// = 0.9927 d from the other centre, so the fits never come that close. The
// instant is then where the tracks bend (the truth's, within its sigma), and
// the shortfall is the 1 % (the fits' centres are d apart there), accepted
// when the contact distance is stated that uncertain and refused when not.
// Spheres whose tracks do not bend (the post-impact fits the pre-impact
// ones) missed each other: no instant.
TEST(FitCollision, ANearlyGrazingImpactShortOfContactIsPlacedWhereTheTracksBend) {
  ShotSpec spec = quick(48);
  spec.contact_angle_rad = 1.45;
  spec.vy_spread_m_s = 0;
  const Staged s = detectAndTrack(spec);
  const double d = s.shot.settings.diameter_m[0], short_of = 0.99 * d;
  const auto fit = [&](double contact, double contact_sigma) {
    return fitCollision(s.frames.data, s.scale, contact, contact_sigma, flightOf(s.shot), 0.0,
                        s.frames.frame_dt);
  };
  const auto reached = fit(d, 0.0);
  ASSERT_TRUE(reached.ok()) << reached.error().message;
  EXPECT_TRUE(reached->contact_reached);

  const auto kinked = fit(short_of, 100e-6);  // 254 um short: 2.5 of its sigmas
  ASSERT_TRUE(kinked.ok()) << kinked.error().message;
  EXPECT_FALSE(kinked->contact_reached);
  EXPECT_EQ(kinked->t_before, kinked->t_after);
  EXPECT_GT(kinked->sigma_before, 0.0);
  EXPECT_NEAR(kinked->t_before, s.shot.t_collision_s, 5 * kinked->sigma_before);
  EXPECT_NEAR(kinked->shortfall_m, d - short_of, 20e-6);

  const auto refused = fit(short_of, 20e-6);  // 12.7 sigmas
  ASSERT_FALSE(refused.ok());
  EXPECT_THAT(refused.error().message, HasSubstr("further apart than the contact distance"));

  CollisionFits straight = *reached;
  for (int i = 0; i < 2; ++i) straight.fit[i][1] = straight.fit[i][0];
  const Status missed = kinkInstant(straight, short_of, 100e-6);
  ASSERT_FALSE(missed.ok());
  EXPECT_THAT(missed.error().message, HasSubstr("missed"));
  EXPECT_TRUE(straight.contact_reached);  // left as it was
}

TEST(MeasureSpins, SpinsOfBothSidesMatchTheTruth) {
  const Staged s = detectAndTrack(46);
  auto fits = fitCollision(s.frames.data, s.scale, s.shot.settings.diameter_m[0], 0.0,
                           flightOf(s.shot), 0.0, s.frames.frame_dt);
  ASSERT_TRUE(fits.ok()) << fits.error().message;
  const ShotSpins spins =
      measureSpins(s.shot.burst, s.frames.data, *fits, s.r_med, s.frames.max_value, 50.0);
  ASSERT_EQ(spins.dots.size(), s.frames.data.size());
  for (int i = 0; i < 2; ++i)
    for (int side = 0; side < 2; ++side) {
      const SideSpin& sp = spins.side[i][side];
      ASSERT_FALSE(sp.unknown_reason.has_value()) << *sp.unknown_reason;
      const Vec3& w = (side == 0 ? s.shot.before : s.shot.after)[i].spin_rad_s;
      for (int a = 0; a < 3; ++a)
        EXPECT_NEAR(sp.spin[a], w[a], 5 * sp.sigma[a] + 0.05) << i << " " << side << " " << a;
    }
}

// Before the impact the launchers' spread stands in where the dots pin the
// spin less well than it (analysis/spin_prior.hpp). These dots pin it within
// 0.05 rad/s: with a spread of 50 nothing changes; with one of 0.001 every
// direction before takes it and the spins before come out within it. After
// the impact nothing changes either way.
TEST(MeasureSpins, ABeforeSpinPinnedLessWellThanTheLaunchersSpreadIsCombinedWithIt) {
  const Staged s = detectAndTrack(46);
  auto fits = fitCollision(s.frames.data, s.scale, s.shot.settings.diameter_m[0], 0.0,
                           flightOf(s.shot), 0.0, s.frames.frame_dt);
  ASSERT_TRUE(fits.ok()) << fits.error().message;
  const auto spinsWith = [&](double spread) {
    return measureSpins(s.shot.burst, s.frames.data, *fits, s.r_med, s.frames.max_value, spread);
  };
  const ShotSpins wide = spinsWith(50.0), narrow = spinsWith(0.001);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(wide.side[i][0].prior_directions, 0) << i;  // the dots pin it within 50 rad/s
    EXPECT_EQ(narrow.side[i][0].prior_directions, 3) << i;
    EXPECT_LT(narrow.side[i][0].sigma.maxCoeff(), 0.001) << i;
    EXPECT_LT(narrow.side[i][0].spin.norm(), wide.side[i][0].spin.norm()) << i;
    EXPECT_EQ(narrow.side[i][1].prior_directions, 0) << i;
    EXPECT_EQ(narrow.side[i][1].spin, wide.side[i][1].spin) << i;
    EXPECT_EQ(narrow.side[i][1].cov, wide.side[i][1].cov) << i;
  }
}

// Plain spheres show no dot: every spin is unknown, zero, with the spread the
// caller states for the launchers' spins (the rig profile's launch_spin_rad_s).
TEST(MeasureSpins, AnUnseenSpinIsZeroWithTheLaunchersSpread) {
  ShotSpec spec = quick(47);
  spec.dots = false;
  const Staged s = detectAndTrack(spec);
  const auto& set = s.shot.settings;
  auto fits = fitCollision(s.frames.data, s.scale, set.diameter_m[0], 0.0, flightOf(s.shot), 0.0,
                           s.frames.frame_dt);
  ASSERT_TRUE(fits.ok()) << fits.error().message;
  for (const double spread : {12.0, 50.0}) {
    const ShotSpins spins =
        measureSpins(s.shot.burst, s.frames.data, *fits, s.r_med, s.frames.max_value, spread);
    for (int i = 0; i < 2; ++i)
      for (int side = 0; side < 2; ++side) {
        const SideSpin& sp = spins.side[i][side];
        EXPECT_TRUE(sp.unknown_reason.has_value()) << i << " " << side;
        EXPECT_EQ(sp.spin, Vec3::Zero());
        EXPECT_TRUE(sp.cov.isApprox(Eigen::Matrix3d::Identity() * spread * spread)) << sp.cov;
        EXPECT_TRUE(sp.sigma.array().isNaN().all());
      }
    EXPECT_TRUE(poorlyMeasuredSpins(spins).empty());
  }
}

// spin_poorly_measured fires when, and only when, a measured spin's sigma on
// some axis is above kPoorlyMeasuredSpinSigma.
TEST(PoorlyMeasuredSpins, WhenAndOnlyWhenASigmaExceedsTheLimit) {
  ShotSpins spins;
  for (auto& sphere : spins.side)
    for (SideSpin& sp : sphere) sp.sigma = Vec3(3, 22, 8);
  EXPECT_TRUE(poorlyMeasuredSpins(spins).empty());
  // At the line: not above it.
  spins.side[1][1].sigma = Vec3(5, kPoorlyMeasuredSpinSigma, 5);
  EXPECT_TRUE(poorlyMeasuredSpins(spins).empty());
  // Above it on one axis of sphere 2 after the impact: one note, naming it.
  spins.side[1][1].sigma = Vec3(5, kPoorlyMeasuredSpinSigma + 1, 5);
  std::vector<std::string> notes = poorlyMeasuredSpins(spins);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("sphere 2, after"), std::string::npos) << notes[0];
  EXPECT_NE(notes[0].find("51 rad/s"), std::string::npos) << notes[0];
  // An unknown spin (its own no_spin_* flag) is not a poorly measured one.
  spins.side[1][1].unknown_reason = "no dots found";
  EXPECT_TRUE(poorlyMeasuredSpins(spins).empty());
  // Two at once: two notes.
  spins.side[0][0].sigma = Vec3(400, 20, 20);
  spins.side[1][0].sigma = Vec3(20, 20, 130);
  notes = poorlyMeasuredSpins(spins);
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_NE(notes[0].find("sphere 1, before"), std::string::npos) << notes[0];
  EXPECT_NE(notes[1].find("sphere 2, before"), std::string::npos) << notes[1];
}

}  // namespace
}  // namespace collide::vision
