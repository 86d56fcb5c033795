#include "vision/sphere_tracks.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "vision/frame_parallel.hpp"

namespace collide::vision {

namespace {

double medianOf(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

/// Every frame's round blobs, as measured.
struct Detected {
  std::vector<TrackFrame> frames;
  std::vector<std::vector<SphereMeasurement>> blobs;  ///< per frame, sphere-like ones
  int unreadable = 0, dark = 0;
  std::string first_note;   ///< the detector's reason when a frame had nothing
  std::string first_error;  ///< the first frame that could not be read
};

/// One frame's detections, kept if sphere-like (and of the expected size).
void addFrame(Detected& d, std::int64_t index, const Result<Frame>& frame,
              const FrameSpheres& found, const SphereTrackSettings& set) {
  if (!frame || !frame->good()) {
    ++d.unreadable;
    if (!frame && d.first_error.empty()) d.first_error = frame.error().message;
    return;
  }
  d.dark += found.dark_spheres;
  std::vector<SphereMeasurement> kept;
  for (const SphereMeasurement& m : found.spheres) {
    const double r = m.circle.radius;
    if (set.expected_radius_px > 0 && std::abs(r / set.expected_radius_px - 1) > 0.3) continue;
    kept.push_back(m);
  }
  if (kept.empty() && d.first_note.empty() && !found.notes.empty())
    d.first_note = found.notes.front();
  TrackFrame tf;
  tf.index = index;
  tf.id = frame->id;
  tf.blobs = static_cast<int>(kept.size());
  d.frames.push_back(std::move(tf));
  d.blobs.push_back(std::move(kept));
}

/// Frames are read in order on the calling thread (a video can only be read
/// one frame after the other), a batch at a time, and each batch's frames are
/// detected on every core (forEachFrame: the same numbers on any number of
/// threads). A batch is 8 frames per core, or fewer when they would hold more
/// than set.batch_bytes of pixels (a large camera on many cores): one per core
/// at least.
Detected detectAll(const FrameSource& src, const SphereTrackSettings& set,
                   const std::function<void(int, int)>& progress) {
  const SphereDetector detector(set.detector);
  const std::int64_t threads = frameThreads();
  Detected d;
  std::vector<Result<Frame>> frames;
  std::vector<FrameSpheres> found;
  for (std::int64_t first = 0; first < src.count;) {
    frames.clear();
    const std::int64_t most = std::min(8 * threads, src.count - first);
    std::size_t bytes = 0;
    for (std::int64_t k = 0; k < most && (k < threads || bytes < set.batch_bytes); ++k) {
      frames.push_back(src.read(first + k));
      if (frames.back()) bytes += frames.back()->image.total() * frames.back()->image.elemSize();
    }
    found.assign(frames.size(), FrameSpheres{});
    forEachFrame(frames.size(), [&](std::size_t k) {
      if (frames[k] && frames[k]->good())
        found[k] = detector.detect(frames[k]->image, src.max_value);
    });
    for (std::size_t k = 0; k < frames.size(); ++k)
      addFrame(d, first + static_cast<std::int64_t>(k), frames[k], found[k], set);
    first += static_cast<std::int64_t>(frames.size());
    if (progress) progress(static_cast<int>(first), static_cast<int>(src.count));
  }
  return d;
}

/// The most frequent number of blobs among frames with any (ties: the larger).
int mostFrequentCount(const Detected& d) {
  std::map<int, int> histogram;
  for (const auto& b : d.blobs)
    if (!b.empty()) ++histogram[static_cast<int>(b.size())];
  int best = 0, best_n = 0;
  for (const auto& [count, n] : histogram)
    if (n >= best_n) {
      best = count;
      best_n = n;
    }
  return best;
}

/// A track's state while walking: its last two positions and how long ago.
struct TrackState {
  bool seen = false;
  double u = 0, v = 0, du = 0, dv = 0;  ///< last position, px; displacement per frame
  double radius = 0;
  std::int64_t last_index = 0;
};

/// Joint assignment of candidates to tracks: most tracks matched, then least
/// summed squared distance to the predictions; each match within its gate
/// and with a radius within 30 % of the track's.
struct Assigner {
  const std::vector<SphereMeasurement>& cand;
  std::vector<double> pu, pv, gate, radius;
  std::vector<int> current, best;
  int best_matched = -1;
  double best_cost = 0;

  void search(std::size_t t, int matched, double cost, std::vector<char>& used) {
    if (t == pu.size()) {
      if (matched > best_matched || (matched == best_matched && cost < best_cost)) {
        best_matched = matched;
        best_cost = cost;
        best = current;
      }
      return;
    }
    current[t] = -1;
    search(t + 1, matched, cost, used);
    for (std::size_t c = 0; c < cand.size(); ++c) {
      if (used[c]) continue;
      const double d2 =
          std::pow(cand[c].circle.u - pu[t], 2) + std::pow(cand[c].circle.v - pv[t], 2);
      if (d2 > gate[t] * gate[t]) continue;
      if (radius[t] > 0 && std::abs(cand[c].circle.radius / radius[t] - 1) > 0.3) continue;
      used[c] = 1;
      current[t] = static_cast<int>(c);
      search(t + 1, matched + 1, cost + d2, used);
      used[c] = 0;
      current[t] = -1;
    }
  }
};

TrackedSphere fromMeasurement(const SphereMeasurement& m) {
  TrackedSphere s;
  s.found = true;
  s.u_px = m.circle.u;
  s.v_px = m.circle.v;
  s.radius_px = m.circle.radius;
  s.sigma_px = std::max(m.circle.sigma_u, m.circle.sigma_v);
  s.radius_sigma_px = m.circle.sigma_radius;
  s.cut_by_border = m.cut_by_border;
  s.near_border = !m.cut_by_border && m.border_profiles > 0;
  s.touching = m.touching;
  return s;
}

/// Walks from the seed frame in one direction, assigning each frame's blobs.
void walk(Detected& d, std::vector<TrackState> state, int seed, int step, int n_spheres) {
  for (int k = seed + step; k >= 0 && k < static_cast<int>(d.frames.size()); k += step) {
    TrackFrame& f = d.frames[k];
    Assigner a{d.blobs[k]};
    for (const TrackState& s : state) {
      const double frames_since = std::abs(static_cast<double>(f.index - s.last_index));
      a.pu.push_back(s.u + s.du * frames_since * step);
      a.pv.push_back(s.v + s.dv * frames_since * step);
      const double base = std::max(s.radius, 2 * std::hypot(s.du, s.dv));
      // One sphere has nothing to be confused with: any blob of its size.
      a.gate.push_back(n_spheres == 1 ? std::numeric_limits<double>::infinity()
                                      : base * (1 + 0.5 * (frames_since - 1)));
      a.radius.push_back(s.radius);
    }
    a.current.assign(state.size(), -1);
    std::vector<char> used(a.cand.size(), 0);
    a.search(0, 0, 0.0, used);
    for (std::size_t t = 0; t < state.size(); ++t) {
      if (a.best[t] < 0) continue;
      const SphereMeasurement& m = a.cand[a.best[t]];
      f.spheres[t] = fromMeasurement(m);
      TrackState& s = state[t];
      const double frames_since = std::abs(static_cast<double>(f.index - s.last_index));
      if (frames_since > 0 && !m.touching && !m.cut_by_border) {
        s.du = (m.circle.u - s.u) / (frames_since * step);
        s.dv = (m.circle.v - s.v) / (frames_since * step);
      }
      s.u = m.circle.u;
      s.v = m.circle.v;
      if (!m.touching && !m.cut_by_border) s.radius = m.circle.radius;
      s.last_index = f.index;
    }
  }
}

/// The first frame with every sphere apart (none touching; outlines whole
/// when such a frame exists), or -1.
int seedFrame(const Detected& d, int n) {
  for (const bool whole : {true, false})
    for (std::size_t k = 0; k < d.frames.size(); ++k) {
      const auto& b = d.blobs[k];
      if (static_cast<int>(b.size()) != n) continue;
      bool ok = true;
      for (const auto& m : b) ok = ok && !m.touching && !(whole && m.cut_by_border);
      if (ok) return static_cast<int>(k);
    }
  return -1;
}

/// Two spheres touching, or closer than the margin or their relative motion
/// in one frame: a contact in that frame.
void markContacts(std::vector<TrackFrame>& frames, double margin_px) {
  for (std::size_t k = 0; k < frames.size(); ++k) {
    auto& sp = frames[k].spheres;
    for (std::size_t a = 0; a < sp.size(); ++a)
      for (std::size_t b = a + 1; b < sp.size(); ++b) {
        if (!sp[a].found || !sp[b].found) continue;
        double margin = margin_px;
        for (const std::size_t j : {k - 1, k + 1}) {
          if (j >= frames.size()) continue;  // k - 1 wraps to a huge value at k = 0
          const auto& o = frames[j].spheres;
          if (!o[a].found || !o[b].found) continue;
          const double rel_u = (sp[a].u_px - sp[b].u_px) - (o[a].u_px - o[b].u_px);
          const double rel_v = (sp[a].v_px - sp[b].v_px) - (o[a].v_px - o[b].v_px);
          margin = std::max(margin, std::hypot(rel_u, rel_v));
        }
        const double gap = std::hypot(sp[a].u_px - sp[b].u_px, sp[a].v_px - sp[b].v_px) -
                           sp[a].radius_px - sp[b].radius_px;
        if (gap < margin || sp[a].touching || sp[b].touching) {
          sp[a].contact = sp[b].contact = true;
        }
      }
  }
}

std::string polarityName(SphereDetectorSettings::Polarity p) {
  using P = SphereDetectorSettings::Polarity;
  return p == P::Dark ? "dark" : p == P::Bright ? "bright" : "auto";
}

}  // namespace

Result<SphereTracks> trackFootageSpheres(const FrameSource& source,
                                         const SphereTrackSettings& settings,
                                         const std::function<void(int, int)>& progress) {
  if (settings.spheres < 0 || settings.spheres > 3)
    return fail("the number of spheres must be 1, 2 or 3 (or automatic), not " +
                std::to_string(settings.spheres));
  Detected d = detectAll(source, settings, progress);
  if (d.frames.empty())
    return fail("no frame could be read (" + std::to_string(d.unreadable) + " tried" +
                (d.first_error.empty() ? "" : ": " + d.first_error) + ")");
  SphereTracks out;
  out.frames_unreadable = d.unreadable;
  out.dark_spheres = mostlyDark(d.dark, static_cast<int>(d.frames.size()));
  const int seen = mostFrequentCount(d);
  if (seen == 0)
    return fail("no sphere found in any of the " + std::to_string(d.frames.size()) +
                " frames (polarity " + polarityName(settings.detector.polarity) +
                (d.first_note.empty() ? "" : "; " + d.first_note) +
                "): check that the spheres are in view and exposed, and the polarity "
                "(--polarity dark for silhouettes on a bright backlight, bright for lit spheres "
                "on a dark background)");
  const int n = settings.spheres > 0 ? settings.spheres : seen;
  if (n > 3)
    return fail("most frames show " + std::to_string(seen) +
                " round blobs; track follows 1 to 3 spheres: give --spheres N");
  const int seed = seedFrame(d, n);
  if (seed < 0)
    return fail("never " + std::to_string(n) + " separate sphere" + (n > 1 ? "s" : "") +
                " in one frame (most frames show " + std::to_string(seen) +
                "): give the right --spheres");
  out.spheres = n;
  out.seed_index = d.frames[seed].index;
  for (auto& f : d.frames) f.spheres.assign(n, TrackedSphere{});
  // Sphere 1 is the leftmost at the seed.
  std::vector<SphereMeasurement> at_seed = d.blobs[seed];
  std::sort(at_seed.begin(), at_seed.end(),
            [](const auto& a, const auto& b) { return a.circle.u < b.circle.u; });
  std::vector<TrackState> state(n);
  for (int t = 0; t < n; ++t) {
    d.frames[seed].spheres[t] = fromMeasurement(at_seed[t]);
    state[t] = {true, at_seed[t].circle.u,      at_seed[t].circle.v, 0,
                0,    at_seed[t].circle.radius, d.frames[seed].index};
  }
  walk(d, state, seed, +1, n);
  walk(d, state, seed, -1, n);
  markContacts(d.frames, settings.contact_margin_px);
  for (int t = 0; t < n; ++t) {
    std::vector<double> r;
    for (const auto& f : d.frames)
      if (f.spheres[t].found && !f.spheres[t].cut_by_border && !f.spheres[t].touching)
        r.push_back(f.spheres[t].radius_px);
    out.radius_px.push_back(medianOf(r));
  }
  int extra = 0;
  for (std::size_t k = 0; k < d.frames.size(); ++k) {
    int assigned = 0;
    for (const auto& s : d.frames[k].spheres) assigned += s.found;
    extra += d.frames[k].blobs > assigned;
  }
  if (extra > 0)
    out.notes.push_back(std::to_string(extra) + " frames show round blobs that are not on a track");
  if (d.unreadable > 0)
    out.notes.push_back(std::to_string(d.unreadable) +
                        " frames could not be read and are left out" +
                        (d.first_error.empty() ? "" : " (" + d.first_error + ")"));
  out.frames = std::move(d.frames);
  return out;
}

}  // namespace collide::vision
