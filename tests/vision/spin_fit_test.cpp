// Spin from dots: synthetic dot positions from a known constant spin (exact
// rotations plus Gaussian noise of known size), so the estimate and its stated
// uncertainty can be checked against the truth; and rendered frames end to end.
#include "vision/spin_fit.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <random>

#include "vision/dot_detector.hpp"
#include "vision/render.hpp"

namespace collide::vision {
namespace {

Vec3 randomUnit(std::mt19937_64& rng) {
  std::normal_distribution<double> nd;
  return Vec3(nd(rng), nd(rng), nd(rng)).normalized();
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

struct Truth {
  Vec3 spin;
  std::vector<SpinFrame> frames;
};

// `dots` random body dots, seen when z > 0.15, with tangent noise sigma / z
// (what lifting does to isotropic image noise, roughly) and weights z^2.
// track_bias > 0: each dot is also seen displaced by its own constant image
// offset of that standard deviation per axis (a centroid bias from the dot's
// shading that changes little as it turns).
Truth synthetic(std::mt19937_64& rng, double rate, int frames, int dots, double sigma,
                double dt = 1e-3, int spurious_per_frame = 0, double track_bias = 0) {
  std::normal_distribution<double> nd;
  std::uniform_real_distribution<double> uni(0, 1);
  Truth t;
  t.spin = randomUnit(rng) * rate;
  std::vector<Vec3> body;
  std::vector<Eigen::Vector2d> bias;
  for (int i = 0; i < dots; ++i) {
    body.push_back(randomUnit(rng));
    // No draws without a bias: the other tests keep their random sequences.
    bias.push_back(track_bias > 0 ? Eigen::Vector2d(track_bias * nd(rng), track_bias * nd(rng))
                                  : Eigen::Vector2d::Zero());
  }
  const Eigen::Matrix3d q0 =
      Eigen::Quaterniond(nd(rng), nd(rng), nd(rng), nd(rng)).normalized().toRotationMatrix();
  double time = 0.0123;
  for (int k = 0; k < frames; ++k) {
    SpinFrame f;
    f.t_s = time;
    const double a = t.spin.norm() * (time - 0.0123);
    const Eigen::Matrix3d rot = Eigen::AngleAxisd(a, t.spin.normalized()).toRotationMatrix() * q0;
    for (std::size_t j = 0; j < body.size(); ++j) {
      const Vec3 p = rot * body[j];
      if (p.z() < 0.15) continue;
      // Isotropic noise in the image plane, then lifted back onto the sphere.
      const double x = p.x() + bias[j].x() + sigma * nd(rng);
      const double y = p.y() + bias[j].y() + sigma * nd(rng);
      f.dots.push_back(Vec3(x, y, std::sqrt(std::max(0.0, 1 - x * x - y * y))));
      f.weights.push_back(1.0);
    }
    for (int s = 0; s < spurious_per_frame; ++s) {
      Vec3 x = randomUnit(rng);
      if (x.z() < 0) x.z() = -x.z();
      f.dots.push_back(x);
      f.weights.push_back(1.0);
    }
    t.frames.push_back(f);
    time += dt * (k % 7 == 3 ? 2.0 : 1.0);  // a dropped frame now and then
  }
  return t;
}

TEST(FitSpin, RecoversTheSpinWithHonestUncertainties) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> uni(0, 1);
  double pull2[3] = {0, 0, 0}, pull_sum[3] = {0, 0, 0};
  const int trials = 200;
  for (int t = 0; t < trials; ++t) {
    const Truth tr = synthetic(rng, 20 + 130 * uni(rng), 12 + t % 14, 20, 0.002);
    auto fit = fitSpin(tr.frames);
    ASSERT_TRUE(fit.ok()) << fit.error().message;
    for (int i = 0; i < 3; ++i) {
      const double p = (fit->spin_rad_s[i] - tr.spin[i]) / fit->sigma_rad_s[i];
      pull2[i] += p * p;
      pull_sum[i] += p;
    }
  }
  for (int i = 0; i < 3; ++i) {
    const double rms = std::sqrt(pull2[i] / trials), mean = pull_sum[i] / trials;
    std::printf("axis %d: pull RMS %.3f, mean %+.3f\n", i, rms, mean);
    // 200 trials: the RMS of unit pulls is known to ~5 %, the mean to ~0.07.
    EXPECT_GT(rms, 0.85);
    EXPECT_LT(rms, 1.15);
    EXPECT_LT(std::abs(mean), 0.25);
  }
}

// Each dot carries its own constant centroid bias, larger than the noise: the
// residuals along a track hardly show it, but each track then turns with a
// slightly wrong spin, and the tracks disagree. The stated sigmas still cover
// the error (the tracks' jackknife spread enters them); on the fit's
// residuals alone the pulls came out at about 3.
TEST(FitSpin, DotsWithTheirOwnBiasStillGiveHonestUncertainties) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> uni(0, 1);
  Pulls pulls[3];
  const int trials = 200;
  for (int t = 0; t < trials; ++t) {
    const Truth tr =
        synthetic(rng, 20 + 130 * uni(rng), 12 + t % 14, 20, 0.002, 1e-3, 0, /*track_bias=*/0.006);
    auto fit = fitSpin(tr.frames);
    ASSERT_TRUE(fit.ok()) << fit.error().message;
    for (int i = 0; i < 3; ++i) pulls[i].add(fit->spin_rad_s[i] - tr.spin[i], fit->sigma_rad_s[i]);
  }
  for (int i = 0; i < 3; ++i) {
    std::printf("axis %d: pull RMS %.3f\n", i, pulls[i].rms());
    EXPECT_GT(pulls[i].rms(), 0.7);
    EXPECT_LT(pulls[i].rms(), 1.5);
  }
}

TEST(FitSpin, FastSpinSpuriousDotsAndGaps) {
  std::mt19937_64 rng(2);
  for (int t = 0; t < 20; ++t) {
    // 400 rad/s at 1000 frames/s: 0.4 rad between frames, more than the dots'
    // spacing, so only the pair search can match the first frames.
    const Truth tr = synthetic(rng, 400, 15, 20, 0.002, 1e-3, 1);
    auto fit = fitSpin(tr.frames);
    ASSERT_TRUE(fit.ok()) << fit.error().message;
    EXPECT_LT((fit->spin_rad_s - tr.spin).norm(), 0.005 * tr.spin.norm());
  }
}

TEST(FitSpin, TwoDotsPerFrameStillGiveTheSpin) {
  std::mt19937_64 rng(5);
  for (int t = 0; t < 20; ++t) {
    Truth tr = synthetic(rng, 60, 20, 20, 0.001);
    // Keep two dots per frame (the two nearest the line of sight).
    for (auto& f : tr.frames) {
      std::vector<std::size_t> idx(f.dots.size());
      std::iota(idx.begin(), idx.end(), 0);
      std::sort(idx.begin(), idx.end(),
                [&](auto a, auto b) { return f.dots[a].z() > f.dots[b].z(); });
      std::vector<Vec3> keep;
      for (std::size_t i = 0; i < std::min<std::size_t>(2, idx.size()); ++i)
        keep.push_back(f.dots[idx[i]]);
      f.dots = keep;
      f.weights.assign(keep.size(), 1.0);
    }
    auto fit = fitSpin(tr.frames);
    ASSERT_TRUE(fit.ok()) << fit.error().message;
    EXPECT_LT((fit->spin_rad_s - tr.spin).norm(), 5 * fit->sigma_rad_s.norm() + 0.01 * 60);
  }
}

// Two dots a frame but three in two frames: the pairs with two matches must
// count as well. These are the dots lifted from a lab-imaging shot
// (accuracy_bench --preset lab --seed 7, shot 18, sphere 2 after the impact,
// leaving through the frame's bottom border; rounded to 0.001), whose true
// spin the simulation knows: (2.848, 8.991, -93.121) rad/s. The one pair with
// three dots was the only one matched, and a spin from one pair was too rough
// to grow the tracks from: it came out at (-0.1, 11.2, -80.5) rad/s.
TEST(FitSpin, TwoDotsAfterAPairOfThreeStillGiveTheSpin) {
  const std::vector<std::pair<double, std::vector<Vec3>>> seen = {
      {0.03000, {{0.288, 0.576, 0.765}, {-0.331, -0.027, 0.943}}},
      {0.03050, {{0.318, 0.562, 0.763}, {-0.327, -0.013, 0.945}, {0.648, -0.351, 0.675}}},
      {0.03100, {{0.346, 0.547, 0.762}, {-0.324, 0.002, 0.946}, {0.686, -0.301, 0.662}}},
      {0.03150, {{0.377, 0.531, 0.759}, {-0.317, 0.016, 0.948}}},
      {0.03200, {{0.402, 0.510, 0.760}, {-0.313, 0.027, 0.949}}},
      {0.03250, {{0.432, 0.488, 0.759}, {-0.306, 0.039, 0.951}}},
      {0.03300, {{0.456, 0.467, 0.757}, {-0.299, 0.052, 0.953}}},
      {0.03350, {{0.483, 0.443, 0.755}, {-0.290, 0.062, 0.955}}},
      {0.03400, {{0.505, 0.421, 0.753}, {-0.283, 0.076, 0.956}}},
      {0.03450, {{0.528, 0.395, 0.752}, {-0.274, 0.086, 0.958}}},
      {0.03500, {{0.549, 0.370, 0.750}, {-0.264, 0.097, 0.960}}},
      {0.03550, {{0.569, 0.342, 0.748}, {-0.254, 0.107, 0.961}}},
      {0.03600, {{0.589, 0.314, 0.745}, {-0.243, 0.117, 0.963}}},
      {0.03750, {{0.636, 0.224, 0.739}, {-0.210, 0.146, 0.967}}},
      {0.03800, {{0.648, 0.193, 0.737}, {-0.198, 0.155, 0.968}}},
      {0.03850, {{0.660, 0.162, 0.734}, {-0.187, 0.164, 0.969}}},
      {0.03900, {{-0.172, 0.172, 0.970}, {0.672, 0.128, 0.730}}},
      {0.03950, {{-0.159, 0.179, 0.971}, {0.682, 0.094, 0.725}}},
      {0.04000, {{-0.148, 0.184, 0.972}, {0.692, 0.058, 0.720}}},
      {0.04050, {{-0.133, 0.192, 0.972}, {0.701, 0.026, 0.713}}},
      {0.04100, {{-0.121, 0.197, 0.973}, {0.706, -0.006, 0.708}}},
      {0.04150, {{-0.108, 0.201, 0.974}, {0.707, -0.041, 0.706}}},
      {0.04200, {{-0.095, 0.206, 0.974}, {0.710, -0.074, 0.701}}},
      {0.04250, {{-0.082, 0.207, 0.975}, {0.707, -0.110, 0.699}}},
      {0.04300, {{-0.069, 0.212, 0.975}}},
      {0.04350, {{-0.055, 0.211, 0.976}}},
      {0.04400, {{-0.042, 0.214, 0.976}}},
      {0.04700, {{-0.462, 0.796, 0.391}}},
      {0.04750, {{-0.423, 0.816, 0.394}}},
      {0.04800, {{-0.383, 0.834, 0.397}}},
      {0.04850, {{-0.342, 0.848, 0.404}}},
  };
  std::vector<SpinFrame> frames;
  for (const auto& [t, dots] : seen) {
    SpinFrame f;
    f.t_s = t;
    for (const Vec3& d : dots) f.dots.push_back(d.normalized());
    frames.push_back(f);
  }
  const Vec3 truth(2.848, 8.991, -93.121);
  auto fit = fitSpin(frames);
  ASSERT_TRUE(fit.ok()) << fit.error().message;
  const Vec3 err = fit->spin_rad_s - truth;
  std::printf("spin (%.2f %.2f %.2f) rad/s, error (%.2f %.2f %.2f), sigma (%.2f %.2f %.2f)\n",
              fit->spin_rad_s.x(), fit->spin_rad_s.y(), fit->spin_rad_s.z(), err.x(), err.y(),
              err.z(), fit->sigma_rad_s.x(), fit->sigma_rad_s.y(), fit->sigma_rad_s.z());
  EXPECT_LT(err.norm(), 0.02 * truth.norm());
  for (int i = 0; i < 3; ++i) EXPECT_LT(std::abs(err[i]), 4 * fit->sigma_rad_s[i]) << "axis " << i;
}

TEST(FitSpin, OneDotFollowedOverFramesGivesTheSpin) {
  // A single dot in view at a time: its path on the sphere still fixes the
  // spin, less well; the stated uncertainty must cover the error.
  std::mt19937_64 rng(6);
  Pulls p;
  for (int t = 0; t < 40; ++t) {
    Truth tr = synthetic(rng, 40, 30, 20, 0.002);
    // Keep the dot nearest the line of sight in the first frame, followed by
    // its true identity: the one nearest its predicted place.
    Vec3 d = tr.frames[0].dots[0];
    for (const Vec3& x : tr.frames[0].dots)
      if (x.z() > d.z()) d = x;
    std::vector<SpinFrame> one;
    for (std::size_t k = 0; k < tr.frames.size(); ++k) {
      if (k > 0) {
        const double dt = tr.frames[k].t_s - tr.frames[k - 1].t_s;
        d = Eigen::AngleAxisd(tr.spin.norm() * dt, tr.spin.normalized()) * d;
      }
      int best = -1;
      for (std::size_t i = 0; i < tr.frames[k].dots.size(); ++i)
        if (best < 0 || tr.frames[k].dots[i].dot(d) > tr.frames[k].dots[best].dot(d))
          best = static_cast<int>(i);
      if (best < 0 || tr.frames[k].dots[best].dot(d) < std::cos(0.02)) break;
      SpinFrame f;
      f.t_s = tr.frames[k].t_s;
      f.dots = {tr.frames[k].dots[best]};
      one.push_back(f);
    }
    if (one.size() < 10) continue;
    auto fit = fitSpin(one);
    ASSERT_TRUE(fit.ok()) << fit.error().message;
    for (int i = 0; i < 3; ++i) p.add(fit->spin_rad_s[i] - tr.spin[i], fit->sigma_rad_s[i]);
  }
  std::printf("one dot: %d components, pull RMS %.2f\n", p.n, p.rms());
  EXPECT_GT(p.n, 30);
  EXPECT_GT(p.rms(), 0.6);
  EXPECT_LT(p.rms(), 1.6);
}

TEST(FitSpin, Errors) {
  std::mt19937_64 rng(3);
  Truth tr = synthetic(rng, 50, 5, 20, 0.001);
  EXPECT_FALSE(fitSpin({tr.frames[0]}).ok());
  std::vector<SpinFrame> backwards{tr.frames[1], tr.frames[0]};
  EXPECT_FALSE(fitSpin(backwards).ok());
  // No dots at all: nothing to follow.
  for (auto& f : tr.frames) {
    f.dots.clear();
    f.weights.clear();
  }
  auto r = fitSpin(tr.frames);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("no dot"), std::string::npos) << r.error().message;
}

