#include "analysis/free_flight_segments.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>

#include "analysis/residual_structure.hpp"

namespace collide {

namespace {

/// A stretch of usable points with no gap: [first, last], and what follows it.
struct Run {
  int first = 0, last = 0;
  std::string ends_at;
};

struct Span {
  int first = 0, last = 0;
};

Status checkInput(const std::vector<FlightPoint>& points, const FreeFlightOptions& o) {
  if (o.min_samples < 4)
    return fail("free-flight segments: min_samples " + std::to_string(o.min_samples) +
                " is too few to fit a parabola and judge its residuals (at least 4)");
  if (!(o.break_sigmas > 0) || !(o.noise_floor_m >= 0) || !(o.max_gap_frames > 1))
    return fail(
        "free-flight segments: break_sigmas must be > 0, noise_floor_m >= 0 and "
        "max_gap_frames > 1");
  if (!(o.centre_wander_m >= 0) || !(o.centre_wander_time_s >= 0) ||
      !std::isfinite(o.centre_wander_m) || !std::isfinite(o.centre_wander_time_s))
    return fail(
        "free-flight segments: centre_wander_m and centre_wander_time_s must be finite and >= 0");
  for (std::size_t i = 0; i < points.size(); ++i) {
    const FlightPoint& p = points[i];
    if (!std::isfinite(p.t_s) || !p.position_m.allFinite())
      return fail("free-flight segments: point " + std::to_string(i) +
                  " has a non-finite time or position");
    if (p.usable && !(p.sigma_m > 0 && std::isfinite(p.sigma_m)))
      return fail("free-flight segments: point " + std::to_string(i) +
                  " has no positive position uncertainty");
    if (i > 0 && !(p.t_s > points[i - 1].t_s))
      return fail("free-flight segments: point " + std::to_string(i) +
                  " is not later than the one before it; give the points in time order");
  }
  return Ok{};
}

std::vector<Run> usableRuns(const std::vector<FlightPoint>& points, double max_gap_frames) {
  std::vector<double> dt;
  for (std::size_t i = 1; i < points.size(); ++i) dt.push_back(points[i].t_s - points[i - 1].t_s);
  double median_dt = std::numeric_limits<double>::infinity();
  if (!dt.empty()) {
    std::nth_element(dt.begin(), dt.begin() + dt.size() / 2, dt.end());
    median_dt = dt[dt.size() / 2];
  }
  std::vector<Run> runs;
  const int n = static_cast<int>(points.size());
  int i = 0;
  while (i < n) {
    if (!points[i].usable) {
      ++i;
      continue;
    }
    Run r{i, i, "end"};
    while (r.last + 1 < n) {
      const FlightPoint& next = points[r.last + 1];
      if (!next.usable) {
        r.ends_at = next.contact ? "contact" : "unusable";
        break;
      }
      if (next.t_s - points[r.last].t_s > max_gap_frames * median_dt) {
        r.ends_at = "gap";
        break;
      }
      ++r.last;
    }
    runs.push_back(r);
    i = r.last + 1;
  }
  return runs;
}

/// Quadratic fit of points [first, last] without the outliers, t_ref at the first.
Result<TrajectoryFit> fitSpan(const std::vector<FlightPoint>& points,
                              const std::vector<char>& outlier, int first, int last) {
  const int n = last - first + 1;
  Eigen::VectorXd t(n), w(n);
  Eigen::MatrixXd p(n, 2);
  for (int k = 0; k < n; ++k) {
    const FlightPoint& q = points[first + k];
    t[k] = q.t_s;
    p.row(k) = q.position_m.transpose();
    w[k] = outlier[first + k] ? 0.0 : 1.0 / (q.sigma_m * q.sigma_m);
  }
  return fitTrajectory(t, p, Weights::relative(w), points[first].t_s);
}

double chi2(const TrajectoryFit& f) {
  return f.axisFit(0).chi2 + f.axisFit(1).chi2;
}

/// A quadratic fit's gains over points [first, last] (the weights it used),
/// about the first point's time, and those points' times.
struct SpanGains {
  Eigen::VectorXd t;
  Eigen::Matrix<double, 3, Eigen::Dynamic> g;  ///< rows c0, c1, c2 (quadraticGains)
};
std::optional<SpanGains> spanGains(const std::vector<FlightPoint>& points, int first, int last,
                                   const TrajectoryFit& fit) {
  const Eigen::VectorXd& w = fit.axisFit(0).weights;
  if (w.size() != last - first + 1) return std::nullopt;
  SpanGains sg;
  sg.t.resize(w.size());
  for (Eigen::Index k = 0; k < w.size(); ++k) sg.t[k] = points[first + k].t_s;
  sg.g = quadraticGains(sg.t, w, points[first].t_s);
  if (sg.g.cols() != w.size()) return std::nullopt;
  return sg;
}

bool wanderGiven(const FreeFlightOptions& o) {
  return o.centre_wander_m > 0 && o.centre_wander_time_s > 0;
}

/// What the centres' wander (FreeFlightOptions::centre_wander_m) does to a
/// segment's velocity at its first sample, at its last, and to its
/// acceleration.
struct WanderSigmas {
  double velocity_m_s = 0, end_velocity_m_s = 0, acceleration_m_s2 = 0;
};
WanderSigmas wanderSigmas(const std::vector<FlightPoint>& points, int first, int last,
                          const TrajectoryFit& fit, const FreeFlightOptions& o) {
  if (!wanderGiven(o)) return {};
  const auto sg = spanGains(points, first, last, fit);
  if (!sg) return {};
  const double span = points[last].t_s - points[first].t_s;
  const auto sigma = [&](const Eigen::VectorXd& gain) {
    return wanderSigma(sg->t, gain, o.centre_wander_m, o.centre_wander_time_s);
  };
  return {sigma(sg->g.row(1).transpose()), sigma((sg->g.row(1) + span * sg->g.row(2)).transpose()),
          sigma(sg->g.row(2).transpose())};
}

/// What the fit's extrapolation to point q may miss q's own place by besides
/// q's noise, m: the extrapolation's sigma from the points' stated sigmas
/// (`stated_m`; a short fit whose few residuals happen to be small would
/// otherwise scale its covariance far below them), and the centres' wander
/// (`wander_m`, both places wander, together as they are near in time).
struct PredictionSpread {
  double stated_m = 0, wander_m = 0;
};
PredictionSpread predictionSpread(const std::vector<FlightPoint>& points, int first, int last,
                                  int q, const TrajectoryFit& fit, const FreeFlightOptions& o) {
  const auto sg = spanGains(points, first, last, fit);
  if (!sg) return {};
  const Eigen::Index n = sg->t.size();
  const double tau = points[q].t_s - points[first].t_s;
  const Eigen::VectorXd g =
      (sg->g.row(0) + tau * sg->g.row(1) + 0.5 * tau * tau * sg->g.row(2)).transpose();
  PredictionSpread p;
  double var = 0;
  for (Eigen::Index i = 0; i < n; ++i) var += std::pow(g[i] * points[first + i].sigma_m, 2);
  p.stated_m = std::sqrt(var);
  if (wanderGiven(o)) {
    Eigen::VectorXd t(n + 1), h(n + 1);
    t << sg->t, points[q].t_s;
    h << g, -1.0;
    p.wander_m = wanderSigma(t, h, o.centre_wander_m, o.centre_wander_time_s);
  }
  return p;
}

/// How far point q lies from the fit's extrapolation, in sigmas (largest axis):
/// the point's own noise (inflated by the fit's scatter when it has enough
/// degrees of freedom to say), the extrapolation's uncertainty (at least what
/// the points' stated sigmas give it) and the centres' wander (`spread`).
double breakScore(const TrajectoryFit& fit, const FlightPoint& q, double floor_m,
                  const PredictionSpread& spread) {
  const LinearFit& ax = fit.axisFit(0);
  const LinearFit& ay = fit.axisFit(1);
  const int dof = ax.dof + ay.dof;
  double scale = 1.0;
  if (dof >= 6) scale = std::max(1.0, std::sqrt((ax.chi2 + ay.chi2) / dof));
  const double s = std::max(q.sigma_m * scale, floor_m);
  const Estimate3 pos = fit.positionAt_m(q.t_s);
  double score = 0;
  for (int k = 0; k < 2; ++k) {
    const double sp = std::max(std::isfinite(pos.sigma[k]) ? pos.sigma[k] : 0.0, spread.stated_m);
    score = std::max(score,
                     std::abs(q.position_m[k] - pos.value[k]) / std::hypot(s, sp, spread.wander_m));
  }
  return score;
}

/// Greedy: grow a segment while each next point follows its extrapolation;
/// a point that does not while the one after it does is an outlier (left out).
Result<std::vector<Span>> splitRun(const std::vector<FlightPoint>& points, const Run& run,
                                   const FreeFlightOptions& o, std::vector<char>& outlier) {
  std::vector<Span> spans;
  int start = run.first;
  while (run.last - start + 1 >= o.min_samples) {
    int end = start + o.min_samples - 1;
    auto fit = fitSpan(points, outlier, start, end);
    if (!fit) return fit.error();
    int fitted_end = end;
    // What the next point's prediction may miss by, with each fit (the same
    // for the few points until the next one).
    PredictionSpread spread = end < run.last
                                  ? predictionSpread(points, start, end, end + 1, *fit, o)
                                  : PredictionSpread{};
    while (end < run.last) {
      // Refit every step while short, every ~5 % of the length when long.
      if (end - fitted_end >= std::max(1, (end - start + 1) / 20)) {
        fit = fitSpan(points, outlier, start, end);
        if (!fit) return fit.error();
        fitted_end = end;
        spread = predictionSpread(points, start, end, end + 1, *fit, o);
      }
      if (breakScore(*fit, points[end + 1], o.noise_floor_m, spread) <= o.break_sigmas) {
        ++end;
        continue;
      }
      if (end + 2 <= run.last &&
          breakScore(*fit, points[end + 2], o.noise_floor_m, spread) <= o.break_sigmas) {
        outlier[end + 1] = 1;  // one wild point, the flight goes on
        end += 2;
        continue;
      }
      break;
    }
    spans.push_back({start, end});
    start = end + 1;
  }
  return spans;
}

/// Moves the boundary between consecutive spans of one run by up to two
/// points to where the two fits' summed chi-square is least.
Status refineBoundaries(const std::vector<FlightPoint>& points, const std::vector<char>& outlier,
                        std::vector<Span>& spans, int min_samples) {
  for (std::size_t k = 0; k + 1 < spans.size(); ++k) {
    Span& a = spans[k];
    Span& b = spans[k + 1];
    if (b.first != a.last + 1) continue;
    int best = a.last;
    double best_chi2 = std::numeric_limits<double>::infinity();
    for (int end = a.last - 2; end <= a.last + 2; ++end) {
      if (end - a.first + 1 < min_samples || b.last - end < min_samples) continue;
      auto fa = fitSpan(points, outlier, a.first, end);
      auto fb = fitSpan(points, outlier, end + 1, b.last);
      if (!fa || !fb) continue;
      const double c = chi2(*fa) + chi2(*fb);
      if (c < best_chi2) {
        best_chi2 = c;
        best = end;
      }
    }
    a.last = best;
    b.first = best + 1;
  }
  return Ok{};
}

Result<FreeFlightSegment> segmentFrom(const std::vector<FlightPoint>& points,
                                      const std::vector<char>& outlier, const Span& s,
                                      std::string ends_at, const FreeFlightOptions& o) {
  auto fit = fitSpan(points, outlier, s.first, s.last);
  if (!fit) return fit.error();
  FreeFlightSegment seg{s.first, s.last, std::move(*fit)};
  const Estimate3 v = seg.fit.velocityAt_m_s(points[s.first].t_s);
  const Estimate3 v_end = seg.fit.velocityAt_m_s(points[s.last].t_s);
  const Estimate3 a = seg.fit.acceleration_m_s2();
  // Residuals that run in one direction over several frames move the fit more
  // than its covariance (independent frames) says.
  const double inflate = std::sqrt(residualInflation(seg.fit));
  const WanderSigmas wander = wanderSigmas(points, s.first, s.last, seg.fit, o);
  seg.velocity_m_s = v.value.head<2>();
  seg.end_velocity_m_s = v_end.value.head<2>();
  seg.acceleration_m_s2 = a.value.head<2>();
  for (int k = 0; k < 2; ++k) {
    seg.velocity_sigma_m_s[k] = std::hypot(inflate * v.sigma[k], wander.velocity_m_s);
    seg.end_velocity_sigma_m_s[k] = std::hypot(inflate * v_end.sigma[k], wander.end_velocity_m_s);
    seg.acceleration_sigma_m_s2[k] = std::hypot(inflate * a.sigma[k], wander.acceleration_m_s2);
  }
  double sum2 = 0;
  int n = 0;
  for (int axis = 0; axis < 2; ++axis) {
    const LinearFit& f = seg.fit.axisFit(axis);
    for (Eigen::Index i = 0; i < f.residuals.size(); ++i)
      if (f.weights[i] > 0) {
        sum2 += f.residuals[i] * f.residuals[i];
        ++n;
      }
  }
  seg.residual_rms_m = n > 0 ? std::sqrt(sum2 / n) : 0.0;
  seg.ends_at = std::move(ends_at);
  return seg;
}

}  // namespace

Result<std::vector<FreeFlightSegment>> fitFreeFlightSegments(const std::vector<FlightPoint>& points,
                                                             const FreeFlightOptions& options) {
  if (auto st = checkInput(points, options); !st) return st.error();
  std::vector<char> outlier(points.size(), 0);
  std::vector<FreeFlightSegment> out;
  for (const Run& run : usableRuns(points, options.max_gap_frames)) {
    auto spans = splitRun(points, run, options, outlier);
    if (!spans) return spans.error();
    if (auto st = refineBoundaries(points, outlier, *spans, options.min_samples); !st)
      return st.error();
    for (std::size_t k = 0; k < spans->size(); ++k) {
      // A span short of its run's end ended at a break (the points after it
      // may be too few to fit).
      const std::string why = (*spans)[k].last < run.last ? "velocity_change" : run.ends_at;
      auto seg = segmentFrom(points, outlier, (*spans)[k], why, options);
      if (!seg) return seg.error();
      out.push_back(std::move(*seg));
    }
  }
  return out;
}

}  // namespace collide
