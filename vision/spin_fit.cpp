#include "vision/spin_fit.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <string>
#include <utility>

#include "analysis/rotation.hpp"

namespace collide::vision {
namespace {

using Match = std::pair<int, int>;

Eigen::Matrix3d skew(const Vec3& v) {
  Eigen::Matrix3d s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

Eigen::Matrix3d expRot(const Vec3& phi) {
  const double a = phi.norm();
  if (a < 1e-12) return Eigen::Matrix3d::Identity() + skew(phi);
  return Eigen::AngleAxisd(a, phi / a).toRotationMatrix();
}

// Left Jacobian of SO(3): exp([phi + d]) ~ exp([J_l(phi) d]) exp([phi]).
Eigen::Matrix3d leftJacobian(const Vec3& phi) {
  const double a = phi.norm();
  const Eigen::Matrix3d k = skew(phi);
  if (a < 1e-6) return Eigen::Matrix3d::Identity() + 0.5 * k;
  return Eigen::Matrix3d::Identity() + (1 - std::cos(a)) / (a * a) * k +
         (a - std::sin(a)) / (a * a * a) * k * k;
}

double weightOf(const SpinFrame& f, std::size_t i) {
  return f.weights.size() == f.dots.size() ? f.weights[i] : 1.0;
}

// Mutual nearest neighbours between rot * a and b within the gate.
std::vector<Match> matchDots(const SpinFrame& a, const SpinFrame& b, const Eigen::Matrix3d& rot,
                             double cos_gate) {
  const std::size_t na = a.dots.size(), nb = b.dots.size();
  std::vector<int> best_ab(na, -1), best_ba(nb, -1);
  std::vector<double> score_ab(na, cos_gate), score_ba(nb, cos_gate);
  for (std::size_t i = 0; i < na; ++i) {
    const Vec3 q = rot * a.dots[i];
    for (std::size_t j = 0; j < nb; ++j) {
      const double c = q.dot(b.dots[j]);
      if (c > score_ab[i]) score_ab[i] = c, best_ab[i] = static_cast<int>(j);
      if (c > score_ba[j]) score_ba[j] = c, best_ba[j] = static_cast<int>(i);
    }
  }
  std::vector<Match> m;
  for (std::size_t i = 0; i < na; ++i)
    if (best_ab[i] >= 0 && best_ba[best_ab[i]] == static_cast<int>(i))
      m.emplace_back(static_cast<int>(i), best_ab[i]);
  return m;
}

// Kabsch on the matches, then one more round of matching with the result.
bool refinePair(const SpinFrame& a, const SpinFrame& b, std::vector<Match>& m, Eigen::Matrix3d& rot,
                double cos_gate, int min_matches) {
  for (int round = 0; round < 2; ++round) {
    if (static_cast<int>(m.size()) < min_matches) return false;
    Eigen::Matrix3Xd from(3, m.size()), to(3, m.size());
    Eigen::VectorXd w(m.size());
    for (std::size_t k = 0; k < m.size(); ++k) {
      from.col(k) = a.dots[m[k].first];
      to.col(k) = b.dots[m[k].second];
      w[k] = std::sqrt(weightOf(a, m[k].first) * weightOf(b, m[k].second));
    }
    auto fit = fitRotation(from, to, w);
    if (!fit) return false;
    rot = fit->rotation;
    m = matchDots(a, b, rot, cos_gate);
  }
  return static_cast<int>(m.size()) >= min_matches;
}

// Orthonormal frame from two non-parallel unit vectors (first axis = p).
Eigen::Matrix3d triad(const Vec3& p, const Vec3& q) {
  const Vec3 e2 = p.cross(q).normalized();
  Eigen::Matrix3d f;
  f.col(0) = p;
  f.col(1) = e2;
  f.col(2) = p.cross(e2);
  return f;
}

// Every rotation taking a pair of a's dots onto a pair of b's with the same
// separation, scored by how many dots it matches. Returns the best rotation
// (by count, then by the smaller angle) or false if none reaches min_matches.
bool searchRotation(const SpinFrame& a, const SpinFrame& b, double max_angle, double cos_gate,
                    int min_matches, Eigen::Matrix3d& best_rot) {
  // The best-conditioned dots only: bounded cost, and near-limb dots are noisy.
  const auto strongest = [](const SpinFrame& f) {
    std::vector<int> idx(f.dots.size());
    std::iota(idx.begin(), idx.end(), 0);
    std::sort(idx.begin(), idx.end(),
              [&](int x, int y) { return weightOf(f, x) > weightOf(f, y); });
    if (idx.size() > 10) idx.resize(10);
    return idx;
  };
  const std::vector<int> ia = strongest(a), ib = strongest(b);
  int best = -1;
  double best_angle = 1e9;
  const double cos_max = std::cos(max_angle);
  for (std::size_t x = 0; x < ia.size(); ++x)
    for (std::size_t y = x + 1; y < ia.size(); ++y) {
      const Vec3 &p = a.dots[ia[x]], &q = a.dots[ia[y]];
      const double sep = std::acos(std::clamp(p.dot(q), -1.0, 1.0));
      if (sep < 0.12 || sep > 2.8) continue;  // too close or nearly opposite: poor axis
      const Eigen::Matrix3d fa = triad(p, q);
      for (std::size_t u = 0; u < ib.size(); ++u)
        for (std::size_t v = 0; v < ib.size(); ++v) {
          if (u == v) continue;
          const Vec3 &r = b.dots[ib[u]], &s = b.dots[ib[v]];
          if (std::abs(std::acos(std::clamp(r.dot(s), -1.0, 1.0)) - sep) > 0.04) continue;
          const Eigen::Matrix3d rot = triad(r, s) * fa.transpose();
          const double tr = 0.5 * (rot.trace() - 1.0);  // cos of the rotation angle
          if (tr < cos_max) continue;
          int count = 0;
          for (const Vec3& d : a.dots) {
            const Vec3 e = rot * d;
            for (const Vec3& o : b.dots)
              if (e.dot(o) > cos_gate) {
                ++count;
                break;
              }
          }
          const double angle = std::acos(std::clamp(tr, -1.0, 1.0));
          if (count > best || (count == best && angle < best_angle))
            best = count, best_angle = angle, best_rot = rot;
        }
    }
  return best >= min_matches;
}

struct Observation {
  int frame, track;
  Vec3 p;
  double w;
  int dot;  ///< index in its frame's dots
};

// The joint fit of one side's tracks (see the header). `body` is indexed by
// track id and filled for tracks seen at least twice.
struct JointFit {
  Vec3 w = Vec3::Zero();
  std::vector<Vec3> body;
  std::vector<char> has_body;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  int tracks = 0, used = 0, rejected = 0, frames = 0;
  double rms = 0;
  // Where the fit ended, to start another from (trackJackknife): each frame's
  // centre shift, the residuals' variance scale, whether the shifts were on.
  std::vector<Eigen::Vector2d> shift;
  double s2 = 0;
  bool with_offsets = false;
  std::vector<std::vector<char>> used_obs;  ///< [frame][dot]: kept by the outlier cut
};

// The joint fit's normal equations h dx = g, kept in blocks: h = [[A, B],
// [B^T, D]], where A holds the first `nb` parameters (spin and dot positions),
// B couples them to each frame's centre offset and D is block-diagonal, one
// 2 x 2 block per offset (an offset touches only its own frame). A frame's
// column pair of B is non-zero only in the spin's rows and in those of the
// tracks seen in that frame (`rows`), so neither the zeros of D nor most of
// B's are multiplied, and D's are not stored: with 100 frames a side and 30
// tracks, a dense h would be four times the size of A and B.
struct NormalEquations {
  int nb = 0;
  Eigen::MatrixXd a;                   ///< nb x nb
  Eigen::VectorXd ga;                  ///< nb
  Eigen::MatrixXd b;                   ///< nb x 2 per offset
  std::vector<Eigen::Matrix2d> d;      ///< per offset
  std::vector<Eigen::Vector2d> gd;     ///< per offset
  std::vector<std::vector<int>> rows;  ///< per offset: rows of its B columns that may be non-zero

  NormalEquations(int nb_, int offsets)
      : nb(nb_),
        a(nb_, nb_),
        ga(nb_),
        b(nb_, 2 * offsets),
        d(offsets),
        gd(offsets),
        rows(offsets) {}
  int offsets() const { return static_cast<int>(d.size()); }
  void setZero() {
    a.setZero();
    ga.setZero();
    b.setZero();
    for (Eigen::Matrix2d& m : d) m.setZero();
    for (Eigen::Vector2d& v : gd) v.setZero();
  }
};

// Solves the normal equations: the offsets are eliminated (Schur complement
// S = A - B D^-1 B^T, one frame at a time over its own rows; only S's lower
// triangle is formed, all the LDLT reads), so the dense solve is the size of
// A, not of A plus two per frame. Returns dx for the nb parameters followed
// by two per offset. `a_inverse`, when given, receives S^-1: the top-left
// nb x nb block of h^-1.
Eigen::VectorXd solveWithFrameOffsets(const NormalEquations& ne,
                                      Eigen::MatrixXd* a_inverse = nullptr) {
  const int nb = ne.nb, offsets = ne.offsets();
  std::vector<Eigen::Matrix2d> d_inv(static_cast<std::size_t>(offsets));
  Eigen::MatrixXd s = ne.a;
  Eigen::VectorXd rhs = ne.ga;
  // A frame's B rows (b0, b1) and B D^-1 (d0, d1), gathered.
  std::vector<double> b0, b1, d0, d1;
  for (int k = 0; k < offsets; ++k) {
    const std::vector<int>& r = ne.rows[k];
    const std::size_t m = r.size();
    const Eigen::Matrix2d& di = d_inv[k] = ne.d[k].inverse();
    b0.resize(m), b1.resize(m), d0.resize(m), d1.resize(m);
    for (std::size_t i = 0; i < m; ++i) {
      b0[i] = ne.b(r[i], 2 * k), b1[i] = ne.b(r[i], 2 * k + 1);
      d0[i] = b0[i] * di(0, 0) + b1[i] * di(1, 0);
      d1[i] = b0[i] * di(0, 1) + b1[i] * di(1, 1);
    }
    // The lower triangle only: the LDLT reads nothing else. `rows` is sorted,
    // so r[i] >= r[j] for i >= j.
    for (std::size_t j = 0; j < m; ++j) {
      double* col = s.col(r[j]).data();
      for (std::size_t i = j; i < m; ++i) col[r[i]] -= d0[i] * b0[j] + d1[i] * b1[j];
      rhs[r[j]] -= d0[j] * ne.gd[k].x() + d1[j] * ne.gd[k].y();
    }
  }
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(s);
  Eigen::VectorXd dx(nb + 2 * offsets);
  dx.head(nb) = ldlt.solve(rhs);
  for (int k = 0; k < offsets; ++k) {
    Eigen::Vector2d bx = Eigen::Vector2d::Zero();
    for (const int i : ne.rows[k]) bx += ne.b.block<1, 2>(i, 2 * k).transpose() * dx[i];
    dx.segment<2>(nb + 2 * k) = d_inv[k] * (ne.gd[k] - bx);
  }
  if (a_inverse) *a_inverse = ldlt.solve(Eigen::MatrixXd::Identity(nb, nb));
  return dx;
}

// One side's joint fit as it runs: the observations of the tracks seen at
// least twice; the unknowns (the spin, each track's position on the body,
// each frame's centre shift) and their normal equations. Residuals are taken
// in the image plane (x, y of the unit sphere), where the dots' errors are
// isotropic; lifting only served the matching.
struct JointProblem {
  const std::vector<SpinFrame>& frames;
  const std::size_t n;
  const double t0;
  // ---- what is observed
  std::vector<int> param_of;  // per track id: its body-position parameter, -1: seen once
  int tracks = 0;
  std::vector<Observation> obs;
  std::vector<char> frame_used;
  std::vector<int> offset_of;  // per frame: its centre offset, -1: none
  int offsets = 0;
  int nb = 0;  // parameters besides the offsets: spin and body positions
  // ---- the unknowns
  Vec3 w = Vec3::Zero();
  std::vector<Vec3> body;
  std::vector<Eigen::Vector2d> shift;
  std::vector<char> use;  // per observation: kept by the outlier cut
  // Offsets are held at zero until the residuals have given the dots' noise
  // scale, which sets the weight of their prior (the detector's centre sigma).
  bool with_offsets = false;
  double s2 = 0;  // the residuals' variance scale
  int used = 0;
  double rms = 0;
  // The rotation to each frame with observations, and its left Jacobian, at
  // spin w: once per frame, not once per dot.
  std::vector<Eigen::Matrix3d> rot, jl;
  NormalEquations ne{0, 0};

  JointProblem(const std::vector<SpinFrame>& frames_, const std::vector<std::vector<int>>& track_of,
               int next_track, const Vec3& w_start, const JointFit* warm)
      : frames(frames_), n(frames_.size()), t0(frames_.front().t_s), rot(n), jl(n) {
    observe(track_of, next_track);
    start(w_start, warm, next_track);
    nb = 3 + 2 * tracks;
    ne = NormalEquations(nb, offsets);
    couplingRows();
  }

  // Observations of the tracks seen at least twice.
  void observe(const std::vector<std::vector<int>>& track_of, int next_track) {
    std::vector<int> count(next_track, 0);
    for (std::size_t k = 0; k < n; ++k)
      for (const int t : track_of[k])
        if (t >= 0) ++count[t];
    param_of.assign(next_track, -1);
    for (int t = 0; t < next_track; ++t)
      if (count[t] >= 2) param_of[t] = tracks++;
    frame_used.assign(n, 0);
    for (std::size_t k = 0; k < n; ++k)
      for (std::size_t i = 0; i < frames[k].dots.size(); ++i) {
        const int t = track_of[k][i];
        if (t < 0 || param_of[t] < 0) continue;
        obs.push_back({static_cast<int>(k), param_of[t], frames[k].dots[i], weightOf(frames[k], i),
                       static_cast<int>(i)});
        frame_used[k] = 1;
      }
    offset_of.assign(n, -1);
    for (std::size_t k = 0; k < n; ++k)
      if (frame_used[k] && frames[k].centre_sigma > 0) offset_of[k] = offsets++;
  }

  // Where the fit starts: the warm fit's state, or spin w_start with each
  // track's body position the mean of its dots turned back by it.
  void start(const Vec3& w_start, const JointFit* warm, int next_track) {
    w = warm ? warm->w : w_start;
    body.assign(tracks, Vec3::Zero());
    for (const Observation& o : obs)
      body[o.track] += o.w * expRot(w * (frames[o.frame].t_s - t0)).transpose() * o.p;
    for (Vec3& b : body) b.normalize();
    if (warm)
      for (int t = 0; t < next_track; ++t)
        if (param_of[t] >= 0 && warm->has_body[t]) body[param_of[t]] = warm->body[t];
    shift = warm ? warm->shift : std::vector<Eigen::Vector2d>(n, Eigen::Vector2d::Zero());
    use.assign(obs.size(), 1);
    if (warm) {
      for (std::size_t i = 0; i < obs.size(); ++i)
        use[i] = warm->used_obs[obs[i].frame][obs[i].dot];
      s2 = warm->s2;
      with_offsets = warm->with_offsets;
    }
  }

  // The rows of each frame offset's coupling block that may be non-zero.
  void couplingRows() {
    for (const Observation& o : obs) {
      if (offset_of[o.frame] < 0) continue;
      std::vector<int>& r = ne.rows[offset_of[o.frame]];
      if (r.empty()) r = {0, 1, 2};
      r.push_back(3 + 2 * o.track);
      r.push_back(4 + 2 * o.track);
    }
    for (std::vector<int>& r : ne.rows) {
      std::sort(r.begin(), r.end());
      r.erase(std::unique(r.begin(), r.end()), r.end());
    }
  }

  void rotateFrames(const Vec3& spin, bool jacobians = true) {
    for (std::size_t k = 0; k < n; ++k) {
      if (!frame_used[k]) continue;
      const Vec3 phi = spin * (frames[k].t_s - t0);
      rot[k] = expRot(phi);
      if (jacobians) jl[k] = leftJacobian(phi);
    }
  }

  // Each body position's tangent plane: the two directions its step moves it.
  std::vector<Eigen::Matrix<double, 3, 2>> tangentBases() const {
    std::vector<Eigen::Matrix<double, 3, 2>> basis(tracks);
    for (int j = 0; j < tracks; ++j) {
      const Vec3& b = body[j];
      const Vec3 e1 = (std::abs(b.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(b).normalized();
      basis[j].col(0) = e1;
      basis[j].col(1) = b.cross(e1);
    }
    return basis;
  }

  // The normal equations at the current state; the offsets' prior weighted
  // by prior_scale over each frame's centre variance.
  void accumulate(const std::vector<Eigen::Matrix<double, 3, 2>>& basis, double prior_scale) {
    ne.setZero();
    rotateFrames(w);
    for (std::size_t i = 0; i < obs.size(); ++i) {
      if (!use[i]) continue;
      const Observation& o = obs[i];
      const double tau = frames[o.frame].t_s - t0;
      const Eigen::Matrix3d& e = rot[o.frame];
      const Vec3 m = e * body[o.track];
      const int off = with_offsets ? offset_of[o.frame] : -1;
      Eigen::Vector2d r = o.p.head<2>() - m.head<2>();
      if (off >= 0) r -= shift[o.frame];
      Eigen::Matrix<double, 2, 5> jac;
      jac.leftCols<3>() = (-skew(m) * jl[o.frame] * tau).topRows<2>();
      jac.rightCols<2>() = (e * basis[o.track]).topRows<2>();
      const int pb = 3 + 2 * o.track;
      const Eigen::Matrix<double, 5, 5> jtj = o.w * jac.transpose() * jac;
      const Eigen::Matrix<double, 5, 1> jtr = o.w * jac.transpose() * r;
      ne.a.topLeftCorner<3, 3>() += jtj.topLeftCorner<3, 3>();
      ne.a.block<3, 2>(0, pb) += jtj.topRightCorner<3, 2>();
      ne.a.block<2, 3>(pb, 0) += jtj.bottomLeftCorner<2, 3>();
      ne.a.block<2, 2>(pb, pb) += jtj.bottomRightCorner<2, 2>();
      ne.ga.head<3>() += jtr.head<3>();
      ne.ga.segment<2>(pb) += jtr.tail<2>();
      if (off >= 0) {
        // d(model)/d(shift) = identity.
        ne.b.block<3, 2>(0, 2 * off) += o.w * jac.leftCols<3>().transpose();
        ne.b.block<2, 2>(pb, 2 * off) += o.w * jac.rightCols<2>().transpose();
        ne.d[off] += o.w * Eigen::Matrix2d::Identity();
        ne.gd[off] += o.w * r;
      }
    }
    if (with_offsets)
      for (std::size_t k = 0; k < n; ++k) {
        if (offset_of[k] < 0) continue;
        const int po = offset_of[k];
        const double lambda = prior_scale / (frames[k].centre_sigma * frames[k].centre_sigma);
        ne.d[po] += lambda * Eigen::Matrix2d::Identity();
        ne.gd[po] -= lambda * shift[k];
      }
    // A track whose observations were all dropped leaves its block empty;
    // offsets are unused until enabled.
    ne.a.diagonal().tail(nb - 3).array() += 1e-12;
    for (Eigen::Matrix2d& m : ne.d) m.diagonal().array() += with_offsets ? 1e-12 : 1.0 + 1e-12;
  }

  // One Gauss-Newton step: true once it no longer moves the spin.
  Result<bool> step(double prior_scale) {
    const std::vector<Eigen::Matrix<double, 3, 2>> basis = tangentBases();
    accumulate(basis, prior_scale);
    const Eigen::VectorXd dx = solveWithFrameOffsets(ne);
    if (!dx.allFinite()) return fail("spin: the dot fit is degenerate (dots on one line?)");
    w += dx.head<3>();
    for (int j = 0; j < tracks; ++j)
      body[j] = (body[j] + basis[j] * dx.segment<2>(3 + 2 * j)).normalized();
    if (with_offsets)
      for (std::size_t k = 0; k < n; ++k)
        if (offset_of[k] >= 0) shift[k] += dx.segment<2>(nb + 2 * offset_of[k]);
    return dx.norm() < 1e-12 + 1e-10 * w.norm();
  }

  // The residuals: the noise scale s2 (the offsets' prior counting as data:
  // its penalty joins them), and the observations beyond 4 robust sigmas
  // dropped. Turns the offsets on after the first round. True when nothing
  // changed and a refit is not needed.
  Result<bool> cutOutliers(double prior_scale, int outer) {
    std::vector<double> rn(obs.size(), 0), absr;
    double ss = 0, ss_unw = 0;
    used = 0;
    rotateFrames(w, false);
    for (std::size_t i = 0; i < obs.size(); ++i) {
      const Observation& o = obs[i];
      const Vec3 m = rot[o.frame] * body[o.track];
      Eigen::Vector2d r = o.p.head<2>() - m.head<2>();
      if (with_offsets && offset_of[o.frame] >= 0) r -= shift[o.frame];
      rn[i] = std::sqrt(o.w) * r.norm();
      if (!use[i]) continue;
      absr.push_back(rn[i]);
      ss += rn[i] * rn[i];
      ss_unw += r.squaredNorm();
      ++used;
    }
    const int dof = 2 * used - nb;
    if (dof < 1)
      return fail("spin: " + std::to_string(used) + " dot positions in " + std::to_string(tracks) +
                  " tracks are too few to fit a spin");
    double penalty = 0;
    if (with_offsets)
      for (std::size_t k = 0; k < n; ++k)
        if (offset_of[k] >= 0)
          penalty += prior_scale * shift[k].squaredNorm() /
                     (frames[k].centre_sigma * frames[k].centre_sigma);
    s2 = (ss + penalty) / dof;
    rms = std::sqrt(ss_unw / used);
    std::nth_element(absr.begin(), absr.begin() + absr.size() / 2, absr.end());
    // Norms of 2-D Gaussian residuals: median = 1.1774 sigma.
    const double sigma = absr[absr.size() / 2] / 1.1774;
    bool changed = false;
    for (std::size_t i = 0; i < obs.size(); ++i) {
      const char keep = rn[i] <= 4.0 * sigma;
      changed |= keep != use[i];
      use[i] = keep;
    }
    const bool enable = offsets > 0 && !with_offsets;
    with_offsets = with_offsets || offsets > 0;
    return !changed && !enable && outer > 0;
  }

  // The fit as JointFit keeps it (body positions by track id); the spin's
  // covariance only for a full fit (`covariance`).
  JointFit result(int next_track, bool covariance) {
    JointFit out;
    out.w = w;
    if (covariance) {
      Eigen::MatrixXd a_inverse;
      solveWithFrameOffsets(ne, &a_inverse);
      out.cov = a_inverse.topLeftCorner<3, 3>() * s2;
    }
    out.rms = rms;
    out.shift = shift;
    out.s2 = s2;
    out.with_offsets = with_offsets;
    out.used_obs.resize(n);
    for (std::size_t k = 0; k < n; ++k) out.used_obs[k].assign(frames[k].dots.size(), 0);
    for (std::size_t i = 0; i < obs.size(); ++i) out.used_obs[obs[i].frame][obs[i].dot] = use[i];
    out.body.assign(next_track, Vec3::Zero());
    out.has_body.assign(next_track, 0);
    for (int t = 0; t < next_track; ++t)
      if (param_of[t] >= 0) out.body[t] = body[param_of[t]], out.has_body[t] = 1;
    out.tracks = tracks;
    out.used = used;
    out.rejected = static_cast<int>(obs.size()) - used;
    out.frames = static_cast<int>(std::count(frame_used.begin(), frame_used.end(), 1));
    return out;
  }
};

// `warm`: a fit of the same frames to start from (its spin, dot positions,
// shifts, noise scale and outlier cut), for a refit with one track fewer: one
// Gauss-Newton step from there (the delete-one estimate to second order),
// without a new outlier cut. Otherwise the spin starts at w_start: Gauss-
// Newton steps, then the outlier cut and the noise scale, four rounds at
// most, the frames' centre offsets freed after the first.
Result<JointFit> jointFit(const std::vector<SpinFrame>& frames,
                          const std::vector<std::vector<int>>& track_of, int next_track,
                          const Vec3& w_start, const JointFit* warm = nullptr) {
  JointProblem p(frames, track_of, next_track, w_start, warm);
  const int outer_rounds = warm ? 1 : 4, inner_steps = warm ? 1 : 20;
  for (int outer = 0; outer < outer_rounds; ++outer) {
    const double prior_scale = p.with_offsets ? p.s2 : 0.0;
    for (int it = 0; it < inner_steps; ++it) {
      const Result<bool> converged = p.step(prior_scale);
      if (!converged) return converged.error();
      if (*converged) break;
    }
    if (warm) break;  // the cut and the noise scale are the full fit's
    const Result<bool> settled = p.cutOutliers(prior_scale, outer);
    if (!settled) return settled.error();
    if (*settled) break;
  }
  return p.result(next_track, warm == nullptr);
}

// The spin's spread when one track (one physical dot) at a time is left out,
// as a covariance (jackknife: (m - 1)/m sum of outer products about the mean).
// A dot's image position is biased in a way that depends on where it is on
// the sphere (shading pulls its centroid towards the light, the limb
// foreshortens it): each track then carries its own false rotation, which the
// fit's residuals, smooth along the track, hardly show; the tracks' disagreement
// does. With few tracks that spread is itself uncertain (its relative
// standard deviation is about sqrt(2 / (m - 1))), so it is pooled with the
// fit's covariance by degrees of freedom, the fit counting as kFitPriorDof:
// 20 tracks give 80 % of the jackknife, 4 tracks 38 %, 3 tracks 29 %. Empty
// with fewer than 3 tracks or when fewer than 3 refits converge. (Two dots in
// view for a whole side make 3 or so tracks; from 4 up, such a side kept the
// fit's covariance alone, 7 of its sigmas short on a lab shot.)
std::optional<Eigen::Matrix3d> trackJackknife(const std::vector<SpinFrame>& frames,
                                              const std::vector<std::vector<int>>& track_of,
                                              int next_track, const JointFit& fit) {
  if (fit.tracks < 3) return std::nullopt;
  std::vector<Vec3> w;
  for (int t = 0; t < next_track; ++t) {
    if (!fit.has_body[t]) continue;
    std::vector<std::vector<int>> without = track_of;
    for (auto& frame : without) std::replace(frame.begin(), frame.end(), t, -1);
    if (auto f = jointFit(frames, without, next_track, fit.w, &fit)) w.push_back(f->w);
  }
  const int m = static_cast<int>(w.size());
  if (m < 3) return std::nullopt;
  Vec3 mean = Vec3::Zero();
  for (const Vec3& v : w) mean += v / m;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Vec3& v : w) cov += (v - mean) * (v - mean).transpose();
  cov *= (m - 1.0) / m;
  constexpr double kFitPriorDof = 5;
  const double dof = m - 1.0;
  return (dof * cov + kFitPriorDof * fit.cov) / (dof + kFitPriorDof);
}

// The larger of two covariances in every direction: a + the positive part of
// (b - a), so that the result is at least a and at least b.
Eigen::Matrix3d atLeast(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(b - a);
  const Vec3 excess = es.eigenvalues().cwiseMax(0.0);
  return a + es.eigenvectors() * excess.asDiagonal() * es.eigenvectors().transpose();
}

}  // namespace

namespace {

// Dots followed from frame to frame, chained into tracks (track_of[k][i]:
// frame k's dot i's track, -1: none), and the mean rotation rate the pairs
// gave (the first fit's start).
struct Tracks {
  std::vector<std::vector<int>> track_of;
  int next_track = 0;        // tracks 0 .. next_track - 1
  int pairs = 0;             // consecutive frames matched
  std::vector<char> paired;  // paired[k]: frames k and k + 1 matched
  Vec3 sum_w = Vec3::Zero();
  double sum_dt = 0;

  explicit Tracks(const std::vector<SpinFrame>& frames)
      : track_of(frames.size()), paired(frames.size(), 0) {
    for (std::size_t k = 0; k < frames.size(); ++k) track_of[k].assign(frames[k].dots.size(), -1);
  }
  // Frames k and k + 1's matched dots onto one track each. A dot of frame
  // k + 1 already on a track (from the pair after it) joins the two tracks.
  void chain(std::size_t k, const std::vector<Match>& m) {
    paired[k] = 1;
    for (const Match& mm : m) {
      int& ta = track_of[k][mm.first];
      int& tb = track_of[k + 1][mm.second];
      if (ta < 0) ta = tb >= 0 ? tb : next_track++;
      if (tb >= 0 && tb != ta) relabel(tb, ta);
      tb = ta;
    }
  }
  void relabel(int from, int to) {
    for (auto& frame : track_of) std::replace(frame.begin(), frame.end(), from, to);
  }
};

// Consecutive frames with at least `min_matches` dots each matched by the
// rotation between them: predicted from the mean rate so far when there is
// one, else (with `search`) searched for (searchRotation), then refined on
// the matches. Pairs an earlier pass matched are kept as they are.
void matchPairs(const std::vector<SpinFrame>& frames, const SpinOptions& opt, int min_matches,
                double cos_gate, bool search, Tracks& tr) {
  bool have_pred = tr.sum_dt > 0;  // from an earlier pass
  for (std::size_t k = 0; k + 1 < frames.size(); ++k) {
    if (tr.paired[k]) continue;
    const SpinFrame &a = frames[k], &b = frames[k + 1];
    const double dt = b.t_s - a.t_s;
    if (static_cast<int>(std::min(a.dots.size(), b.dots.size())) < min_matches) continue;
    Eigen::Matrix3d rot;
    std::vector<Match> m;
    bool ok = false;
    if (have_pred) {
      rot = expRot(tr.sum_w / tr.sum_dt * dt);
      m = matchDots(a, b, rot, cos_gate);
      const double need = 0.5 * static_cast<double>(std::min(a.dots.size(), b.dots.size()));
      ok = static_cast<double>(m.size()) >= need && refinePair(a, b, m, rot, cos_gate, min_matches);
    }
    if (!ok && search &&
        searchRotation(a, b, opt.max_rotation_per_frame_rad, cos_gate, min_matches, rot)) {
      m = matchDots(a, b, rot, cos_gate);
      ok = refinePair(a, b, m, rot, cos_gate, min_matches);
    }
    if (!ok) continue;
    const Eigen::AngleAxisd aa(rot);
    // Prediction for the next pair: the mean angular velocity so far.
    tr.sum_w += aa.axis() * aa.angle();
    tr.sum_dt += dt;
    have_pred = true;
    ++tr.pairs;
    tr.chain(k, m);
  }
}

// The tracks from the pairs: matched by rotation; with few dots in view,
// bootstrapped from pairs of two (the smaller of the two possible rotations
// is taken; the fit's residuals catch a wrong one); with one dot in view at
// a time, each dot followed to its nearest neighbour in the next frame (a
// turn of less than the gate per frame: a dot's path over several frames
// still fixes the spin; the fit's covariance says how well).
Result<Tracks> trackDots(const std::vector<SpinFrame>& frames, const SpinOptions& opt) {
  const double cos_gate = std::cos(opt.match_gate_rad);
  Tracks tr(frames);
  matchPairs(frames, opt, opt.min_matches, cos_gate, true, tr);
  // Then the pairs with two dots matched: by the rotation the pairs with more
  // predict when there are any (two dots alone leave the search two
  // rotations to choose from), else searched for. With two dots in view most
  // of a side's pairs have only two, and a spin from the one or two pairs
  // that showed three is too rough to regrow the tracks far from them (a 93
  // rad/s spin came out at 80).
  if (opt.min_matches > 2) matchPairs(frames, opt, 2, cos_gate, tr.pairs == 0, tr);
  if (tr.pairs == 0) {
    for (std::size_t k = 0; k + 1 < frames.size(); ++k) {
      const std::vector<Match> m =
          matchDots(frames[k], frames[k + 1], Eigen::Matrix3d::Identity(), cos_gate);
      if (m.empty()) continue;
      ++tr.pairs;
      tr.chain(k, m);
    }
    tr.sum_w = Vec3::Zero();
    tr.sum_dt = 1;
  }
  if (tr.pairs == 0)
    return fail(
        "spin: no dot could be followed from one frame to the next (no dots in view, "
        "or the sphere turns too far between frames)");
  return tr;
}

// Every dot re-assigned with the first fit: to the track whose predicted
// place it is the mutual best match of (tracks grow across frames the
// pairwise matching skipped), then the dots on no track yet joined into new
// tracks from consecutive frames, predicted with the spin. grown_next: one
// past the last track.
std::vector<std::vector<int>> regrowTracks(const std::vector<SpinFrame>& frames,
                                           const JointFit& first, int next_track, double cos_tight,
                                           int& grown_next) {
  const std::size_t n = frames.size();
  const double t0 = frames.front().t_s;
  std::vector<std::vector<int>> grown(n);
  for (std::size_t k = 0; k < n; ++k) {
    grown[k].assign(frames[k].dots.size(), -1);
    const Eigen::Matrix3d o = expRot(first.w * (frames[k].t_s - t0));
    std::vector<int> best_track(frames[k].dots.size(), -1);
    std::vector<double> best_c(frames[k].dots.size(), cos_tight);
    std::vector<int> best_dot(next_track, -1);
    std::vector<double> best_dc(next_track, cos_tight);
    for (int t = 0; t < next_track; ++t) {
      if (!first.has_body[t]) continue;
      const Vec3 q = o * first.body[t];
      for (std::size_t i = 0; i < frames[k].dots.size(); ++i) {
        const double c = q.dot(frames[k].dots[i]);
        if (c > best_c[i]) best_c[i] = c, best_track[i] = t;
        if (c > best_dc[t]) best_dc[t] = c, best_dot[t] = static_cast<int>(i);
      }
    }
    for (std::size_t i = 0; i < frames[k].dots.size(); ++i)
      if (best_track[i] >= 0 && best_dot[best_track[i]] == static_cast<int>(i))
        grown[k][i] = best_track[i];
  }
  grown_next = next_track;
  for (std::size_t k = 0; k + 1 < n; ++k) {
    SpinFrame a, b;
    std::vector<int> ia, ib;
    for (std::size_t i = 0; i < frames[k].dots.size(); ++i)
      if (grown[k][i] < 0 || grown[k][i] >= next_track)
        a.dots.push_back(frames[k].dots[i]), ia.push_back(static_cast<int>(i));
    for (std::size_t i = 0; i < frames[k + 1].dots.size(); ++i)
      if (grown[k + 1][i] < 0)
        b.dots.push_back(frames[k + 1].dots[i]), ib.push_back(static_cast<int>(i));
    if (a.dots.empty() || b.dots.empty()) continue;
    const Eigen::Matrix3d rot = expRot(first.w * (frames[k + 1].t_s - frames[k].t_s));
    for (const Match& mm : matchDots(a, b, rot, cos_tight)) {
      int& ta = grown[k][ia[mm.first]];
      if (ta < 0) ta = grown_next++;
      grown[k + 1][ib[mm.second]] = ta;
    }
  }
  return grown;
}

}  // namespace

Result<SpinFit> fitSpin(const std::vector<SpinFrame>& frames, const SpinOptions& opt) {
  const std::size_t n = frames.size();
  if (n < 2) return fail("spin: " + std::to_string(n) + " frames with dots; need at least 2");
  for (std::size_t k = 1; k < n; ++k)
    if (!(frames[k].t_s > frames[k - 1].t_s))
      return fail("spin: frame times must increase (frame " + std::to_string(k) + ")");
  Result<Tracks> tr = trackDots(frames, opt);
  if (!tr) return tr.error();
  SpinFit out;
  out.pairs = tr->pairs;
  out.track_of = std::move(tr->track_of);
  // The first fit, then every dot re-assigned with it, and the final fit (the
  // first kept when the grown tracks do not fit).
  auto first = jointFit(frames, out.track_of, tr->next_track, tr->sum_w / tr->sum_dt);
  if (!first) return first.error();
  int tracks_total = 0;
  std::vector<std::vector<int>> grown =
      regrowTracks(frames, *first, tr->next_track, std::cos(opt.regrow_gate_rad), tracks_total);
  auto fit = jointFit(frames, grown, tracks_total, first->w);
  if (!fit) {
    fit = std::move(first);
    tracks_total = tr->next_track;
  } else {
    out.track_of = std::move(grown);
  }
  out.spin_rad_s = fit->w;
  out.covariance = fit->cov;
  if (const auto jack = trackJackknife(frames, out.track_of, tracks_total, *fit))
    out.covariance = atLeast(fit->cov, *jack);
  out.sigma_rad_s = out.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  out.tracks = fit->tracks;
  out.observations = fit->used;
  out.rejected = fit->rejected;
  out.frames = fit->frames;
  out.residual_rms_rad = fit->rms;
  return out;
}

}  // namespace collide::vision
