#include "vision/shot_analysis.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <random>
#include <set>
#include <string>

#include "analysis/error_model.hpp"
#include "analysis/rotation.hpp"
#include "vision/dot_detector.hpp"
#include "vision/sphere_detector.hpp"
#include "vision/spin_fit.hpp"

namespace collide::vision {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kG = 9.80665;

// Systematic uncertainties, calibrated on simulated shots (rendered with dots,
// blur and noise; tests/vision/shot_analysis_test.cpp checks the pulls).
// Dots passing near the limb shift the measured centre by a few thousandths
// of a pixel, slowly, as the sphere turns: an error correlated from frame to
// frame that the fits' residuals cannot reveal. It is carried as a random
// drift of the centre over each track, and a random offset of each sphere's
// centre, of this RMS:
// In pixels, 0.22 / radius: 0.004 px for 60 px spheres, 0.012 px at the
// thesis' 18.5 px (where a dot covers more of the limb's few edge points).
double systematicCentrePx(double radius_px) {
  return 0.22 / radius_px;
}
// The spin fits' scatter-based uncertainties fall short by about this factor
// for the same reason (slowly changing dot-centroid errors).
constexpr double kSpinSigmaScale = 1.25;
// Standard deviation given to each component of a spin that could not be
// measured (no dot followed), rad/s.
constexpr double kUnknownSpinSigma = 50.0;

std::string fmt(const char* spec, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, spec, v);
  return buf;
}

// ------------------------------------------------------------------ tracks

// One analysed (good) frame.
struct FrameData {
  std::size_t index = 0;  // in burst.frames
  double t = 0;           // s, from the first analysed frame
  FrameSpheres found;
  std::vector<int> candidates;          // indices into found.spheres of sphere-like blobs
  std::array<int, 2> assigned{-1, -1};  // found.spheres index per track
};

const SphereMeasurement* trackAt(const FrameData& f, int track) {
  return f.assigned[track] >= 0 ? &f.found.spheres[f.assigned[track]] : nullptr;
}

// Position of `track` predicted at time t from its last two (or one) points.
bool predict(const std::vector<FrameData>& frames, const std::vector<int>& order, int upto,
             int track, double t, Eigen::Vector2d& out) {
  int seen = 0;
  Eigen::Vector2d p[2];
  double tt[2] = {0, 0};
  for (int i = upto; i >= 0 && seen < 2; --i) {
    const FrameData& f = frames[order[i]];
    if (const SphereMeasurement* m = trackAt(f, track)) {
      p[seen] = {m->circle.u, m->circle.v};
      tt[seen] = f.t;
      ++seen;
    }
  }
  if (seen == 0) return false;
  if (seen == 1 || tt[0] == tt[1]) {
    out = p[0];
    return true;
  }
  out = p[0] + (p[0] - p[1]) * ((t - tt[0]) / (tt[0] - tt[1]));
  return true;
}

// Assigns each frame's candidates to the two tracks, walking away from the
// seed frame in the given direction.
void track(std::vector<FrameData>& frames, int seed, int dir, double gate) {
  std::vector<int> order;  // frames in walking order, seed first
  for (int i = seed; i >= 0 && i < static_cast<int>(frames.size()); i += dir) order.push_back(i);
  for (std::size_t o = 1; o < order.size(); ++o) {
    FrameData& f = frames[order[o]];
    Eigen::Vector2d pred[2];
    bool have[2];
    for (int k = 0; k < 2; ++k)
      have[k] = predict(frames, order, static_cast<int>(o) - 1, k, f.t, pred[k]);
    // Best assignment of up to one candidate per track (cost: distance to the
    // prediction; leaving a track empty costs the gate).
    double best = 2 * gate + 1;
    std::array<int, 2> pick{-1, -1};
    const int n = static_cast<int>(f.candidates.size());
    for (int a = -1; a < n; ++a)
      for (int b = -1; b < n; ++b) {
        if (a >= 0 && a == b) continue;
        double cost = 0;
        bool ok = true;
        for (int k = 0; k < 2; ++k) {
          const int c = k == 0 ? a : b;
          if (c < 0) {
            cost += gate;
            continue;
          }
          if (!have[k]) {
            ok = false;
            break;
          }
          const CircleFit& cf = f.found.spheres[f.candidates[c]].circle;
          const double d = (Eigen::Vector2d(cf.u, cf.v) - pred[k]).norm();
          if (d > gate) {
            ok = false;
            break;
          }
          cost += d;
        }
        if (ok && cost < best) best = cost, pick = {a, b};
      }
    for (int k = 0; k < 2; ++k) f.assigned[k] = pick[k] >= 0 ? f.candidates[pick[k]] : -1;
  }
}

double median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// ------------------------------------------------------------ fits & draws

struct SideFit {
  TrajectoryFit fit;
  std::vector<int> frames;  // indices into the FrameData vector
  /// Variance inflation for residuals correlated from frame to frame:
  /// (1 + rho) / (1 - rho), rho their lag-1 autocorrelation (Bartlett): the
  /// fit's covariance assumes independent frames, and neighbouring frames
  /// share slowly changing detection errors (dots near the limb, blur).
  double inflation = 1;
};

// Lag-1 autocorrelation of a fit's normalised residuals, pooled over the axes.
double residualInflation(const TrajectoryFit& fit) {
  double num = 0, den = 0;
  for (int k = 0; k < 2; ++k) {
    const LinearFit& af = fit.axisFit(k);
    const Eigen::VectorXd z = af.residuals.cwiseProduct(af.weights.cwiseSqrt());
    for (Eigen::Index i = 0; i < z.size(); ++i) {
      den += z[i] * z[i];
      if (i > 0) num += z[i] * z[i - 1];
    }
  }
  if (!(den > 0)) return 1;
  const double rho = std::clamp(num / den, 0.0, 0.8);
  return (1 + rho) / (1 - rho);
}