// Issue 4 §3: spin within 2 % of |omega| for |omega| >= 50 rad/s at 1000
// frames/s, 640 x 480, 120 px spheres, noise 2, from rendered frames.
TEST(FitSpin, RenderedFramesMeetTheSpinTarget) {
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> uni(0, 1);
  const SphereDetector det;
  for (int t = 0; t < 6; ++t) {
    RenderSettings rs;
    rs.noise_grey = 2;
    rs.exposure_s = 200e-6;
    rs.noise_seed = 40 + t;
    const Renderer ren(rs);
    const DotPattern pat = DotPattern::random(90 + t);
    const Vec3 spin = randomUnit(rng) * (50 + 100 * uni(rng));
    const Quat q0(Eigen::AngleAxisd(uni(rng) * 6, randomUnit(rng)));
    std::vector<SpinFrame> frames;
    for (int k = 0; k < 20; ++k) {
      const double time = k * 1e-3;
      SphereView v;
      v.radius_px = 60;
      v.centre_px = {120 + 9000 * time, 240 - 1000 * time};
      v.velocity_px_s = {9000, -1000};
      v.spin_rad_s = spin;
      v.orientation = Quat(Eigen::AngleAxisd(spin.norm() * time, spin.normalized())) * q0;
      v.dots = &pat;
      const cv::Mat img = ren.render({v}, k);
      const FrameSpheres fs = det.detect(img, 255);
      ASSERT_EQ(fs.spheres.size(), 1u);
      const DotFrame df = findDots(img, fs.spheres[0], 255);
      SpinFrame f;
      f.t_s = time;
      for (const Dot& d : df.dots) f.dots.push_back(d.on_sphere), f.weights.push_back(d.weight);
      f.centre_sigma =
          1.2 * std::max(fs.spheres[0].circle.sigma_u, fs.spheres[0].circle.sigma_v) / 60;
      frames.push_back(f);
    }
    auto fit = fitSpin(frames);
    ASSERT_TRUE(fit.ok()) << fit.error().message;
    const double rel = (fit->spin_rad_s - spin).norm() / spin.norm();
    std::printf("|w| %.1f rad/s: error %.4f %% (sigma %.3f rad/s), %d tracks\n", spin.norm(),
                100 * rel, fit->sigma_rad_s.norm(), fit->tracks);
    EXPECT_LT(rel, 0.02);
  }
}

}  // namespace
}  // namespace collide::vision
