#pragma once
// Shots with every field set to a distinct, non-default value, a field-by-field
// comparison, scratch folders, and a way to run code under a file-size limit
// (a disk that fills up, without root). Shared by the app/ storage tests.
#include <gtest/gtest.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <sstream>
#include <string>

#include "hw/shot.hpp"

namespace collide::testing {

struct ShotSpec {
  std::string id = "20260314-101500-0001";
  std::int64_t wall_time_unix_ns = 1773483300123456789LL;  // 2026-03-14 10:15:00 UTC
  vision::PixelFormat format = vision::PixelFormat::Mono8;
  int frames = 6, width = 40, height = 30;
  bool truth = true;
  bool results = true;
  hw::ShotStatus status = hw::ShotStatus::Ok;
  std::string material = "nylon-6/6";
  std::string rig_name = "bench-rig";
  double commanded_kPa = 150.0;
  /// Smooth images compress; random ones test every bit of every pixel.
  bool smooth_images = false;
  unsigned seed = 7;
};

inline std::string sampleResultsJson() {
  return R"({"e": 0.93, "beta": 0.41, "f": 0.17, "gamma_deg": 135.5, "vn_m_s": -1.25,)"
         R"( "vs_m_s": 0.8, "quality_flags": ["grazing", "few_frames"], "note": "x"})";
}

inline hw::Shot makeShot(const ShotSpec& spec = {}) {
  std::mt19937 rng(spec.seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  hw::Shot s;
  s.id = spec.id;
  s.wall_time_unix_ns = spec.wall_time_unix_ns;
  s.program_version = "0.1.0-test";
  s.rig_name = spec.rig_name;
  s.rig_profile_toml = "[rig]\nname = \"" + spec.rig_name +
                       "\"\n# a comment with UTF-8: \xc2\xb1 1 kPa\n[camera]\nbackend = \"sim\"\n";
  s.status = spec.status;
  if (spec.status == hw::ShotStatus::Failed)
    s.failure_reason = "regulator did not settle within 5 s: check the air supply";

  s.launchers[0] = {2.5, spec.commanded_kPa, spec.commanded_kPa - 0.75, 123456789012LL, 15000};
  // Pressure set directly: no wanted speed (NaN must survive the round trip).
  s.launchers[1] = {std::numeric_limits<double>::quiet_NaN(), spec.commanded_kPa + 12.5,
                    spec.commanded_kPa + 12.0, 123456799012LL, 15250};
  s.steps = {{"set_pressure", 1000, "p0 = 150 kPa"},
             {"settled", 2500000000LL, ""},
             {"fire", 2600000000LL, "both valves"},
             {"collected", 2900000000LL, "\xc2\xb5s ok"}};

  auto& c = s.camera;
  c.backend = "sim";
  c.device = "sim://0";
  c.roi_x = 8;
  c.roi_y = 4;
  c.width = spec.width;
  c.height = spec.height;
  c.format = spec.format;
  c.fps = 1000.0;
  c.exposure_us = 200.5;
  c.gain_db = 3.25;
  c.pre_trigger_frames = 2;
  c.post_trigger_frames = spec.frames - 2;

  auto& sc = s.scene;
  sc.pixel_size_m = 1.3e-4;
  sc.diameter_m = {0.0254, 0.0127};
  sc.mass_kg = {0.00972, 0.00121};
  sc.material_name = spec.material;
  sc.origin_u_px = 20.5;
  sc.origin_v_px = 15.25;

  auto& b = s.burst;
  b.format = spec.format;
  b.fps = 1000.0;
  b.exposure_us = 200.5;
  b.complete = spec.frames >= 4;
  b.note = b.complete ? "" : "camera stopped early";
  const int max_value = vision::maxValue(spec.format);
  std::uniform_int_distribution<int> pixel(0, max_value);
  for (int i = 0; i < spec.frames; ++i) {
    vision::Frame f;
    f.id = i - 2;
    f.timestamp_ns = 5000000000LL + i * 1000000LL + (i % 3);
    cv::Mat image(spec.height, spec.width, vision::cvType(spec.format));
    for (int y = 0; y < spec.height; ++y)
      for (int x = 0; x < spec.width; ++x) {
        const int v = spec.smooth_images ? (x + y + i) % (max_value + 1) : pixel(rng);
        if (image.depth() == CV_8U)
          image.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(v);
        else
          image.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(v);
      }
    f.image = image;
    if (i == 1) {
      // A frame the transport failed: status kept, no image data at all.
      f.status = vision::FrameStatus::Failed;
      f.image = cv::Mat();
    } else if (i == 2) {
      f.status = vision::FrameStatus::Incomplete;
    } else if (i == 3) {
      // A view into a larger buffer (rows not contiguous), as a camera may hand over.
      cv::Mat big(spec.height + 4, spec.width + 6, image.type(), cv::Scalar(1));
      image.copyTo(big(cv::Rect(3, 2, spec.width, spec.height)));
      f.image = big(cv::Rect(3, 2, spec.width, spec.height));
    }
    b.frames.push_back(f);
  }
  b.stats = {static_cast<std::uint64_t>(spec.frames), 2, 1, 3, 17, 5, {spec.frames + 1LL}};

  if (spec.truth) {
    hw::TruthRecord t;
    t.material = {0.95, 0.18, 0.45};
    t.t_collision_s = 0.0021;
    for (int i = 0; i < spec.frames; ++i) {
      t.frame_id.push_back(i - 2);
      t.t_s.push_back((i - 2) * 1e-3);
      std::array<SphereState, 2> pair;
      for (auto& st : pair) {
        st.position_m = Vec3(u(rng), u(rng), u(rng)) * 0.1;
        st.velocity_m_s = Vec3(u(rng), u(rng), u(rng));
        st.spin_rad_s = Vec3(u(rng), u(rng), u(rng)) * 50.0;
        st.orientation = Quat(u(rng), u(rng), u(rng), u(rng)).normalized();
      }
      t.states.push_back(pair);
    }
    for (int k = 0; k < 2; ++k)
      for (int d = 0; d < 5 + 2 * k; ++d)
        t.dot_centres[k].push_back(Vec3(u(rng), u(rng), u(rng)).normalized());
    t.dot_angular_radius_rad = 0.1;
    s.truth = t;
  }
  if (spec.results) s.results_json = sampleResultsJson();
  return s;
}

/// Equal as stored numbers: bit for bit, NaN equal to NaN.
inline bool sameDouble(double a, double b) {
  return (std::isnan(a) && std::isnan(b)) || a == b;
}

inline void expectSameImage(const cv::Mat& a, const cv::Mat& b, const std::string& what) {
  ASSERT_EQ(a.empty(), b.empty()) << what;
  if (a.empty()) return;
  ASSERT_EQ(a.type(), b.type()) << what;
  ASSERT_EQ(a.size(), b.size()) << what;
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0) << what << " differs";
}

inline void expectSameVec(const Vec3& a, const Vec3& b, const std::string& what) {
  EXPECT_EQ(a.x(), b.x()) << what;
  EXPECT_EQ(a.y(), b.y()) << what;
  EXPECT_EQ(a.z(), b.z()) << what;
}

/// Every field of Shot, images included when `images` is set (otherwise the
/// actual frames must have none).
inline void expectSameShot(const hw::Shot& e, const hw::Shot& a, bool images = true) {
  EXPECT_EQ(a.id, e.id);
  EXPECT_EQ(a.wall_time_unix_ns, e.wall_time_unix_ns);
  EXPECT_EQ(a.program_version, e.program_version);
  EXPECT_EQ(a.rig_name, e.rig_name);
  EXPECT_EQ(a.rig_profile_toml, e.rig_profile_toml);
  EXPECT_EQ(a.status, e.status);
  EXPECT_EQ(a.failure_reason, e.failure_reason);
  for (int k = 0; k < 2; ++k) {
    const auto &le = e.launchers[k], &la = a.launchers[k];
    EXPECT_TRUE(sameDouble(la.wanted_speed_m_s, le.wanted_speed_m_s)) << "launcher " << k;
    EXPECT_EQ(la.commanded_kPa, le.commanded_kPa) << "launcher " << k;
    EXPECT_EQ(la.readback_kPa, le.readback_kPa) << "launcher " << k;
    EXPECT_EQ(la.valve_open_ns, le.valve_open_ns) << "launcher " << k;
    EXPECT_EQ(la.pulse_us, le.pulse_us) << "launcher " << k;
  }
  ASSERT_EQ(a.steps.size(), e.steps.size());
  for (std::size_t i = 0; i < e.steps.size(); ++i) {
    EXPECT_EQ(a.steps[i].name, e.steps[i].name);
    EXPECT_EQ(a.steps[i].t_ns, e.steps[i].t_ns);
    EXPECT_EQ(a.steps[i].detail, e.steps[i].detail);
  }
  const auto &ce = e.camera, &ca = a.camera;
  EXPECT_EQ(ca.backend, ce.backend);
  EXPECT_EQ(ca.device, ce.device);
  EXPECT_EQ(ca.roi_x, ce.roi_x);
  EXPECT_EQ(ca.roi_y, ce.roi_y);
  EXPECT_EQ(ca.width, ce.width);
  EXPECT_EQ(ca.height, ce.height);
  EXPECT_EQ(ca.format, ce.format);
  EXPECT_EQ(ca.fps, ce.fps);
  EXPECT_EQ(ca.exposure_us, ce.exposure_us);
  EXPECT_EQ(ca.gain_db, ce.gain_db);
  EXPECT_EQ(ca.pre_trigger_frames, ce.pre_trigger_frames);
  EXPECT_EQ(ca.post_trigger_frames, ce.post_trigger_frames);
  const auto &se = e.scene, &sa = a.scene;
  EXPECT_EQ(sa.pixel_size_m, se.pixel_size_m);
  EXPECT_EQ(sa.diameter_m, se.diameter_m);
  EXPECT_EQ(sa.mass_kg, se.mass_kg);
  EXPECT_EQ(sa.material_name, se.material_name);
  EXPECT_EQ(sa.origin_u_px, se.origin_u_px);
  EXPECT_EQ(sa.origin_v_px, se.origin_v_px);

  const auto &be = e.burst, &ba = a.burst;
  EXPECT_EQ(ba.format, be.format);
  EXPECT_EQ(ba.fps, be.fps);
  EXPECT_EQ(ba.exposure_us, be.exposure_us);
  EXPECT_EQ(ba.complete, be.complete);
  EXPECT_EQ(ba.note, be.note);
  EXPECT_EQ(ba.stats.completed, be.stats.completed);
  EXPECT_EQ(ba.stats.failed, be.stats.failed);
  EXPECT_EQ(ba.stats.dropped, be.stats.dropped);
  EXPECT_EQ(ba.stats.underruns, be.stats.underruns);
  EXPECT_EQ(ba.stats.missing_packets, be.stats.missing_packets);
  EXPECT_EQ(ba.stats.resent_packets, be.stats.resent_packets);
  EXPECT_EQ(ba.stats.missing_ids, be.stats.missing_ids);
  ASSERT_EQ(ba.frames.size(), be.frames.size());
  for (std::size_t i = 0; i < be.frames.size(); ++i) {
    EXPECT_EQ(ba.frames[i].id, be.frames[i].id) << "frame " << i;
    EXPECT_EQ(ba.frames[i].timestamp_ns, be.frames[i].timestamp_ns) << "frame " << i;
    EXPECT_EQ(ba.frames[i].status, be.frames[i].status) << "frame " << i;
    if (images)
      expectSameImage(be.frames[i].image, ba.frames[i].image, "frame " + std::to_string(i));
    else
      EXPECT_TRUE(ba.frames[i].image.empty()) << "frame " << i << " read without frames";
  }

  ASSERT_EQ(a.truth.has_value(), e.truth.has_value());
  if (e.truth) {
    const auto &te = *e.truth, &ta = *a.truth;
    EXPECT_EQ(ta.material.e, te.material.e);
    EXPECT_EQ(ta.material.mu, te.material.mu);
    EXPECT_EQ(ta.material.beta0, te.material.beta0);
    EXPECT_EQ(ta.t_collision_s, te.t_collision_s);
    EXPECT_EQ(ta.frame_id, te.frame_id);
    EXPECT_EQ(ta.t_s, te.t_s);
    ASSERT_EQ(ta.states.size(), te.states.size());
    for (std::size_t i = 0; i < te.states.size(); ++i)
      for (int k = 0; k < 2; ++k) {
        const std::string what =
            "truth frame " + std::to_string(i) + " sphere " + std::to_string(k);
        expectSameVec(ta.states[i][k].position_m, te.states[i][k].position_m, what);
        expectSameVec(ta.states[i][k].velocity_m_s, te.states[i][k].velocity_m_s, what);
        expectSameVec(ta.states[i][k].spin_rad_s, te.states[i][k].spin_rad_s, what);
        EXPECT_EQ(ta.states[i][k].orientation.coeffs(), te.states[i][k].orientation.coeffs())
            << what;
      }
    for (int k = 0; k < 2; ++k) {
      ASSERT_EQ(ta.dot_centres[k].size(), te.dot_centres[k].size());
      for (std::size_t d = 0; d < te.dot_centres[k].size(); ++d)
        expectSameVec(ta.dot_centres[k][d], te.dot_centres[k][d], "dot " + std::to_string(d));
    }
    EXPECT_EQ(ta.dot_angular_radius_rad, te.dot_angular_radius_rad);
  }
  EXPECT_EQ(a.results_json, e.results_json);
}

/// A fresh scratch folder, removed with everything in it on destruction.
class ScratchDir {
 public:
  ScratchDir() {
    std::string pattern = ::testing::TempDir() + "collide-storage-XXXXXX";
    if (!mkdtemp(pattern.data())) throw std::runtime_error("mkdtemp failed");
    path_ = pattern;
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  const std::string& path() const { return path_; }
  std::string file(const std::string& name) const { return path_ + "/" + name; }
  /// Names of everything in the folder (hidden temporary files included).
  std::vector<std::string> entries() const {
    std::vector<std::string> out;
    for (const auto& e : std::filesystem::directory_iterator(path_))
      out.push_back(e.path().filename().string());
    std::sort(out.begin(), out.end());
    return out;
  }

 private:
  std::string path_;
};

/// Runs `body` in a forked child whose files may not grow past `limit_bytes`
/// (RLIMIT_FSIZE, with SIGXFSZ ignored so writes fail with EFBIG as on a full
/// disk) and returns what `body` returned. Needs no root and no special
/// filesystem.
inline std::string runWithFileSizeLimit(rlim_t limit_bytes,
                                        const std::function<std::string()>& body) {
  int fds[2];
  if (pipe(fds) != 0) return "pipe failed";
  const pid_t pid = fork();
  if (pid < 0) return "fork failed";
  if (pid == 0) {
    close(fds[0]);
    signal(SIGXFSZ, SIG_IGN);
    const rlimit limit{limit_bytes, limit_bytes};
    setrlimit(RLIMIT_FSIZE, &limit);
    const std::string out = body();
    std::size_t done = 0;
    while (done < out.size()) {
      const ssize_t n = write(fds[1], out.data() + done, out.size() - done);
      if (n <= 0) break;
      done += static_cast<std::size_t>(n);
    }
    _exit(0);
  }
  close(fds[1]);
  std::string out;
  char buf[4096];
  ssize_t n;
  while ((n = read(fds[0], buf, sizeof buf)) > 0) out.append(buf, static_cast<std::size_t>(n));
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) return "child crashed: " + out;
  return out;
}

inline std::string readAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

inline void writeAll(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << bytes;
}

}  // namespace collide::testing