// Fits one sphere's centres over `frames` (metres, world axes), dropping
// frames that lie far off the fit (more than 5 robust sigmas) once.
Result<SideFit> fitSide(const std::vector<FrameData>& data, std::vector<int> frames, int sphere,
                        double px, double ou, double ov, const Vec3& gravity, bool fix_gravity,
                        double t_ref) {
  for (int round = 0; round < 2; ++round) {
    const int n = static_cast<int>(frames.size());
    Eigen::VectorXd t(n), w(n);
    Eigen::MatrixXd pos(n, 2);
    for (int i = 0; i < n; ++i) {
      const FrameData& f = data[frames[i]];
      const SphereMeasurement& m = *trackAt(f, sphere);
      t[i] = f.t;
      pos(i, 0) = (m.circle.u - ou) * px;
      pos(i, 1) = -(m.circle.v - ov) * px;
      const double sig = std::max({m.circle.sigma_u, m.circle.sigma_v, 1e-4});
      w[i] = 1.0 / (sig * sig);
    }
    TrajectoryOptions opt;
    if (fix_gravity) opt.fixed_acceleration_m_s2 = gravity;
    auto fit = fitTrajectory(t, pos, Weights::relative(w), t_ref, opt);
    if (!fit) return fit.error();
    if (round == 1 || n <= 4) return SideFit{*fit, frames, residualInflation(*fit)};
    // Normalised residuals; drop gross outliers (a mis-measured frame).
    std::vector<double> z(n);
    for (int i = 0; i < n; ++i) {
      double r2 = 0;
      for (int k = 0; k < 2; ++k) {
        const double r = fit->axisFit(k).residuals[i];
        r2 += r * r;
      }
      z[i] = std::sqrt(r2 * w[i]);
    }
    const double med = median(z);
    std::vector<int> keep;
    for (int i = 0; i < n; ++i)
      if (z[i] <= std::max(5.0 * med / 1.1774, 1e-12)) keep.push_back(frames[i]);
    if (keep.size() == frames.size() || keep.size() < 4)
      return SideFit{*fit, frames, residualInflation(*fit)};
    frames = keep;
  }
  return fail("unreachable");
}

// A trajectory fit with its coefficients drawn from their covariance.
struct DrawnFit {
  double t_ref = 0;
  std::array<Eigen::Vector3d, 2> c;
  Eigen::Vector2d pos(double t) const {
    const double tau = t - t_ref;
    return {c[0][0] + c[0][1] * tau + c[0][2] * tau * tau,
            c[1][0] + c[1][1] * tau + c[1][2] * tau * tau};
  }
  Eigen::Vector2d vel(double t) const {
    const double tau = t - t_ref;
    return {c[0][1] + 2 * c[0][2] * tau, c[1][1] + 2 * c[1][2] * tau};
  }
};

DrawnFit drawFit(const TrajectoryFit& f, double inflation, double drift_m_s, double offset_m,
                 std::mt19937_64& rng, bool nominal) {
  std::normal_distribution<double> nd;
  DrawnFit d;
  d.t_ref = f.tRef_s();
  const int np = f.accelerationFixed() ? 2 : 3;
  for (int k = 0; k < 2; ++k) {
    d.c[k] = f.coefficients(k);
    if (nominal) continue;
    const Eigen::MatrixXd cov = f.covariance(k).topLeftCorner(np, np) * inflation;
    if (!cov.allFinite()) continue;
    const Eigen::LLT<Eigen::MatrixXd> llt(cov);
    if (llt.info() != Eigen::Success) continue;
    Eigen::VectorXd z(np);
    for (int i = 0; i < np; ++i) z[i] = nd(rng);
    d.c[k].head(np) += llt.matrixL() * z;
    d.c[k][1] += drift_m_s * nd(rng);
    d.c[k][0] += offset_m * nd(rng);
  }
  return d;
}

// |r_a(t) - r_b(t)| = dist near t0, by Newton's method.
double contactTime(const DrawnFit& a, const DrawnFit& b, double dist, double t0) {
  double t = t0;
  for (int it = 0; it < 6; ++it) {
    const Eigen::Vector2d dr = a.pos(t) - b.pos(t), dv = a.vel(t) - b.vel(t);
    const double f = dr.squaredNorm() - dist * dist, df = 2 * dr.dot(dv);
    if (df == 0) break;
    t -= f / df;
  }
  return t;
}

Vec3 drawVec(const Vec3& mean, const Eigen::Matrix3d& cov, std::mt19937_64& rng, bool nominal) {
  if (nominal || !cov.allFinite()) return mean;
  std::normal_distribution<double> nd;
  const Eigen::LLT<Eigen::Matrix3d> llt(cov);
  if (llt.info() != Eigen::Success) return mean;
  return mean + llt.matrixL() * Vec3(nd(rng), nd(rng), nd(rng));
}

struct Outcome {
  double t_c = 0;
  double n_z = 0;    // z component of the line of centres
  double dt_ba = 0;  // pre-impact minus post-impact collision instant
  std::array<Vec3, 2> v_before, v_after, w_before, w_after;
  WaltonMeasurement m;
  double vs_after = 0;
  bool ok = false;
};

