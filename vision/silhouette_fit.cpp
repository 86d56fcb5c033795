#include "vision/silhouette_fit.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

namespace collide::vision {
namespace {

// Parameters: u, v, R, then the linear ones bg, gx, gy, A, Bx, By, C, E.
constexpr int kParams = 11;
using Vec = Eigen::Matrix<double, kParams, 1>;
using Mat = Eigen::Matrix<double, kParams, kParams>;

struct Pixel {
  float x, y, value;
  int sub;  // subsamples per axis
};

// Where the model is written: the start centre (u0, v0), about which the
// background plane is, and M, the symmetric map that makes the outline a
// circle: the identity, or under a pinhole lens the inverse of the outline's
// shape there (PinholeCamera::outlineShape: a sphere theta off the optical
// axis is seen as an ellipse 1 / cos(theta) longer away from the principal
// point, the distortion's derivative on top). to_mean: the mean of the
// outline's semi-axes over its radius in M's circle, what the profiles'
// circle fit reports.
struct Outline {
  double u0 = 0, v0 = 0;
  double m00 = 1, m01 = 0, m11 = 1;
  double to_mean = 1;
};

Outline outlineAt(double u, double v, const std::optional<PinholeCamera>& camera) {
  Outline o;
  o.u0 = u, o.v0 = v;
  if (!camera) return o;
  const Eigen::Matrix2d shape = camera->outlineShape(u, v);
  const Eigen::Matrix2d m = shape.inverse();
  if (!m.allFinite()) return o;
  o.m00 = m(0, 0), o.m01 = 0.5 * (m(0, 1) + m(1, 0)), o.m11 = m(1, 1);
  o.to_mean = 0.5 * shape.trace();
  return o;
}

// The pixels of the annulus around `start`, away from the other spheres.
template <class T>
std::vector<Pixel> gatherPixels(const cv::Mat& img, const CircleFit& start,
                                std::span<const CircleFit> others, const SilhouetteFitSettings& s) {
  std::vector<Pixel> px;
  const double r_in = std::max(0.0, start.radius - std::min(s.inner_depth_px, 0.6 * start.radius));
  const double r_out = start.radius + s.outer_px;
  const int x0 = std::max(0, static_cast<int>(std::floor(start.u - r_out)));
  const int x1 = std::min(img.cols - 1, static_cast<int>(std::ceil(start.u + r_out)));
  const int y0 = std::max(0, static_cast<int>(std::floor(start.v - r_out)));
  const int y1 = std::min(img.rows - 1, static_cast<int>(std::ceil(start.v + r_out)));
  px.reserve(static_cast<std::size_t>((x1 - x0 + 1) * (y1 - y0 + 1)));
  for (int y = y0; y <= y1; ++y) {
    const T* row = img.ptr<T>(y);
    for (int x = x0; x <= x1; ++x) {
      const double r = std::sqrt((x - start.u) * (x - start.u) + (y - start.v) * (y - start.v));
      if (r < r_in || r > r_out) continue;
      bool near_other = false;
      for (const CircleFit& o : others) {
        const double d = o.radius + 2.0;
        near_other |= (x - o.u) * (x - o.u) + (y - o.v) * (y - o.v) < d * d;
      }
      if (near_other) continue;
      const int sub = std::abs(r - start.radius) < s.edge_band_px ? s.subsamples : 1;
      px.push_back({static_cast<float>(x), static_cast<float>(y), static_cast<float>(row[x]), sub});
    }
  }
  return px;
}

// The model's level over one pixel's area, and its derivatives in the eleven
// parameters (`jac`). q(2) is the outline's radius in the frame where M makes
// it a circle (its semi-axis across the direction away from the axis).
double pixelModel(const Pixel& p, const Vec& q, const Outline& o, Vec& jac) {
  const double u = q(0), v = q(1), R = q(2), bg = q(3), gx = q(4), gy = q(5), A = q(6), Bx = q(7),
               By = q(8), C = q(9), E = q(10);
  const double u0 = o.u0, v0 = o.v0, m00 = o.m00, m01 = o.m01, m11 = o.m11;
  const int n = p.sub;
  const double inv_n = 1.0 / n, w = inv_n * inv_n;
  double value = 0;
  jac.setZero();
  // Wholly outside (no sample within half a sample of the outline): the
  // background plane, whose mean over the pixel is its value at the centre.
  const double cx = m00 * (p.x - u) + m01 * (p.y - v), cy = m01 * (p.x - u) + m11 * (p.y - v);
  const double outside = R + 0.5 * inv_n + 0.7072 * (1 - inv_n);
  if (cx * cx + cy * cy > outside * outside) {
    jac(3) = 1;
    jac(4) = p.x - u0;
    jac(5) = p.y - v0;
    return bg + gx * jac(4) + gy * jac(5);
  }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double xs = p.x + (i + 0.5) * inv_n - 0.5, ys = p.y + (j + 0.5) * inv_n - 0.5;
      const double dx = xs - u, dy = ys - v;
      const double dxp = m00 * dx + m01 * dy, dyp = m01 * dx + m11 * dy;  // outline a circle
      const double r = std::max(1e-9, std::sqrt(dxp * dxp + dyp * dyp));
      // Coverage: a ramp one subsample wide across the outline (one pixel wide
      // for a pixel not subsampled).
      const double t = 0.5 + (R - r) * n;
      const double c = std::clamp(t, 0.0, 1.0), dc = t > 0 && t < 1 ? n : 0.0;
      const double out = bg + gx * (xs - u0) + gy * (ys - v0);
      const double rx = dxp / R, ry = dyp / R, qq = rx * rx + ry * ry;
      const double s = std::sqrt(std::max(0.0, 1.0 - qq));
      const double lit_term = Bx * rx + By * ry + C * s;
      const bool lit = lit_term > 0;
      const double in = A + E * s * s + (lit ? lit_term : 0.0);
      value += w * (out + c * (in - out));
      // d/du, d/dv, d/dR of the inside level (where lit), s kept off zero.
      // (rx, ry) move by -(m00, m01) / R with u and -(m01, m11) / R with v.
      const double qu = rx * m00 + ry * m01, qv = rx * m01 + ry * m11;
      double din_du = 2 * E * qu / R, din_dv = 2 * E * qv / R, din_dR = 2 * E * qq / R;
      if (lit) {
        const double se = std::max(s, 0.1);
        din_du += (-Bx * m00 - By * m01 + C * qu / se) / R;
        din_dv += (-Bx * m01 - By * m11 + C * qv / se) / R;
        din_dR += (-(Bx * rx + By * ry) + C * qq / se) / R;
      }
      const double step = dc * (in - out);
      jac(0) += w * (step * (dxp * m00 + dyp * m01) / r + c * din_du);
      jac(1) += w * (step * (dxp * m01 + dyp * m11) / r + c * din_dv);
      jac(2) += w * (step + c * din_dR);
      jac(3) += w * (1 - c);
      jac(4) += w * (1 - c) * (xs - u0);
      jac(5) += w * (1 - c) * (ys - v0);
      jac(6) += w * c;
      jac(10) += w * c * s * s;
      if (lit) {
        jac(7) += w * c * rx;
        jac(8) += w * c * ry;
        jac(9) += w * c * s;
      }
    }
  return value;
}

// The model at q over all pixels: residuals (image - model) and the model's
// derivatives, one row per pixel.
struct Evaluation {
  std::vector<double> res;
  Eigen::Matrix<double, Eigen::Dynamic, kParams> jac;
};

void evaluate(const std::vector<Pixel>& px, const Vec& q, const Outline& o, Evaluation& e) {
  e.res.resize(px.size());
  e.jac.resize(static_cast<Eigen::Index>(px.size()), kParams);
  Vec j;
  for (std::size_t k = 0; k < px.size(); ++k) {
    e.res[k] = px[k].value - pixelModel(px[k], q, o, j);
    e.jac.row(static_cast<Eigen::Index>(k)) = j.transpose();
  }
}

double weightedCost(const Evaluation& e, const std::vector<double>& w) {
  double cost = 0;
  for (std::size_t k = 0; k < e.res.size(); ++k) cost += w[k] * e.res[k] * e.res[k];
  return cost;
}

// Weighted normal equations J'WJ and J'Wr (the first `fixed` parameters held).
struct Normal {
  Mat jtj = Mat::Zero();
  Vec jtr = Vec::Zero();
};

Normal accumulate(const Evaluation& e, const std::vector<double>& w, int fixed) {
  const Eigen::Index n = e.jac.rows();
  const Eigen::Map<const Eigen::VectorXd> wv(w.data(), n), rv(e.res.data(), n);
  const Eigen::Matrix<double, Eigen::Dynamic, kParams> wj = e.jac.array().colwise() * wv.array();
  Normal ne;
  ne.jtj = e.jac.transpose() * wj;
  ne.jtr = wj.transpose() * rv;
  for (int a = 0; a < fixed; ++a) {
    ne.jtj.row(a).setZero();
    ne.jtj.col(a).setZero();
    ne.jtj(a, a) = 1;
    ne.jtr(a) = 0;
  }
  return ne;
}

// Tukey's biweight at 4.685 robust standard deviations of the residuals:
// dots, a highlight and hot pixels get no weight. The noise grows with the
// level (photon noise), so the standard deviation (1.4826 MAD) is taken per
// quarter of the pixels by model level, and each pixel is weighted by its
// inverse variance besides. `floor`: the least standard deviation taken (the
// model's own error on a noiseless frame).
void tukeyWeights(const std::vector<Pixel>& px, const std::vector<double>& res, double floor,
                  std::vector<double>& weights) {
  const std::size_t n = res.size();
  std::vector<std::pair<double, double>> by_level(n);  // (model level, |residual|)
  for (std::size_t k = 0; k < n; ++k) by_level[k] = {px[k].value - res[k], std::abs(res[k])};
  constexpr int kGroups = 4;
  // Each quarter's pixels, in no particular order within it: partitioned at
  // the quarters' bounds (a full sort was 7 % of tracking small spheres).
  std::vector<std::size_t> order(n);
  for (std::size_t k = 0; k < n; ++k) order[k] = k;
  const auto lower = [&](std::size_t a, std::size_t b) {
    return by_level[a].first < by_level[b].first;
  };
  for (int g = 1; g < kGroups; ++g)
    std::nth_element(order.begin() + static_cast<std::ptrdiff_t>(n * (g - 1) / kGroups),
                     order.begin() + static_cast<std::ptrdiff_t>(n * g / kGroups), order.end(),
                     lower);
  weights.resize(n);
  std::vector<double> a;
  for (int g = 0; g < kGroups; ++g) {
    const std::size_t lo = n * g / kGroups, hi = n * (g + 1) / kGroups;
    if (hi <= lo) continue;
    a.clear();
    for (std::size_t i = lo; i < hi; ++i) a.push_back(by_level[order[i]].second);
    auto mid = a.begin() + static_cast<std::ptrdiff_t>(a.size() / 2);
    std::nth_element(a.begin(), mid, a.end());
    const double sd = std::max(1.4826 * *mid, floor), c = 4.685 * sd;
    for (std::size_t i = lo; i < hi; ++i) {
      const std::size_t k = order[i];
      const double z = res[k] / c;
      weights[k] = std::abs(z) >= 1 ? 0.0 : (1 - z * z) * (1 - z * z) / (sd * sd);
    }
  }
}

// The least noise a pixel is taken to have: half a grey level, or 1 % of the
// sphere's contrast over its background (what averaging the limb over 3 x 3
// samples per pixel may miss).
double modelFloor(const Vec& q) {
  return std::max(0.5, 0.01 * std::abs(q(6) + q(9) + q(10) - q(3)));
}

// Levenberg-damped Gauss-Newton at fixed weights. `e` holds the evaluation at
// q on entry and on return.
void solve(const std::vector<Pixel>& px, Vec& q, const Outline& o, Evaluation& e,
           const std::vector<double>& w, int iterations) {
  Normal ne = accumulate(e, w, 0);
  double cost = weightedCost(e, w), lambda = 1e-3;
  Evaluation trial_e;
  for (int it = 0; it < iterations; ++it) {
    Mat a = ne.jtj;
    for (int i = 0; i < kParams; ++i) a(i, i) += lambda * a(i, i) + 1e-12;
    const Vec step = a.ldlt().solve(ne.jtr);
    // A step this small is not worth a model evaluation: the circle is found.
    if (!step.allFinite() || step.head<3>().norm() < 2e-3) break;
    const Vec trial = q + step;
    if (!(trial(2) > 1)) {
      lambda *= 10;
      continue;
    }
    evaluate(px, trial, o, trial_e);
    const double trial_cost = weightedCost(trial_e, w);
    if (trial_cost > cost) {
      lambda *= 10;
      if (lambda > 1e6) break;
      continue;
    }
    q = trial;
    std::swap(e, trial_e);
    lambda = std::max(1e-6, lambda * 0.3);
    ne = accumulate(e, w, 0);
    cost = weightedCost(e, w);
  }
}

}  // namespace

