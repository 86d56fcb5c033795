// Spheres followed through rendered footage (vision/render): centres against
// the drawn truth, identities of two and three spheres passing close by,
// contacts, and the polarity of backlit footage.
#include "vision/sphere_tracks.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>

#include "vision/render.hpp"

namespace collide::vision {
namespace {

/// Spheres' centres (px) at frame k; radius per sphere.
struct Scene {
  std::vector<double> radius_px;
  std::function<std::vector<Eigen::Vector2d>(int)> centres;
  int frames = 60;
  bool backlit = false;
};

FrameSource render(const Scene& sc) {
  RenderSettings rs;
  rs.format = PixelFormat::Mono12;
  rs.noise_grey = 6;
  if (sc.backlit) {
    rs.background_level = 0.85;
    rs.sphere_level = 0.12;
    rs.rim_level = 0.08;
  }
  auto renderer = std::make_shared<Renderer>(rs);
  FrameSource src;
  src.count = sc.frames;
  src.max_value = 4095;
  src.read = [renderer, sc](std::int64_t k) -> Result<Frame> {
    std::vector<SphereView> views;
    const auto c = sc.centres(static_cast<int>(k));
    for (std::size_t i = 0; i < c.size(); ++i) {
      SphereView v;
      v.centre_px = c[i];
      v.radius_px = sc.radius_px[i];
      views.push_back(v);
    }
    Frame f;
    f.id = k;
    f.timestamp_ns = k * 1000000;
    f.image = renderer->render(views, static_cast<std::uint64_t>(k));
    return f;
  };
  return src;
}

TEST(SphereTracks, OneFallingSphereIsFoundInEveryFrameAtItsDrawnCentre) {
  Scene sc;
  sc.radius_px = {20};
  sc.centres = [](int k) {
    const double t = k * 1e-3;  // 1000 frames/s, 0.25 mm/px: g = 39 227 px/s^2
    return std::vector<Eigen::Vector2d>{{100 + 1600 * t, 120 - 1200 * t + 0.5 * 39227 * t * t}};
  };
  auto tr = trackFootageSpheres(render(sc), {});
  ASSERT_TRUE(tr.ok()) << tr.error().message;
  EXPECT_EQ(tr->spheres, 1);
  ASSERT_EQ(tr->frames.size(), 60u);
  double se = 0;
  for (int k = 0; k < 60; ++k) {
    const auto& s = tr->frames[k].spheres[0];
    ASSERT_TRUE(s.found) << "frame " << k;
    se += (Eigen::Vector2d(s.u_px, s.v_px) - sc.centres(k)[0]).squaredNorm();
  }
  EXPECT_LT(std::sqrt(se / 60), 0.05);
  EXPECT_NEAR(tr->radius_px[0], 20, 0.1);
}

// Two spheres pass each other 6 px apart (outline to outline) going opposite
// ways; a third rises to 5 px below the lower one as it passes over, and falls
// back: each keeps its number throughout.
TEST(SphereTracks, TwoAndThreeSpheresKeepTheirIdentitiesPassingClose) {
  Scene sc;
  sc.radius_px = {18, 18, 15};
  sc.frames = 80;
  auto truth = [](int k) {
    const double s = k - 54;
    return std::vector<Eigen::Vector2d>{{320 - 200 + 5 * k, 200},       // left to right
                                        {320 + 200 - 5 * k, 200 + 42},  // right to left, below
                                        {250 + 0.5 * s, 280 + 0.05 * s * s}};
  };
  sc.centres = truth;
  for (const int n : {2, 3}) {
    Scene s2 = sc;
    s2.radius_px.resize(n);
    s2.centres = [truth, n](int k) {
      auto c = truth(k);
      c.resize(n);
      return c;
    };
    SphereTrackSettings set;
    auto tr = trackFootageSpheres(render(s2), set);
    ASSERT_TRUE(tr.ok()) << tr.error().message;
    ASSERT_EQ(tr->spheres, n) << "automatic count";
    // Sphere 1 is the leftmost at the seed frame, and so on.
    const auto at_seed = s2.centres(static_cast<int>(tr->seed_index));
    std::vector<int> drawn(n);
    for (int i = 0; i < n; ++i) drawn[i] = i;
    std::sort(drawn.begin(), drawn.end(),
              [&](int a, int b) { return at_seed[a].x() < at_seed[b].x(); });
    for (const auto& f : tr->frames)
      for (int i = 0; i < n; ++i) {
        const auto& s = f.spheres[i];
        ASSERT_TRUE(s.found) << n << " spheres, frame " << f.index << ", sphere " << i + 1;
        const Eigen::Vector2d truth_c = s2.centres(static_cast<int>(f.index))[drawn[i]];
        EXPECT_LT((Eigen::Vector2d(s.u_px, s.v_px) - truth_c).norm(), 0.5)
            << n << " spheres, frame " << f.index << ": sphere " << i + 1 << " swapped or lost";
      }
  }
}

TEST(SphereTracks, SpheresThatTouchAreMarkedInContact) {
  Scene sc;
  sc.radius_px = {20, 20};
  sc.frames = 40;
  // Head-on along u, touching at frame 20 (centres 40 px apart), elastic.
  sc.centres = [](int k) {
    const double d = std::abs(k - 20) * 6.0;
    return std::vector<Eigen::Vector2d>{{300 - 20 - d, 240}, {300 + 20 + d, 240}};
  };
  auto tr = trackFootageSpheres(render(sc), {});
  ASSERT_TRUE(tr.ok()) << tr.error().message;
  ASSERT_EQ(tr->spheres, 2);
  // Touching at frame 20; two frames away the gap (24 px) is twice a frame's
  // relative motion (12 px): no contact. (Frames 19 and 21, one frame's motion
  // apart, are on the margin and may go either way.)
  for (const auto& f : tr->frames) {
    if (std::abs(f.index - 20) == 1) continue;
    const bool touching = f.index == 20;
    EXPECT_EQ(f.spheres[0].contact, touching) << "frame " << f.index;
    EXPECT_EQ(f.spheres[1].contact, touching) << "frame " << f.index;
  }
}

TEST(SphereTracks, BacklitFootageNeedsTheRightPolarity) {
  Scene sc;
  sc.radius_px = {20};
  sc.backlit = true;
  sc.frames = 20;
  sc.centres = [](int k) { return std::vector<Eigen::Vector2d>{{200 + 3 * k, 200 + 2 * k}}; };
  SphereTrackSettings set;
  auto tr = trackFootageSpheres(render(sc), set);  // auto
  ASSERT_TRUE(tr.ok()) << tr.error().message;
  EXPECT_TRUE(tr->dark_spheres);
  EXPECT_NEAR(tr->frames[5].spheres[0].u_px, 215, 0.05);
  set.detector.polarity = SphereDetectorSettings::Polarity::Dark;
  tr = trackFootageSpheres(render(sc), set);
  ASSERT_TRUE(tr.ok()) << tr.error().message;
  EXPECT_NEAR(tr->frames[5].spheres[0].v_px, 210, 0.05);
  set.detector.polarity = SphereDetectorSettings::Polarity::Bright;
  tr = trackFootageSpheres(render(sc), set);
  ASSERT_FALSE(tr.ok()) << "a bright-sphere search found " << tr->spheres << " in backlit frames";
  EXPECT_NE(tr.error().message.find("no sphere found"), std::string::npos) << tr.error().message;
  EXPECT_NE(tr.error().message.find("polarity bright"), std::string::npos) << tr.error().message;
}

TEST(SphereTracks, AskingForMoreSpheresThanAreApartFails) {
  Scene sc;
  sc.radius_px = {20};
  sc.frames = 10;
  sc.centres = [](int k) { return std::vector<Eigen::Vector2d>{{200 + 3 * k, 200}}; };
  SphereTrackSettings set;
  set.spheres = 2;
  auto tr = trackFootageSpheres(render(sc), set);
  ASSERT_FALSE(tr.ok());
  EXPECT_NE(tr.error().message.find("never 2 separate spheres"), std::string::npos);
}

// Frames are read in order, once each, and detected a batch at a time on
// every core: the tracks are the same on one thread and on two, across
// several batches (16 frames each on two cores) and with an unreadable frame.
TEST(SphereTracks, TheSameTracksOnOneThreadAndOnTwoFramesReadOnceInOrder) {
  Scene sc;
  sc.radius_px = {18, 18};
  sc.frames = 70;
  sc.centres = [](int k) {
    return std::vector<Eigen::Vector2d>{{80 + 4.0 * k, 150 + 0.02 * k * k},
                                        {560 - 4.0 * k, 300 - 1.5 * k + 0.02 * k * k}};
  };
  const auto track = [&](const char* threads, std::vector<std::int64_t>& reads,
                         std::vector<int>& progress, std::size_t batch_bytes = 256 << 20) {
    setenv("COLLIDE_THREADS", threads, 1);
    FrameSource src = render(sc);
    const auto draw = src.read;
    src.read = [&reads, draw](std::int64_t k) -> Result<Frame> {
      reads.push_back(k);
      if (k == 17) return fail("frame 17: unreadable on purpose");
      return draw(k);
    };
    SphereTrackSettings set;
    set.batch_bytes = batch_bytes;
    auto tr = trackFootageSpheres(src, set, [&](int done, int total) {
      EXPECT_EQ(total, 70);
      progress.push_back(done);
    });
    unsetenv("COLLIDE_THREADS");
    return tr;
  };
  std::vector<std::int64_t> reads1, reads2, reads3;
  std::vector<int> progress1, progress2, progress3;
  auto one = track("1", reads1, progress1);
  auto two = track("2", reads2, progress2);
  // Batches cut by their bytes: one frame per core.
  auto small = track("2", reads3, progress3, 1);
  ASSERT_TRUE(one.ok()) << one.error().message;
  ASSERT_TRUE(two.ok()) << two.error().message;
  ASSERT_TRUE(small.ok()) << small.error().message;
  for (const auto* reads : {&reads1, &reads2, &reads3}) {
    ASSERT_EQ(reads->size(), 70u);
    for (std::size_t k = 0; k < reads->size(); ++k) EXPECT_EQ((*reads)[k], k);
  }
  for (const auto* progress : {&progress1, &progress2, &progress3}) {
    ASSERT_FALSE(progress->empty());
    EXPECT_TRUE(std::is_sorted(progress->begin(), progress->end()));
    EXPECT_EQ(progress->back(), 70);
  }
  // Two frames a batch on two cores, sixteen with the default.
  EXPECT_GE(progress3.size(), progress2.size() * 4);
  for (const SphereTracks* tr : {&*one, &*two, &*small}) {
    EXPECT_EQ(tr->frames_unreadable, 1);
    ASSERT_EQ(tr->spheres, 2);
    ASSERT_EQ(tr->frames.size(), 69u);
  }
  int found = 0;
  for (std::size_t f = 0; f < one->frames.size(); ++f) {
    const TrackFrame& a = one->frames[f];
    EXPECT_NE(a.index, 17);
    ASSERT_EQ(a.spheres.size(), 2u);
    for (const SphereTracks* tr : {&*two, &*small}) {
      const TrackFrame& b = tr->frames[f];
      EXPECT_EQ(a.index, b.index);
      ASSERT_EQ(b.spheres.size(), 2u);
      for (int s = 0; s < 2; ++s) {
        EXPECT_EQ(a.spheres[s].found, b.spheres[s].found) << "frame " << a.index;
        EXPECT_EQ(a.spheres[s].u_px, b.spheres[s].u_px) << "frame " << a.index;
        EXPECT_EQ(a.spheres[s].v_px, b.spheres[s].v_px) << "frame " << a.index;
        EXPECT_EQ(a.spheres[s].radius_px, b.spheres[s].radius_px) << "frame " << a.index;
      }
    }
    for (int s = 0; s < 2; ++s) {
      if (!a.spheres[s].found) continue;
      ++found;
      // And where they were drawn.
      const Eigen::Vector2d truth = sc.centres(static_cast<int>(a.index))[s];
      EXPECT_LT((Eigen::Vector2d(a.spheres[s].u_px, a.spheres[s].v_px) - truth).norm(), 0.1)
          << "frame " << a.index << " sphere " << s;
    }
  }
  EXPECT_EQ(found, 2 * 69);
}

}  // namespace
}  // namespace collide::vision