struct Inputs {
  std::array<std::array<const TrajectoryFit*, 2>, 2> fit;  // [sphere][side]
  std::array<std::array<double, 2>, 2> inflation;          // of each fit's covariance
  std::array<std::array<double, 2>, 2> drift;              // systematic velocity sigma, m/s
  std::array<double, 2> offset;                            // systematic position sigma, m
  std::array<std::array<Vec3, 2>, 2> spin;                 // [sphere][side]
  std::array<std::array<Eigen::Matrix3d, 2>, 2> spin_cov;
  std::array<double, 2> diameter, mass;
  double contact = 0;  // contact distance, m
  double t_before = 0, t_after = 0;
  double w_before = 0.5;       // weight of the pre-impact instant in t_c
  double nz_sigma = 0.01;      // prior sigma of the line of centres' z part
  double vz_fraction = 0.005;  // prior sigma of v_z before impact, fraction of the speed
};

// The shot's properties from one draw of every fitted input (or the nominal
// values): collision instant, velocities and spins there, Walton's inverse.
Outcome evaluate(const Inputs& in, std::mt19937_64& rng, bool nominal) {
  Outcome o;
  std::array<std::array<DrawnFit, 2>, 2> d;
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side)
      d[s][side] = drawFit(*in.fit[s][side], in.inflation[s][side], in.drift[s][side], in.offset[s],
                           rng, nominal);
  const double tb = nominal ? in.t_before : contactTime(d[0][0], d[1][0], in.contact, in.t_before);
  const double ta = nominal ? in.t_after : contactTime(d[0][1], d[1][1], in.contact, in.t_after);
  o.t_c = in.w_before * tb + (1 - in.w_before) * ta;
  o.dt_ba = tb - ta;
  std::array<Sphere, 2> before, after;
  for (int s = 0; s < 2; ++s) {
    const Eigen::Vector2d p = d[s][0].pos(o.t_c);
    o.v_before[s] = Vec3(d[s][0].vel(o.t_c).x(), d[s][0].vel(o.t_c).y(), 0);
    if (!nominal)
      o.v_before[s].z() =
          in.vz_fraction * o.v_before[s].norm() * std::normal_distribution<double>()(rng);
    o.v_after[s] = Vec3(d[s][1].vel(o.t_c).x(), d[s][1].vel(o.t_c).y(), 0);
    o.w_before[s] = drawVec(in.spin[s][0], in.spin_cov[s][0], rng, nominal);
    o.w_after[s] = drawVec(in.spin[s][1], in.spin_cov[s][1], rng, nominal);
    before[s].mass_kg = after[s].mass_kg = in.mass[s];
    before[s].diameter_m = after[s].diameter_m = in.diameter[s];
    before[s].position_m = after[s].position_m = Vec3(p.x(), p.y(), 0);
    before[s].velocity_m_s = o.v_before[s];
    before[s].spin_rad_s = o.w_before[s];
    after[s].velocity_m_s = o.v_after[s];
    after[s].spin_rad_s = o.w_after[s];
  }
  // Out of the image plane (thesis Appendix B, generalised): the spin changes
  // give the impulse's z part and, through friction, the line of centres'
  // small z part, which the images cannot show (spheres launched a little out
  // of plane meet a few tenths of a millimetre apart in z). -n x dP =
  // (m_i d_i / 5) d omega_i, rows x and y for each sphere, is linear in
  // (n_z, dP_z):
  //   n_z dP_y - n_y dP_z = c_i d omega_ix,   n_x dP_z - n_z dP_x = c_i d omega_iy.
  // A frictionless (head-on) impulse leaves n_z undetermined, so n_z has a
  // prior N(0, line_of_centres_z_sigma^2), itself drawn in the Monte Carlo.
  {
    const Vec3 dr = before[0].position_m - before[1].position_m;
    const Eigen::Vector2d n2 = dr.head<2>().normalized();
    const double m12 = in.mass[0] * in.mass[1] / (in.mass[0] + in.mass[1]);
    const Vec3 dp = m12 * ((o.v_after[0] - o.v_before[0]) - (o.v_after[1] - o.v_before[1]));
    Eigen::Matrix2d ata = Eigen::Matrix2d::Zero();
    Eigen::Vector2d atb = Eigen::Vector2d::Zero();
    for (int s = 0; s < 2; ++s) {
      const double c = in.mass[s] * in.diameter[s] / 5.0;
      const Vec3 dw = o.w_after[s] - o.w_before[s];
      const Eigen::Matrix3d cov = in.spin_cov[s][0] + in.spin_cov[s][1];
      for (int row = 0; row < 2; ++row) {
        const Eigen::Vector2d a =
            row == 0 ? Eigen::Vector2d(dp.y(), -n2.y()) : Eigen::Vector2d(-dp.x(), n2.x());
        const double var = c * c * std::max(cov(row, row), 1e-12);
        ata += a * a.transpose() / var;
        atb += a * (c * dw[row]) / var;
      }
    }
    const double sz = std::max(in.nz_sigma, 1e-6);
    const double prior = nominal ? 0.0 : sz * std::normal_distribution<double>()(rng);
    ata(0, 0) += 1.0 / (sz * sz);
    atb[0] += prior / (sz * sz);
    const Eigen::Vector2d x = ata.ldlt().solve(atb);
    if (x.allFinite()) {
      const double nz = std::clamp(x[0], -0.2, 0.2);
      // Sphere 1 towards the camera from sphere 2 by n_z of the contact distance.
      const double dz = nz * dr.head<2>().norm() / std::sqrt(1 - nz * nz);
      before[0].position_m.z() = after[0].position_m.z() = 0.5 * dz;
      before[1].position_m.z() = after[1].position_m.z() = -0.5 * dz;
      o.v_after[0].z() = after[0].velocity_m_s.z() = o.v_before[0].z() + x[1] / in.mass[0];
      o.v_after[1].z() = after[1].velocity_m_s.z() = o.v_before[1].z() - x[1] / in.mass[1];
      o.n_z = nz;
    }
  }
  auto m = measureCollision(before, after);
  if (!m) return o;
  o.m = *m;
  o.vs_after = m->after.v_s_vec_m_s.dot(m->before.tangent);
  o.ok = true;
  return o;
}