std::optional<SilhouetteFit> fitSilhouette(const cv::Mat& image, const CircleFit& start,
                                           std::span<const CircleFit> others,
                                           const SilhouetteFitSettings& settings) {
  if (image.empty() || image.channels() != 1 || !(start.radius > 2)) return std::nullopt;
  std::vector<Pixel> px = image.depth() == CV_8U
                              ? gatherPixels<std::uint8_t>(image, start, others, settings)
                              : gatherPixels<std::uint16_t>(image, start, others, settings);
  if (px.size() < 4 * kParams) return std::nullopt;
  const Outline o = outlineAt(start.u, start.v, settings.camera);
  // The profiles' circle fit reports the mean of the ellipse's semi-axes.
  const double to_mean = o.to_mean;
  // Start: the given circle, levels from the pixels well outside and inside.
  double out_sum = 0, in_sum = 0;
  int out_n = 0, in_n = 0;
  for (const Pixel& p : px) {
    const double r = std::hypot(p.x - o.u0, p.y - o.v0);
    if (r > start.radius + 1.5) out_sum += p.value, ++out_n;
    if (r < start.radius - 1.5) in_sum += p.value, ++in_n;
  }
  if (out_n == 0 || in_n == 0) return std::nullopt;
  Vec q = Vec::Zero();
  // A sphere lit along the line of sight to begin with (C > 0): with no lit
  // term the lamp's parameters would have no derivative.
  const double out_level = out_sum / out_n, in_level = in_sum / in_n;
  const double lit = 0.5 * (in_level - out_level);
  q << start.u, start.v, start.radius / to_mean, out_level, 0, 0, in_level - 0.8 * lit, 0, 0, lit,
      0;
  // The levels first (the circle held, one exact linear step), then
  // everything, with weights from the residuals.
  Evaluation e;
  evaluate(px, q, o, e);
  std::vector<double> w(px.size(), 1.0);
  const Normal lin = accumulate(e, w, 3);
  q += lin.jtj.ldlt().solve(lin.jtr);
  evaluate(px, q, o, e);
  for (int round = 0; round < 3; ++round) {
    if (round == 1) {
      // The pixels the outline crosses, subsampled, from the circle found so far.
      CircleFit now = start;
      now.u = q(0), now.v = q(1), now.radius = q(2) * to_mean;
      px = image.depth() == CV_8U ? gatherPixels<std::uint8_t>(image, now, others, settings)
                                  : gatherPixels<std::uint16_t>(image, now, others, settings);
      if (px.size() < 4 * kParams) return std::nullopt;
      evaluate(px, q, o, e);
    }
    // (Otherwise e holds the evaluation at q already.)
    tukeyWeights(px, e.res, modelFloor(q), w);
    solve(px, q, o, e, w, settings.iterations);
  }
  const Normal ne = accumulate(e, w, 0);
  double wsum = 0;
  int zero = 0;
  for (double wk : w) wsum += wk, zero += wk == 0;
  if (!q.allFinite() || std::hypot(q(0) - start.u, q(1) - start.v) > settings.max_shift_px ||
      std::abs(q(2) * to_mean - start.radius) > settings.max_shift_px)
    return std::nullopt;
  // The sphere must stand off its background at its limb: on average round
  // the outline (A + |B| / pi above the background) by more than the noise.
  const double dof = std::max(1.0, wsum - kParams);
  const double var = weightedCost(e, w) / dof;
  const double limb_step = q(6) + std::hypot(q(7), q(8)) / std::numbers::pi - q(3);
  if (!(limb_step > 3 * std::sqrt(var) + 2.0)) return std::nullopt;
  SilhouetteFit fit;
  fit.circle = start;
  fit.circle.u = q(0), fit.circle.v = q(1), fit.circle.radius = q(2) * to_mean;
  const Mat cov = ne.jtj.ldlt().solve(Mat::Identity()) * var;
  fit.circle.sigma_u = std::sqrt(std::max(0.0, cov(0, 0)));
  fit.circle.sigma_v = std::sqrt(std::max(0.0, cov(1, 1)));
  fit.circle.sigma_radius = to_mean * std::sqrt(std::max(0.0, cov(2, 2)));
  fit.circle.residual_rms = std::sqrt(var);
  fit.background = q(3);
  fit.ambient_level = q(6);
  fit.pixels = static_cast<int>(px.size());
  fit.downweighted = zero;
  return fit;
}

}  // namespace collide::vision