struct Spread {
  double s = 0, s2 = 0;
  int n = 0;
  void add(double x) {
    if (!std::isfinite(x)) return;
    s += x, s2 += x * x, ++n;
  }
  double sigma() const {
    if (n < 2) return kNaN;
    const double m = s / n;
    return std::sqrt(std::max(0.0, (s2 - n * m * m) / (n - 1)));
  }
};

void addFlag(ShotAnalysis& a, const std::string& f) {
  if (std::find(a.quality_flags.begin(), a.quality_flags.end(), f) == a.quality_flags.end())
    a.quality_flags.push_back(f);
}

}  // namespace

Result<ShotAnalysis> analyzeBurst(const Burst& burst, const AnalysisSettings& set) {
  // ---- frames, sizes, clock
  std::vector<std::size_t> good;
  for (std::size_t i = 0; i < burst.frames.size(); ++i)
    if (burst.frames[i].good()) good.push_back(i);
  if (good.empty())
    return fail("no usable frame in the burst (" + std::to_string(burst.frames.size()) +
                " frames, none complete): nothing to analyse; record the shot again");
  const cv::Mat& first = burst.frames[good.front()].image;
  const int max_value = maxValue(burst.format);
  for (const std::size_t i : good) {
    const cv::Mat& img = burst.frames[i].image;
    if (img.size() != first.size() || img.type() != first.type())
      return fail("frames of different sizes or pixel types: frame " +
                  std::to_string(burst.frames[good.front()].id) + " is " +
                  std::to_string(first.cols) + "x" + std::to_string(first.rows) + ", frame " +
                  std::to_string(burst.frames[i].id) + " is " + std::to_string(img.cols) + "x" +
                  std::to_string(img.rows) + "; analyse frames of one recording only");
    if (img.channels() != 1 || (img.depth() != CV_8U && img.depth() != CV_16U))
      return fail("frame " + std::to_string(burst.frames[i].id) +
                  " is not a one-channel 8- or 16-bit image");
  }
  if (first.depth() != (burst.format == PixelFormat::Mono8 ? CV_8U : CV_16U))
    return fail(std::string("the burst says ") + toString(burst.format) + " but its frames hold " +
                (first.depth() == CV_8U ? "8" : "16") + "-bit pixels");
  const double fps = set.fps > 0 ? set.fps : burst.fps;
  bool stamps_ok = true;
  for (std::size_t k = 1; k < good.size(); ++k)
    if (burst.frames[good[k]].timestamp_ns <= burst.frames[good[k - 1]].timestamp_ns)
      stamps_ok = false;
  if (good.size() > 1 && !stamps_ok && !(fps > 0))
    return fail(
        "the frames carry no increasing timestamps and no frame rate is known: give "
        "the frame rate (--fps)");

  ShotAnalysis out;
  std::vector<FrameData> data(good.size());
  for (std::size_t k = 0; k < good.size(); ++k) {
    const Frame& f = burst.frames[good[k]];
    data[k].index = good[k];
    data[k].t = stamps_ok ? (f.timestamp_ns - burst.frames[good.front()].timestamp_ns) * 1e-9
                          : (f.id - burst.frames[good.front()].id) / fps;
  }
  const double frame_dt =
      good.size() > 1
          ? (data.back().t - data.front().t) /
                std::max<double>(1, burst.frames[good.back()].id - burst.frames[good.front()].id)
          : (fps > 0 ? 1 / fps : 1e-3);

  // ---- spheres in every frame
  SphereDetectorSettings ds;
  const std::array<double, 2> diam = set.diameter_m;
  if (!(diam[0] > 0) || !(diam[1] > 0))
    return fail("the sphere diameters must be given and > 0 (got " + fmt("%g", diam[0]) + " and " +
                fmt("%g", diam[1]) + " m)");
  if (set.pixel_size_m > 0) {
    // Generous bounds: a wrong diameter must still be measured, to be reported.
    ds.min_radius_px = 0.15 * std::min(diam[0], diam[1]) / set.pixel_size_m;
    ds.max_radius_px = 1.5 * std::max(diam[0], diam[1]) / set.pixel_size_m;
  }
  const SphereDetector detector(ds);
  int saturated = 0;
  for (std::size_t k = 0; k < data.size(); ++k) {
    data[k].found = detector.detect(burst.frames[data[k].index].image, max_value);
    saturated += data[k].found.saturated;
    if (set.progress) set.progress(static_cast<int>(k + 1), static_cast<int>(data.size()));
  }

  // ---- which blobs are spheres: the common radius (or two, for two sizes)
  std::vector<double> radii;
  for (const FrameData& f : data)
    for (const SphereMeasurement& m : f.found.spheres)
      if (!m.cut_by_border) radii.push_back(m.circle.radius);
  if (radii.empty())
    return fail("no sphere found in any of the " + std::to_string(data.size()) + " frames (" +
                (data.front().found.notes.empty() ? std::string("no bright round blob")
                                                  : data.front().found.notes[0]) +
                "); check the exposure and that the spheres are in view");
  const double ratio = diam[1] / diam[0];
  std::array<double, 2> r_expect;
  if (std::abs(ratio - 1) < 0.02) {
    r_expect[0] = r_expect[1] = median(radii);
  } else {
    // Two sizes: split the radii at the geometric mean of their extremes.
    std::sort(radii.begin(), radii.end());
    const double cut = std::sqrt(radii.front() * radii.back());
    std::vector<double> lo, hi;
    for (const double r : radii) (r < cut ? lo : hi).push_back(r);
    const double rl = lo.empty() ? kNaN : median(lo), rh = hi.empty() ? kNaN : median(hi);
    r_expect = ratio > 1 ? std::array<double, 2>{rl, rh} : std::array<double, 2>{rh, rl};
    if (!std::isfinite(rl) || !std::isfinite(rh))
      return fail("the diameters given differ (" + fmt("%.4g", diam[0] * 1e3) + " and " +
                  fmt("%.4g", diam[1] * 1e3) + " mm) but all spheres found measure about " +
                  fmt("%.1f", 2 * median(radii)) + " px across: check --diameter2-mm");
  }
  if (set.pixel_size_m > 0)
    for (int s = 0; s < 2; ++s) {
      const double d_img = 2 * r_expect[s] * set.pixel_size_m;
      if (std::abs(d_img / diam[s] - 1) > 0.05)
        return fail("sphere " + std::to_string(s + 1) + " measures " +
                    fmt("%.2f", 2 * r_expect[s]) + " px across, which at a pixel size of " +
                    fmt("%.5g", set.pixel_size_m * 1e3) + " mm is " + fmt("%.2f", d_img * 1e3) +
                    " mm, but its diameter is given as " + fmt("%.2f", diam[s] * 1e3) +
                    " mm: check the diameter (--diameter-mm) or the pixel size");
    }
  int third_blobs = 0;
  for (FrameData& f : data) {
    for (int i = 0; i < static_cast<int>(f.found.spheres.size()); ++i) {
      const double r = f.found.spheres[i].circle.radius;
      const bool fits =
          std::abs(r / r_expect[0] - 1) < 0.15 || std::abs(r / r_expect[1] - 1) < 0.15;
      if (fits) {
        f.candidates.push_back(i);
      } else if (f.found.spheres[i].cut_by_border) {
        // A sliver at the frame's edge (a sphere entering or leaving) measures
        // a poor radius: left out, nothing to report.
        f.found.notes.push_back("a blob cut by the frame's edge measures " + fmt("%.1f", r) +
                                " px in radius: left out");
      } else {
        ++third_blobs;
        f.found.notes.push_back("a round blob of radius " + fmt("%.1f", r) +
                                " px is not a sphere of this shot (expected " +
                                fmt("%.1f", r_expect[0]) + " px): ignored");
      }
    }
  }

  // ---- tracks: seed at the first frame with two separate spheres
  int seed = -1;
  for (int k = 0; k < static_cast<int>(data.size()) && seed < 0; ++k) {
    const FrameData& f = data[k];
    if (f.candidates.size() != 2) continue;
    const SphereMeasurement &a = f.found.spheres[f.candidates[0]],
                            &b = f.found.spheres[f.candidates[1]];
    if (a.touching || b.touching) continue;
    seed = k;
  }
  if (seed < 0) {
    int one = 0;
    for (const FrameData& f : data) one += !f.candidates.empty();
    return fail("never two separate spheres in one frame (" + std::to_string(one) + " of " +
                std::to_string(data.size()) +
                " frames show one sphere): a collision needs both spheres in view before impact");
  }
  {
    FrameData& f = data[seed];
    // Candidates are sorted by u: the left one is sphere 1.
    f.assigned = {f.candidates[0], f.candidates[1]};
    const double gate = 0.5 * std::min(r_expect[0], r_expect[1]);
    track(data, seed, +1, gate);
    track(data, seed, -1, gate);
  }
  if (std::abs(ratio - 1) >= 0.02) {
    // Two sizes: sphere 1 (left) must be the one whose diameter came first.
    const SphereMeasurement &a = *trackAt(data[seed], 0), &b = *trackAt(data[seed], 1);
    if ((a.circle.radius < b.circle.radius) != (diam[0] < diam[1]))
      return fail("the left sphere measures " + fmt("%.1f", 2 * a.circle.radius) +
                  " px across and the right one " + fmt("%.1f", 2 * b.circle.radius) +
                  " px, but the diameters given say the opposite: give the left sphere's "
                  "diameter first");
  }
  for (FrameData& f : data) {
    int used = (f.assigned[0] >= 0) + (f.assigned[1] >= 0);
    if (static_cast<int>(f.candidates.size()) > used) {
      third_blobs += static_cast<int>(f.candidates.size()) - used;
      f.found.notes.push_back("a sphere-sized blob off both tracks: ignored");
    }
  }

  // ---- pixel size (given, checked against the radii; or from the radii)
  std::array<double, 2> r_med;
  for (int s = 0; s < 2; ++s) {
    std::vector<double> r;
    for (const FrameData& f : data)
      if (const SphereMeasurement* m = trackAt(f, s); m && !m->cut_by_border)
        r.push_back(m->circle.radius);
    if (r.empty())
      for (const FrameData& f : data)
        if (const SphereMeasurement* m = trackAt(f, s)) r.push_back(m->circle.radius);
    r_med[s] = median(r);
  }
  double px = set.pixel_size_m;
  if (px > 0) {
    for (int s = 0; s < 2; ++s) {
      const double d_img = 2 * r_med[s] * px;
      if (std::abs(d_img / diam[s] - 1) > 0.05)
        return fail("sphere " + std::to_string(s + 1) + " measures " + fmt("%.2f", 2 * r_med[s]) +
                    " px across, which at a pixel size of " + fmt("%.5g", px * 1e3) + " mm is " +
                    fmt("%.2f", d_img * 1e3) + " mm, but its diameter is given as " +
                    fmt("%.2f", diam[s] * 1e3) +
                    " mm: check the diameter (--diameter-mm) or the pixel size");
    }
  } else {
    if (std::abs((r_med[1] / r_med[0]) / ratio - 1) > 0.05)
      return fail("the spheres measure " + fmt("%.2f", 2 * r_med[0]) + " and " +
                  fmt("%.2f", 2 * r_med[1]) + " px across, but the diameters given are " +
                  fmt("%.3g", diam[0] * 1e3) + " and " + fmt("%.3g", diam[1] * 1e3) +
                  " mm: check --diameter-mm and --diameter2-mm");
    px = 0.5 * (diam[0] / (2 * r_med[0]) + diam[1] / (2 * r_med[1]));
  }
  out.pixel_size_m = px;
  const double ou = set.origin_u_px, ov = set.origin_v_px;
  Eigen::Vector2d gdir(set.gravity_dir_image[0], set.gravity_dir_image[1]);
  if (!(gdir.norm() > 0)) return fail("gravity_dir_image must be a non-zero direction");
  gdir.normalize();
  const Vec3 gravity(kG * gdir.x(), -kG * gdir.y(), 0.0);

  // ---- the collision: closest approach, then fits on each side
  int k_min = -1;
  double d_min = 1e300;
  for (int k = 0; k < static_cast<int>(data.size()); ++k) {
    const SphereMeasurement *a = trackAt(data[k], 0), *b = trackAt(data[k], 1);
    if (!a || !b) continue;
    const double d = std::hypot(a->circle.u - b->circle.u, a->circle.v - b->circle.v);
    if (d < d_min) d_min = d, k_min = k;
  }
  const double contact = 0.5 * (diam[0] + diam[1]);
  const auto sideFrames = [&](int sphere, int side, int k_split, bool include_split) {
    std::vector<int> v;
    for (int k = 0; k < static_cast<int>(data.size()); ++k) {
      if (!trackAt(data[k], sphere)) continue;
      const bool before = k < k_split || (include_split && side == 0 && k == k_split);
      const bool after = k > k_split || (include_split && side == 1 && k == k_split);
      if ((side == 0 && before) || (side == 1 && after)) v.push_back(k);
    }
    return v;
  };
  const double t_split = data[k_min].t;
  std::array<std::array<std::optional<SideFit>, 2>, 2> fits;
  double t_b = 0, t_a = 0, sig_b = 0, sig_a = 0;
  int include = -1;  // side that gets the closest frame (-1: neither)
  for (int pass = 0; pass < 2; ++pass) {
    for (int s = 0; s < 2; ++s)
      for (int side = 0; side < 2; ++side) {
        const std::vector<int> fr = sideFrames(s, side, k_min, include == side);
        if (fr.size() < 3)
          return fail("sphere " + std::to_string(s + 1) + " is seen in " +
                      std::to_string(fr.size()) + " frame(s) " + (side == 0 ? "before" : "after") +
                      " the collision; a track needs at least 3 (is the collision in the burst?)");
        auto f = fitSide(data, fr, s, px, ou, ov, gravity, set.fix_gravity, t_split);
        if (!f)
          return fail("sphere " + std::to_string(s + 1) + ", " + (side == 0 ? "before" : "after") +
                      " the collision: " + f.error().message);
        fits[s][side] = std::move(f).value();
      }
    auto cb = collisionInstant(fits[0][0]->fit, fits[1][0]->fit, contact, CollisionSide::kBefore);
    auto ca = collisionInstant(fits[0][1]->fit, fits[1][1]->fit, contact, CollisionSide::kAfter);
    if (!cb || !ca)
      return fail("no collision found: " + (cb ? ca.error().message : cb.error().message) +
                  " (closest approach " + fmt("%.1f", d_min) + " px between centres, contact at " +
                  fmt("%.1f", contact / px) + " px)");
    t_b = cb->t_s, sig_b = cb->sigma_s, t_a = ca->t_s, sig_a = ca->sigma_s;
    if (pass == 1) break;
    // The closest frame joins the side it was exposed on, unless its exposure
    // straddles the impact (then it shows a mix of both motions).
    const double tc = 0.5 * (t_b + t_a);
    const double half_exp = 0.5 * burst.exposure_us * 1e-6;
    if (t_split + half_exp < tc - 0.02 * frame_dt)
      include = 0;
    else if (t_split - half_exp > tc + 0.02 * frame_dt)
      include = 1;
    else
      break;
  }
  if (!(t_b > data.front().t - 5 * frame_dt) || !(t_a < data.back().t + 5 * frame_dt))
    return fail("the collision instant lies outside the burst: no collision recorded");

  // ---- dots and spins, per sphere and side
  Inputs in;
  in.contact = contact;
  in.nz_sigma = set.line_of_centres_z_sigma;
  in.vz_fraction = std::max(0.0, set.out_of_plane_speed_fraction);
  in.diameter = diam;
  for (int s = 0; s < 2; ++s)
    in.mass[s] = set.mass_kg[s] > 0 ? set.mass_kg[s]
                                    : 1000.0 * std::numbers::pi / 6 * diam[s] * diam[s] * diam[s];
  std::vector<std::array<DotFrame, 2>> dots(data.size());
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side) {
      const SideFit& sf = *fits[s][side];
      in.fit[s][side] = &sf.fit;
      in.inflation[s][side] = sf.inflation;
      const double span = sf.fit.tLast_s() - sf.fit.tFirst_s();
      in.drift[s][side] = span > 0 ? systematicCentrePx(r_med[s]) * px / span : 0.0;
      in.offset[s] = systematicCentrePx(r_med[s]) * px;
      std::vector<SpinFrame> sfr;
      for (const int k : sf.frames) {
        SphereMeasurement m = *trackAt(data[k], s);
        // Lift with the track's radius: steadier than one frame's.
        m.circle.radius = r_med[s];
        dots[k][s] = findDots(burst.frames[data[k].index].image, m, max_value);
        if (dots[k][s].dots.empty()) continue;
        SpinFrame f;
        f.t_s = data[k].t;
        for (const Dot& d : dots[k][s].dots) {
          f.dots.push_back(d.on_sphere);
          f.weights.push_back(d.weight);
        }
        f.centre_sigma = 1.2 * std::max(m.circle.sigma_u, m.circle.sigma_v) / r_med[s];
        sfr.push_back(std::move(f));
      }
      auto spin = fitSpin(sfr);
      if (spin) {
        in.spin[s][side] = spin->spin_rad_s;
        in.spin_cov[s][side] = spin->covariance * (kSpinSigmaScale * kSpinSigmaScale);
      } else {
        // Unknown spin: zero, with a spread wide enough for any spin these
        // launches give, so beta and f carry the ignorance in their sigmas.
        in.spin[s][side] = Vec3::Zero();
        in.spin_cov[s][side] =
            Eigen::Matrix3d::Identity() * (kUnknownSpinSigma * kUnknownSpinSigma);
        addFlag(out, side == 0 ? "no_spin_before" : "no_spin_after");
        out.notes.push_back("sphere " + std::to_string(s + 1) + ", " +
                            (side == 0 ? "before" : "after") +
                            " the impact: " + spin.error().message);
      }
      SphereKinematics& kin = out.sphere[s];
      const Vec3 sigma =
          spin ? Vec3(kSpinSigmaScale * spin->sigma_rad_s) : Vec3(Vec3::Constant(kNaN));
      (side == 0 ? kin.spin_before_rad_s : kin.spin_after_rad_s) = {in.spin[s][side], sigma};
      (side == 0 ? kin.frames_before : kin.frames_after) = static_cast<int>(sf.frames.size());
    }

  // ---- collision instant: both estimates, combined by their uncertainties
  const double vb = sig_b * sig_b, va = sig_a * sig_a;
  in.w_before = (std::isfinite(vb) && std::isfinite(va) && vb + va > 0) ? va / (va + vb) : 0.5;
  in.t_before = t_b;
  in.t_after = t_a;

  // ---- the properties, and their spread over draws of every fitted input
  std::mt19937_64 rng(12345);
  const Outcome nominal = evaluate(in, rng, true);
  if (!nominal.ok)
    return fail(
        "the measured kinematics are not a collision (the spheres do not approach at "
        "the contact instant); check the tracks");
  Spread e, beta, bimp, f, gamma, vn, vs, vsa, tc, dtba;
  std::array<std::array<Spread, 3>, 2> svb, sva;
  const int draws = 300;
  for (int i = 0; i < draws; ++i) {
    const Outcome o = evaluate(in, rng, false);
    if (!o.ok) continue;
    e.add(o.m.e), beta.add(o.m.beta), bimp.add(o.m.beta_from_impulse), f.add(o.m.f);
    gamma.add(o.m.before.gamma_rad * 180 / std::numbers::pi);
    vn.add(o.m.before.v_n_m_s), vs.add(o.m.before.v_s_m_s), vsa.add(o.vs_after), tc.add(o.t_c);
    dtba.add(o.dt_ba);
    for (int s = 0; s < 2; ++s)
      for (int k = 0; k < 3; ++k) svb[s][k].add(o.v_before[s][k]), sva[s][k].add(o.v_after[s][k]);
  }
  CollisionProperties& c = out.collision;
  c.e = {nominal.m.e, e.sigma()};
  c.beta = {nominal.m.beta, beta.sigma()};
  c.beta_from_impulse = {nominal.m.beta_from_impulse, bimp.sigma()};
  c.f = {nominal.m.f, f.sigma()};
  c.gamma_deg = {nominal.m.before.gamma_rad * 180 / std::numbers::pi, gamma.sigma()};
  c.vn_m_s = {nominal.m.before.v_n_m_s, vn.sigma()};
  c.vs_m_s = {nominal.m.before.v_s_m_s, vs.sigma()};
  c.vs_after_m_s = {nominal.vs_after, vsa.sigma()};
  // The two instants' disagreement beyond their own errors widens t_c's.
  const double chi2 = (t_b - t_a) * (t_b - t_a) / std::max(vb + va, 1e-30);
  c.t_collision_s = {nominal.t_c, tc.sigma() * std::max(1.0, std::sqrt(chi2))};
  c.t_collision_before_s = t_b;
  c.t_collision_after_s = t_a;
  for (int s = 0; s < 2; ++s) {
    SphereKinematics& kin = out.sphere[s];
    kin.velocity_before_m_s.value = nominal.v_before[s];
    kin.velocity_after_m_s.value = nominal.v_after[s];
    for (int k = 0; k < 3; ++k) {
      kin.velocity_before_m_s.sigma[k] = svb[s][k].sigma();
      kin.velocity_after_m_s.sigma[k] = sva[s][k].sigma();
    }
    // In the image plane by assumption, within out_of_plane_speed_fraction of the speed.
    kin.velocity_before_m_s.sigma.z() = in.vz_fraction * nominal.v_before[s].norm();
    for (int side = 0; side < 2; ++side) out.trajectory[s][side] = fits[s][side]->fit;
  }

  // ---- per-frame record
  out.frames.resize(data.size());
  for (std::size_t k = 0; k < data.size(); ++k) {
    FrameDetections& fd = out.frames[k];
    const Frame& fr = burst.frames[data[k].index];
    fd.frame_id = fr.id;
    fd.t_s = data[k].t;
    fd.notes = data[k].found.notes;
    if (data[k].found.saturated) fd.notes.push_back("saturated");
    for (int s = 0; s < 2; ++s) {
      const SphereMeasurement* m = trackAt(data[k], s);
      if (!m) continue;
      SphereDetection det;
      det.u_px = m->circle.u;
      det.v_px = m->circle.v;
      det.radius_px = m->circle.radius;
      det.sigma_px = std::max(m->circle.sigma_u, m->circle.sigma_v);
      det.cut_by_border = m->cut_by_border;
      det.touching = m->touching;
      fd.sphere[s] = det;
      for (const Dot& d : dots[k][s].dots) fd.dots[s].push_back({d.u_px, d.v_px, d.on_sphere});
    }
  }

  // ---- quality flags
  for (int s = 0; s < 2; ++s) {
    if (out.sphere[s].frames_before < 5) addFlag(out, "few_frames_before");
    if (out.sphere[s].frames_after < 5) addFlag(out, "few_frames_after");
  }
  // The two instants disagree beyond what every error source (fits and
  // systematics, as drawn above) allows.
  const double sd_ba = dtba.sigma();
  if (std::abs(t_b - t_a) > 4 * (std::isfinite(sd_ba) ? sd_ba : std::sqrt(vb + va)) &&
      std::abs(t_b - t_a) > 0.01 * frame_dt)
    addFlag(out, "collision_instant_disagree");
  double resid_px = 0;
  std::vector<double> det_sigma;
  for (const FrameData& fd : data)
    for (int s = 0; s < 2; ++s)
      if (const SphereMeasurement* m = trackAt(fd, s))
        det_sigma.push_back(std::max(m->circle.sigma_u, m->circle.sigma_v));
  // Weighted residual RMS (frames weighted by their detection uncertainty, as
  // in the fits), in pixels: poorly measured frames at the border count less.
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side)
      for (int k = 0; k < 2; ++k) {
        const LinearFit& af = fits[s][side]->fit.axisFit(k);
        resid_px = std::max(resid_px, std::sqrt(af.chi2 / af.weights.sum()) / px);
      }
  const double typical_sigma = median(det_sigma);
  if (resid_px > std::max(0.1, 10 * typical_sigma)) addFlag(out, "large_residuals");
  // SPEC eq. 5.1 with the centre scatter actually seen: can |v_n| and v_s be
  // told at this geometry?
  ImagingGeometry g;
  g.position_sigma_px = std::max(resid_px, 0.01);
  g.pixels_per_diameter = 2 * 0.5 * (r_med[0] + r_med[1]);
  g.diameter_m = contact;
  g.frame_interval_s = frame_dt;
  g.frames_per_side = std::min({out.sphere[0].frames_before, out.sphere[0].frames_after,
                                out.sphere[1].frames_before, out.sphere[1].frames_after});
  if (relativeVelocityError(g, c.vn_m_s.value) > 0.05) addFlag(out, "e_untrustworthy_geometry");
  if (relativeVelocityError(g, c.vs_m_s.value) > 0.05) addFlag(out, "beta_untrustworthy_geometry");
  if (saturated > 0) {
    addFlag(out, "saturated_frames");
    out.notes.push_back(std::to_string(saturated) +
                        " frame(s) mostly at full scale: lower the exposure or the gain");
  }
  if (third_blobs > 0) {
    addFlag(out, "extra_blobs_ignored");
    out.notes.push_back(std::to_string(third_blobs) +
                        " round blob(s) that are not this shot's spheres were ignored (see the "
                        "frames' notes)");
  }
  if (good.size() < burst.frames.size() || burst.stats.dropped > 0) {
    addFlag(out, "frames_lost");
    out.notes.push_back(std::to_string(burst.frames.size() - good.size()) +
                        " frame(s) failed or incomplete, " + std::to_string(burst.stats.dropped) +
                        " dropped: the fits used the rest");
  }
  // Gravity as a check of the scale and the clock: a free fit's acceleration
  // along gravity should be g.
  {
    double sum = 0, wsum = 0;
    for (int s = 0; s < 2; ++s)
      for (int side = 0; side < 2; ++side) {
        const SideFit& sf = *fits[s][side];
        if (sf.frames.size() < 6) continue;
        TrajectoryOptions free;
        Eigen::VectorXd t(sf.frames.size());
        Eigen::MatrixXd p(sf.frames.size(), 2);
        for (std::size_t i = 0; i < sf.frames.size(); ++i) {
          const SphereMeasurement& m = *trackAt(data[sf.frames[i]], s);
          t[i] = data[sf.frames[i]].t;
          p(i, 0) = (m.circle.u - ou) * px;
          p(i, 1) = -(m.circle.v - ov) * px;
        }
        auto ff = fitTrajectory(t, p, Weights::equal(), t_split, free);
        if (!ff) continue;
        const Estimate3 a = ff->acceleration_m_s2();
        // Along gravity: world (x, y) = image (u, -v).
        const double along = a.value.x() * gdir.x() - a.value.y() * gdir.y();
        const double sa = std::hypot(a.sigma.x(), a.sigma.y());
        if (!(sa > 0) || !std::isfinite(sa)) continue;
        sum += along / (sa * sa);
        wsum += 1 / (sa * sa);
      }
    if (wsum > 0) {
      const double a = sum / wsum, sa = 1 / std::sqrt(wsum);
      if (std::abs(a - kG) > std::max(0.1 * kG, 5 * sa) && sa < 0.05 * kG) {
        addFlag(out, "gravity_scale_mismatch");
        out.notes.push_back("the spheres fall at " + fmt("%.2f", a) +
                            " m/s^2 along gravity instead of 9.81: the pixel size, a diameter or "
                            "the frame rate is probably wrong");
      }
    }
  }
  return out;
}

}  // namespace collide::vision
