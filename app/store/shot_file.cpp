#include "app/store/shot_file.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <optional>

#include "app/report/results_summary.hpp"
#include "app/store/atomic_file.hpp"
#include "app/store/h5.hpp"
#include "app/store/heap_check_driver.hpp"
#include "app/store/reader_process.hpp"
#include "hw/memory.hpp"

namespace collide::app {

namespace {

using h5::Handle;

constexpr const char* kFormatName = "collide-shot";

/// Held around every whole read, write and update of a shot file. HDF5
/// serialises its calls anyway, so this costs no parallelism; it lets a
/// contained read fork while no thread of ours is inside the library.
std::recursive_mutex& hdf5Mutex() {
  static std::recursive_mutex m;
  return m;
}
constexpr const char* kImages = "/frames/images";

/// Size and OpenCV type shared by every frame that has an image.
struct FrameGeometry {
  int rows = 0, cols = 0;
  int cv_type = CV_8UC1;
};

Result<FrameGeometry> checkShot(const std::string& path, const hw::Shot& shot) {
  const std::string where = "cannot write " + path + ": ";
  FrameGeometry g;
  g.cv_type = vision::cvType(shot.burst.format);
  bool seen = false;
  const auto& frames = shot.burst.frames;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const cv::Mat& m = frames[i].image;
    if (m.empty()) continue;
    if (m.type() != g.cv_type)
      return fail(where + "frame " + std::to_string(i) + " is not a one-channel " +
                  (g.cv_type == CV_8UC1 ? "8" : "16") + "-bit image as pixel format " +
                  vision::toString(shot.burst.format) + " requires");
    if (!seen) {
      g.rows = m.rows;
      g.cols = m.cols;
      seen = true;
    } else if (m.rows != g.rows || m.cols != g.cols) {
      return fail(where + "frame " + std::to_string(i) + " is " + std::to_string(m.cols) + "x" +
                  std::to_string(m.rows) + " but earlier frames are " + std::to_string(g.cols) +
                  "x" + std::to_string(g.rows) + "; all frames of a burst must have one size");
    }
  }
  if (shot.truth) {
    const auto& t = *shot.truth;
    if (t.t_s.size() != t.frame_id.size() || t.states.size() != t.frame_id.size())
      return fail(where + "truth has " + std::to_string(t.frame_id.size()) + " frame ids, " +
                  std::to_string(t.t_s.size()) + " times and " + std::to_string(t.states.size()) +
                  " states; they must be one per frame");
  }
  if (!shot.results_json.empty()) {
    auto summary = summarizeResults(shot.results_json);
    if (!summary) return fail(where + summary.error().message);
  }
  return g;
}

// ------------------------------------------------------------ writing

/// Vec3 per [row][sphere] flattened row-major to [rows, 2, 3].
template <class Get>
std::vector<double> flattenStates(const std::vector<std::array<SphereState, 2>>& states, Get get,
                                  int width) {
  std::vector<double> out;
  out.reserve(states.size() * 2 * width);
  for (const auto& pair : states)
    for (const auto& s : pair) {
      const auto v = get(s);
      for (int k = 0; k < width; ++k) out.push_back(v[k]);
    }
  return out;
}

std::vector<double> flattenVecs(const std::vector<Vec3>& vs) {
  std::vector<double> out;
  out.reserve(vs.size() * 3);
  for (const auto& v : vs) out.insert(out.end(), {v.x(), v.y(), v.z()});
  return out;
}

void writeRoot(h5::Writer& w, const hw::Shot& shot) {
  w.attribute("/", "format", kFormatName);
  w.attribute("/", "format_version", kShotFormatVersion);
  w.attribute("/", "id", shot.id);
  w.attribute("/", "program_version", shot.program_version);
  w.attribute("/", "rig_name", shot.rig_name);
  w.attribute("/", "status", hw::toString(shot.status));
  w.attribute("/", "failure_reason", shot.failure_reason);
  w.scalar("/wall_time_unix_ns", shot.wall_time_unix_ns, "ns");
  w.text("/rig_profile_toml", shot.rig_profile_toml, "application/toml");
}

void writeLaunchers(h5::Writer& w, const std::array<hw::LauncherRecord, 2>& l) {
  w.group("/launchers");
  const double wanted[2] = {l[0].wanted_speed_m_s, l[1].wanted_speed_m_s};
  const double commanded[2] = {l[0].commanded_kPa, l[1].commanded_kPa};
  const double readback[2] = {l[0].readback_kPa, l[1].readback_kPa};
  const std::int64_t open[2] = {l[0].valve_open_ns, l[1].valve_open_ns};
  const std::int64_t pulse[2] = {l[0].pulse_us, l[1].pulse_us};
  w.dataset("/launchers/wanted_speed_m_s", wanted, {2}, "m/s");
  w.dataset("/launchers/commanded_kPa", commanded, {2}, "kPa");
  w.dataset("/launchers/readback_kPa", readback, {2}, "kPa");
  w.dataset("/launchers/valve_open_ns", open, {2}, "ns");
  w.dataset("/launchers/pulse_us", pulse, {2}, "us");
}

void writeSequencer(h5::Writer& w, const std::vector<hw::StepStamp>& steps) {
  w.group("/sequencer");
  std::vector<std::string> names, details;
  std::vector<std::int64_t> t_ns;
  for (const auto& s : steps) {
    names.push_back(s.name);
    details.push_back(s.detail);
    t_ns.push_back(s.t_ns);
  }
  w.strings("/sequencer/name", names);
  w.vector("/sequencer/t_ns", t_ns, "ns");
  w.strings("/sequencer/detail", details);
}

void writeCamera(h5::Writer& w, const hw::CameraRecord& c) {
  w.group("/camera");
  w.attribute("/camera", "backend", c.backend);
  w.attribute("/camera", "device", c.device);
  w.attribute("/camera", "format", vision::toString(c.format));
  w.scalar<std::int32_t>("/camera/roi_x", c.roi_x, "px");
  w.scalar<std::int32_t>("/camera/roi_y", c.roi_y, "px");
  w.scalar<std::int32_t>("/camera/width", c.width, "px");
  w.scalar<std::int32_t>("/camera/height", c.height, "px");
  w.scalar("/camera/fps", c.fps, "Hz");
  w.scalar("/camera/exposure_us", c.exposure_us, "us");
  w.scalar("/camera/gain_db", c.gain_db, "dB");
  w.scalar<std::int32_t>("/camera/pre_trigger_frames", c.pre_trigger_frames, "1");
  w.scalar<std::int32_t>("/camera/post_trigger_frames", c.post_trigger_frames, "1");
}

void writeScene(h5::Writer& w, const hw::SceneRecord& s) {
  w.group("/scene");
  w.attribute("/scene", "material_name", s.material_name);
  w.scalar("/scene/pixel_size_m", s.pixel_size_m, "m/px");
  w.dataset("/scene/diameter_m", s.diameter_m.data(), {2}, "m");
  w.dataset("/scene/mass_kg", s.mass_kg.data(), {2}, "kg");
  w.scalar("/scene/origin_u_px", s.origin_u_px, "px");
  w.scalar("/scene/origin_v_px", s.origin_v_px, "px");
}

/// The images: one N x H x W dataset, one frame per chunk so a viewer (or a
/// replay) reads any frame with one chunk read and no decompression of others.
void writeImages(h5::Writer& w, const vision::Burst& burst, const FrameGeometry& g,
                 const WriteOptions& options) {
  if (!w.ok()) return;
  const hsize_t n = burst.frames.size();
  const hsize_t rows = g.rows, cols = g.cols;
  const bool mono8 = g.cv_type == CV_8UC1;
  const hid_t type = mono8 ? H5T_NATIVE_UINT8 : H5T_NATIVE_UINT16;
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  // A chunk cannot have a zero dimension: a burst without images is stored as
  // an empty contiguous dataset.
  const bool chunked = n > 0 && rows > 0 && cols > 0;
  if (chunked) {
    const hsize_t chunk[3] = {1, rows, cols};
    H5Pset_chunk(dcpl.get(), 3, chunk);
    if (options.compress) {
      if (H5Zfilter_avail(H5Z_FILTER_DEFLATE) <= 0)
        return w.fail(
            fail("cannot write compressed frames: this HDF5 library has no deflate "
                 "filter; save without compression"));
      H5Pset_shuffle(dcpl.get());
      H5Pset_deflate(dcpl.get(), static_cast<unsigned>(std::clamp(options.deflate_level, 1, 9)));
    }
    // Last in the pipeline: a checksum of each frame as stored, so a damaged
    // frame is named on reading instead of analysed as if it were true.
    H5Pset_fletcher32(dcpl.get());
  }
  Handle d = w.createDataset(kImages, type, {n, rows, cols}, dcpl.get());
  if (!w.ok()) return;
  w.attributeOn(d.get(), kImages, "units", "DN");
  w.attributeOn(d.get(), kImages, "pixel_format", vision::toString(burst.format));
  if (!chunked) return;

  const std::size_t frame_bytes = rows * cols * (mono8 ? 1 : 2);
  std::vector<std::uint8_t> chunk;  // a frame and its checksum, for direct writes
  Handle file_space(H5Dget_space(d.get()), H5Sclose);
  const hsize_t mem_dims[3] = {1, rows, cols};
  Handle mem_space(H5Screate_simple(3, mem_dims, nullptr), H5Sclose);
  for (hsize_t i = 0; i < n; ++i) {
    const cv::Mat& image = burst.frames[i].image;
    if (image.empty()) continue;  // recorded in /frames/has_image; the chunk stays unallocated
    const cv::Mat m = image.isContinuous() ? image : image.clone();
    const hsize_t offset[3] = {i, 0, 0};
    herr_t status;
    if (!options.compress) {
      // Direct chunk write: the frame's bytes go to the file as they are,
      // without a pass through HDF5's chunk cache (keeps writes at disk speed),
      // followed by the checksum the fletcher32 filter would have appended
      // (little-endian).
      chunk.resize(frame_bytes + 4);
      std::memcpy(chunk.data(), m.data, frame_bytes);
      const std::uint32_t sum = h5::fletcher32(m.data, frame_bytes);
      for (int b = 0; b < 4; ++b)
        chunk[frame_bytes + b] = static_cast<std::uint8_t>(sum >> (8 * b));
      status = H5Dwrite_chunk(d.get(), H5P_DEFAULT, 0, offset, chunk.size(), chunk.data());
    } else {
      const hsize_t count[3] = {1, rows, cols};
      H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, offset, nullptr, count, nullptr);
      status = H5Dwrite(d.get(), type, mem_space.get(), file_space.get(), H5P_DEFAULT, m.data);
    }
    if (status < 0) return w.failHdf5("writing frame " + std::to_string(i) + " of " + kImages);
  }
}

void writeFrames(h5::Writer& w, const vision::Burst& burst, const FrameGeometry& g,
                 const WriteOptions& options) {
  w.group("/frames");
  w.attribute("/frames", "format", vision::toString(burst.format));
  w.attribute("/frames", "complete", burst.complete ? 1 : 0);
  w.attribute("/frames", "note", burst.note);
  w.scalar("/frames/fps", burst.fps, "Hz");
  w.scalar("/frames/exposure_us", burst.exposure_us, "us");
  std::vector<std::int64_t> ids, stamps;
  std::vector<std::uint8_t> status, has_image;
  for (const auto& f : burst.frames) {
    ids.push_back(f.id);
    stamps.push_back(f.timestamp_ns);
    status.push_back(static_cast<std::uint8_t>(f.status));
    has_image.push_back(f.image.empty() ? 0 : 1);
  }
  w.vector("/frames/id", ids, "1");
  w.vector("/frames/timestamp_ns", stamps, "ns");
  w.vector("/frames/status", status, "1");
  w.vector("/frames/has_image", has_image, "1");
  writeImages(w, burst, g, options);

  const auto& st = burst.stats;
  w.group("/frames/stats");
  w.scalar("/frames/stats/completed", st.completed, "1");
  w.scalar("/frames/stats/failed", st.failed, "1");
  w.scalar("/frames/stats/dropped", st.dropped, "1");
  w.scalar("/frames/stats/underruns", st.underruns, "1");
  w.scalar("/frames/stats/missing_packets", st.missing_packets, "1");
  w.scalar("/frames/stats/resent_packets", st.resent_packets, "1");
  w.vector("/frames/stats/missing_ids", st.missing_ids, "1");
}

void writeTruth(h5::Writer& w, const hw::TruthRecord& t) {
  w.group("/truth");
  w.scalar("/truth/material_e", t.material.e, "1");
  w.scalar("/truth/material_mu", t.material.mu, "1");
  w.scalar("/truth/material_beta0", t.material.beta0, "1");
  w.scalar("/truth/t_collision_s", t.t_collision_s, "s");
  w.vector("/truth/frame_id", t.frame_id, "1");
  w.vector("/truth/t_s", t.t_s, "s");
  const hsize_t n = t.states.size();
  auto vec3 = [&](const char* path, auto get, const char* units) {
    w.dataset(path, flattenStates(t.states, get, 3).data(), {n, 2, 3}, units);
  };
  vec3(
      "/truth/position_m", [](const SphereState& s) { return s.position_m; }, "m");
  vec3(
      "/truth/velocity_m_s", [](const SphereState& s) { return s.velocity_m_s; }, "m/s");
  vec3(
      "/truth/spin_rad_s", [](const SphereState& s) { return s.spin_rad_s; }, "rad/s");
  const auto wxyz = [](const SphereState& s) {
    const Quat& q = s.orientation;
    return std::array<double, 4>{q.w(), q.x(), q.y(), q.z()};
  };
  w.dataset("/truth/orientation_wxyz", flattenStates(t.states, wxyz, 4).data(), {n, 2, 4}, "1");
  for (int k = 0; k < 2; ++k) {
    const std::string path = "/truth/dot_centres_" + std::to_string(k);
    w.dataset(path, flattenVecs(t.dot_centres[k]).data(), {t.dot_centres[k].size(), 3}, "1");
  }
  w.scalar("/truth/dot_angular_radius_rad", t.dot_angular_radius_rad, "rad");
}

/// /results: the JSON text, plus the summary numbers as scalar datasets for
/// tools that do not parse JSON. The JSON was checked before the file was opened.
/// /note: the experimenter's note, a text dataset; absent when empty.
void writeNote(h5::Writer& w, const std::string& note) {
  if (!note.empty()) w.text("/note", note, "text/plain");
}

void writeResults(h5::Writer& w, const std::string& results_json) {
  if (results_json.empty()) return;
  w.group("/results");
  w.text("/results/json", results_json, "application/json");
  const auto summary = summarizeResults(results_json);
  if (!summary) return;
  const std::pair<const char*, const std::optional<double>&> numbers[] = {
      {"/results/e", summary->e},           {"/results/beta", summary->beta},
      {"/results/f", summary->f},           {"/results/gamma_deg", summary->gamma_deg},
      {"/results/vn_m_s", summary->vn_m_s}, {"/results/vs_m_s", summary->vs_m_s},
  };
  const char* units[] = {"1", "1", "1", "deg", "m/s", "m/s"};
  for (std::size_t i = 0; i < std::size(numbers); ++i)
    if (numbers[i].second) w.scalar(numbers[i].first, *numbers[i].second, units[i]);
}

/// Refuses to start a write the folder has no room for (frames plus 1 MB of
/// metadata), with the figures, rather than fill the disk and fail half-way.
Status checkRoom(const std::string& path, const FrameGeometry& g, std::size_t frames) {
  const double needed = static_cast<double>(g.rows) * g.cols * (g.cv_type == CV_8UC1 ? 1 : 2) *
                            static_cast<double>(frames) +
                        1e6;
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  return checkFreeSpace(folder.empty() ? "." : folder.string(), needed, "write " + path);
}

/// Error for a failure to create or open `path` itself.
Error fileError(const std::string& action, const std::string& path) {
  const h5::Cause cause = h5::lastCause();
  if (cause.errno_value != 0) return ioError(cause.errno_value, action, path);
  return fail("cannot " + action + " " + path + ": " + cause.text);
}

Handle fileAccess() {
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  // Closing the file closes anything still open in it, so an early return on
  // error cannot leave the file half-open.
  H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG);
  return fapl;
}

/// Closes `file`, which flushes HDF5's metadata: a full disk may show only here.
void closeFile(h5::Writer& w, Handle& file) {
  if (w.ok() && file.close() < 0) w.failHdf5("closing the file");
}

// ------------------------------------------------------------ reading

void readRoot(h5::Reader& r, hw::Shot& shot, const std::string& path) {
  shot.id = r.stringAttribute("/", "id");
  shot.program_version = r.stringAttribute("/", "program_version");
  shot.rig_name = r.stringAttribute("/", "rig_name");
  const std::string status = r.stringAttribute("/", "status");
  if (r.ok()) {
    if (auto s = parseShotStatus(status))
      shot.status = *s;
    else
      r.fail(fail("shot file " + path + ": attribute 'status' of / is \"" + status +
                  "\", expected \"ok\" or \"failed\""));
  }
  shot.failure_reason = r.stringAttribute("/", "failure_reason");
  shot.wall_time_unix_ns = r.scalar<std::int64_t>("/wall_time_unix_ns");
  shot.rig_profile_toml = r.text("/rig_profile_toml");
}

void readLaunchers(h5::Reader& r, std::array<hw::LauncherRecord, 2>& l) {
  const auto wanted = r.dataset<double>("/launchers/wanted_speed_m_s", {2});
  const auto commanded = r.dataset<double>("/launchers/commanded_kPa", {2});
  const auto readback = r.dataset<double>("/launchers/readback_kPa", {2});
  const auto open = r.dataset<std::int64_t>("/launchers/valve_open_ns", {2});
  const auto pulse = r.dataset<std::int64_t>("/launchers/pulse_us", {2});
  if (!r.ok()) return;
  for (int k = 0; k < 2; ++k) l[k] = {wanted[k], commanded[k], readback[k], open[k], pulse[k]};
}

void readSequencer(h5::Reader& r, std::vector<hw::StepStamp>& steps, const std::string& path) {
  const auto names = r.strings("/sequencer/name");
  const auto t_ns = r.vector<std::int64_t>("/sequencer/t_ns");
  const auto details = r.strings("/sequencer/detail");
  if (!r.ok()) return;
  if (t_ns.size() != names.size() || details.size() != names.size())
    return r.fail(fail("shot file " + path +
                       ": /sequencer/name, t_ns and detail differ in length; the file is corrupt"));
  steps.clear();
  for (std::size_t i = 0; i < names.size(); ++i) steps.push_back({names[i], t_ns[i], details[i]});
}

vision::PixelFormat readFormat(h5::Reader& r, const std::string& object, const std::string& path) {
  vision::PixelFormat f = vision::PixelFormat::Mono8;
  const std::string text = r.stringAttribute(object, "format");
  if (r.ok() && !vision::parsePixelFormat(text, f))
    r.fail(fail("shot file " + path + ": attribute 'format' of " + object + " is \"" + text +
                "\", expected Mono8, Mono12 or Mono16"));
  return f;
}

void readCamera(h5::Reader& r, hw::CameraRecord& c, const std::string& path) {
  c.backend = r.stringAttribute("/camera", "backend");
  c.device = r.stringAttribute("/camera", "device");
  c.format = readFormat(r, "/camera", path);
  c.roi_x = r.scalar<std::int32_t>("/camera/roi_x");
  c.roi_y = r.scalar<std::int32_t>("/camera/roi_y");
  c.width = r.scalar<std::int32_t>("/camera/width");
  c.height = r.scalar<std::int32_t>("/camera/height");
  c.fps = r.scalar<double>("/camera/fps");
  c.exposure_us = r.scalar<double>("/camera/exposure_us");
  c.gain_db = r.scalar<double>("/camera/gain_db");
  c.pre_trigger_frames = r.scalar<std::int32_t>("/camera/pre_trigger_frames");
  c.post_trigger_frames = r.scalar<std::int32_t>("/camera/post_trigger_frames");
}

void readScene(h5::Reader& r, hw::SceneRecord& s) {
  s.material_name = r.stringAttribute("/scene", "material_name");
  s.pixel_size_m = r.scalar<double>("/scene/pixel_size_m");
  const auto diameter = r.dataset<double>("/scene/diameter_m", {2});
  const auto mass = r.dataset<double>("/scene/mass_kg", {2});
  s.origin_u_px = r.scalar<double>("/scene/origin_u_px");
  s.origin_v_px = r.scalar<double>("/scene/origin_v_px");
  if (!r.ok()) return;
  s.diameter_m = {diameter[0], diameter[1]};
  s.mass_kg = {mass[0], mass[1]};
}

void readImages(h5::Reader& r, vision::Burst& burst, const std::vector<std::uint8_t>& has_image,
                const std::string& path) {
  // No chunk cache: every chunk is read exactly once, straight into its frame.
  Handle dapl(H5Pcreate(H5P_DATASET_ACCESS), H5Pclose);
  H5Pset_chunk_cache(dapl.get(), 0, 0, H5D_CHUNK_CACHE_W0_DEFAULT);
  Handle d = r.openDataset(kImages, dapl.get());
  if (!r.ok()) return;
  Handle space(H5Dget_space(d.get()), H5Sclose);
  Handle type(H5Dget_type(d.get()), H5Tclose);
  hsize_t dims[3] = {0, 0, 0};
  const bool mono8 = burst.format == vision::PixelFormat::Mono8;
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank == 3) H5Sget_simple_extent_dims(space.get(), dims, nullptr);
  if (rank != 3 || dims[0] != burst.frames.size() || H5Tget_class(type.get()) != H5T_INTEGER ||
      H5Tget_size(type.get()) != (mono8 ? 1u : 2u))
    return r.fail(fail("shot file " + path + ": " + kImages + " should be " +
                       std::to_string(burst.frames.size()) + " frames of " + (mono8 ? "8" : "16") +
                       "-bit pixels (pixel format " + vision::toString(burst.format) +
                       "); the file is corrupt"));
  // The file's dimensions are not trusted with memory: a corrupt or hostile
  // header must give a message, not a multi-gigabyte allocation.
  if (dims[1] > vision::kMaxFrameSidePx || dims[2] > vision::kMaxFrameSidePx)
    return r.fail(fail("shot file " + path + ": " + kImages + " declares frames of " +
                       std::to_string(dims[2]) + " x " + std::to_string(dims[1]) +
                       " pixels, larger than any camera (at most " +
                       std::to_string(vision::kMaxFrameSidePx) + " a side); the file is corrupt"));
  const double frame_bytes = static_cast<double>(dims[1]) * dims[2] * (mono8 ? 1 : 2);
  const double images = static_cast<double>(
      std::count_if(has_image.begin(), has_image.end(), [](std::uint8_t h) { return h != 0; }));
  if (const auto avail = hw::availableMemoryBytes(); avail && frame_bytes * images > *avail * 0.9)
    return r.fail(fail("shot file " + path + " holds " + std::to_string(dims[0]) + " frames of " +
                       std::to_string(dims[2]) + " x " + std::to_string(dims[1]) + " pixels (" +
                       hw::formatBytes(frame_bytes * images) + "), more than the " +
                       hw::formatBytes(static_cast<double>(*avail)) +
                       " of memory free here: read it on a machine with more memory "
                       "(or the file is corrupt)"));
  const hsize_t mem_dims[3] = {1, dims[1], dims[2]};
  Handle mem_space(H5Screate_simple(3, mem_dims, nullptr), H5Sclose);
  const int cv_type = vision::cvType(burst.format);
  for (hsize_t i = 0; i < dims[0]; ++i) {
    if (!has_image[i] || dims[1] == 0 || dims[2] == 0) continue;
    cv::Mat image(static_cast<int>(dims[1]), static_cast<int>(dims[2]), cv_type);
    const hsize_t offset[3] = {i, 0, 0};
    const hsize_t count[3] = {1, dims[1], dims[2]};
    H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, offset, nullptr, count, nullptr);
    if (H5Dread(d.get(), mono8 ? H5T_NATIVE_UINT8 : H5T_NATIVE_UINT16, mem_space.get(), space.get(),
                H5P_DEFAULT, image.data) < 0) {
      const h5::Cause cause = h5::lastCause();
      if (cause.text.find("checksum") == std::string::npos)
        return r.failHdf5("reading frame " + std::to_string(i) + " of " + kImages, cause);
      // One damaged frame: the rest of the shot is still good. The frame is
      // set aside (as a frame lost in transport would be) and named.
      vision::Frame& f = burst.frames[i];
      f.status = vision::FrameStatus::Failed;
      burst.note += std::string(burst.note.empty() ? "" : "; ") + "frame " + std::to_string(i) +
                    " (id " + std::to_string(f.id) +
                    ") fails its checksum in the file (damaged on disk): left out";
      continue;
    }
    burst.frames[i].image = image;
  }
}

void readFrames(h5::Reader& r, vision::Burst& burst, bool with_images, const std::string& path) {
  burst.format = readFormat(r, "/frames", path);
  burst.complete = r.intAttribute("/frames", "complete") != 0;
  burst.note = r.stringAttribute("/frames", "note");
  burst.fps = r.scalar<double>("/frames/fps");
  burst.exposure_us = r.scalar<double>("/frames/exposure_us");
  const auto ids = r.vector<std::int64_t>("/frames/id");
  const auto n = ids.size();
  const auto stamps = r.dataset<std::int64_t>("/frames/timestamp_ns", {n});
  const auto status = r.dataset<std::uint8_t>("/frames/status", {n});
  const auto has_image = r.dataset<std::uint8_t>("/frames/has_image", {n});
  // Checked even when the images are not read, so listing spots a file that
  // lost them.
  if (!r.exists(kImages))
    r.fail(fail("shot file " + path + " lacks dataset " + kImages +
                ": the file is incomplete or was not written by collide"));
  if (!r.ok()) return;
  burst.frames.assign(n, {});
  for (std::size_t i = 0; i < n; ++i) {
    if (status[i] > static_cast<std::uint8_t>(vision::FrameStatus::Incomplete))
      return r.fail(fail("shot file " + path + ": /frames/status[" + std::to_string(i) + "] is " +
                         std::to_string(status[i]) + ", expected 0, 1 or 2"));
    burst.frames[i].id = ids[i];
    burst.frames[i].timestamp_ns = stamps[i];
    burst.frames[i].status = static_cast<vision::FrameStatus>(status[i]);
  }
  if (with_images) readImages(r, burst, has_image, path);

  auto& st = burst.stats;
  st.completed = r.scalar<std::uint64_t>("/frames/stats/completed");
  st.failed = r.scalar<std::uint64_t>("/frames/stats/failed");
  st.dropped = r.scalar<std::uint64_t>("/frames/stats/dropped");
  st.underruns = r.scalar<std::uint64_t>("/frames/stats/underruns");
  st.missing_packets = r.scalar<std::uint64_t>("/frames/stats/missing_packets");
  st.resent_packets = r.scalar<std::uint64_t>("/frames/stats/resent_packets");
  st.missing_ids = r.vector<std::int64_t>("/frames/stats/missing_ids");
}

void readTruth(h5::Reader& r, hw::TruthRecord& t) {
  t.material.e = r.scalar<double>("/truth/material_e");
  t.material.mu = r.scalar<double>("/truth/material_mu");
  t.material.beta0 = r.scalar<double>("/truth/material_beta0");
  t.t_collision_s = r.scalar<double>("/truth/t_collision_s");
  t.frame_id = r.vector<std::int64_t>("/truth/frame_id");
  const hsize_t n = t.frame_id.size();
  t.t_s = r.dataset<double>("/truth/t_s", {n});
  const auto pos = r.dataset<double>("/truth/position_m", {n, 2, 3});
  const auto vel = r.dataset<double>("/truth/velocity_m_s", {n, 2, 3});
  const auto spin = r.dataset<double>("/truth/spin_rad_s", {n, 2, 3});
  const auto q = r.dataset<double>("/truth/orientation_wxyz", {n, 2, 4});
  std::array<std::vector<double>, 2> dots;
  for (int k = 0; k < 2; ++k)
    dots[k] = r.dataset<double>("/truth/dot_centres_" + std::to_string(k), {h5::kAnySize, 3});
  t.dot_angular_radius_rad = r.scalar<double>("/truth/dot_angular_radius_rad");
  if (!r.ok()) return;
  t.states.assign(n, {});
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t s = 0; s < 2; ++s) {
      const std::size_t v = (i * 2 + s) * 3, o = (i * 2 + s) * 4;
      auto& st = t.states[i][s];
      st.position_m = Vec3(pos[v], pos[v + 1], pos[v + 2]);
      st.velocity_m_s = Vec3(vel[v], vel[v + 1], vel[v + 2]);
      st.spin_rad_s = Vec3(spin[v], spin[v + 1], spin[v + 2]);
      st.orientation = Quat(q[o], q[o + 1], q[o + 2], q[o + 3]);
    }
  for (int k = 0; k < 2; ++k) {
    t.dot_centres[k].clear();
    for (std::size_t i = 0; i + 2 < dots[k].size(); i += 3)
      t.dot_centres[k].emplace_back(dots[k][i], dots[k][i + 1], dots[k][i + 2]);
  }
}

/// Opens `path` as a shot file of a format this program reads.
Result<Handle> openShotFile(const std::string& path, unsigned flags) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return fail("no such shot file: " + path);
    return ioError(errno, "opening", path);
  }
  if (S_ISDIR(st.st_mode)) return fail(path + " is a folder, not a shot file (.h5)");
  if (H5Fis_hdf5(path.c_str()) <= 0) {
    h5::lastCause();  // clear whatever H5Fis_hdf5 left on the stack
    return fail(path + " is not an HDF5 file, so not a collide shot file: check the name");
  }
  Handle fapl = fileAccess();
  // Reading: a damaged global heap is refused before libhdf5 parses it.
  if (flags == H5F_ACC_RDONLY && h5::heapCheckDriver() >= 0)
    H5Pset_driver(fapl.get(), h5::heapCheckDriver(), nullptr);
  Handle file(H5Fopen(path.c_str(), flags, fapl.get()), H5Fclose);
  if (!file.valid()) {
    Error e = fileError("open", path);
    return fail(e.message + " (the file is truncated or corrupt)");
  }
  h5::Reader r(file.get(), path);
  const bool has_format = H5Aexists_by_name(file.get(), "/", "format", H5P_DEFAULT) > 0;
  const std::string format = has_format ? r.stringAttribute("/", "format") : "";
  if (!r.ok()) return r.error();  // e.g. a corrupt global heap, named by the driver
  if (format != kFormatName)
    return fail(path + " is an HDF5 file but not a collide shot file (no attribute format = \"" +
                kFormatName + "\")");
  const int version = r.intAttribute("/", "format_version");
  if (!r.ok()) return r.error();
  if (version > kShotFormatVersion)
    return fail(path + " was written by a newer collide (shot format " + std::to_string(version) +
                ", this one reads up to " + std::to_string(kShotFormatVersion) +
                "): update collide");
  return file;
}

}  // namespace

std::optional<hw::ShotStatus> parseShotStatus(std::string_view text) {
  if (text == hw::toString(hw::ShotStatus::Ok)) return hw::ShotStatus::Ok;
  if (text == hw::toString(hw::ShotStatus::Failed)) return hw::ShotStatus::Failed;
  return std::nullopt;
}

Result<WriteOutcome> writeShotIfAbsent(const std::string& path, const hw::Shot& shot,
                                       const WriteOptions& options) {
  std::lock_guard lock(hdf5Mutex());
  h5::silenceErrorPrinting();
  auto geometry = checkShot(path, shot);
  if (!geometry) return geometry.error();
  if (auto room = checkRoom(path, *geometry, shot.burst.frames.size()); !room) return room.error();
  auto temp = AtomicFile::create(path);
  if (!temp) return temp.error();
  {
    Handle fapl = fileAccess();
    // The 1.10 file format: superblock v3 and v2 object headers carry
    // checksums, so a damaged header is reported as such rather than read as
    // data. Files stay readable by HDF5 >= 1.10 (h5py, MATLAB, HDFView).
    H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_V110, H5F_LIBVER_V110);
    Handle file(H5Fcreate(temp->tempPath().c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get()),
                H5Fclose);
    if (!file.valid()) return fileError("create", path);
    h5::Writer w(file.get(), path);
    writeRoot(w, shot);
    writeLaunchers(w, shot.launchers);
    writeSequencer(w, shot.steps);
    writeCamera(w, shot.camera);
    writeScene(w, shot.scene);
    writeFrames(w, shot.burst, *geometry, options);
    if (shot.truth) writeTruth(w, *shot.truth);
    writeResults(w, shot.results_json);
    writeNote(w, shot.note);
    closeFile(w, file);
    if (!w.ok()) return w.error();  // ~AtomicFile removes the temporary file
  }
  auto committed = temp->commitIfAbsent();
  if (!committed) return committed.error();
  return *committed == AtomicFile::Outcome::Committed ? WriteOutcome::Written
                                                      : WriteOutcome::NameTaken;
}

Status writeShot(const std::string& path, const hw::Shot& shot, const WriteOptions& options) {
  auto written = writeShotIfAbsent(path, shot, options);
  if (!written) return written.error();
  if (*written == WriteOutcome::NameTaken)
    return fail(path +
                " already exists: a shot file is never replaced; "
                "write to another name or move the existing file away first");
  return Ok{};
}

namespace {

Result<hw::Shot> readShotLocked(const std::string& path, const ReadOptions& options) {
  h5::silenceErrorPrinting();
  auto file = openShotFile(path, H5F_ACC_RDONLY);
  if (!file) return file.error();
  h5::Reader r(file->get(), path);
  hw::Shot shot;
  readRoot(r, shot, path);
  readLaunchers(r, shot.launchers);
  readSequencer(r, shot.steps, path);
  readCamera(r, shot.camera, path);
  readScene(r, shot.scene);
  readFrames(r, shot.burst, options.frames, path);
  if (r.ok() && r.exists("/truth")) {
    shot.truth.emplace();
    readTruth(r, *shot.truth);
  }
  if (r.ok() && r.exists("/results")) shot.results_json = r.text("/results/json");
  if (r.ok() && r.exists("/note")) shot.note = r.text("/note");
  if (!r.ok()) return r.error();
  return shot;
}

/// The reader process's work (see reader_process.hpp): the whole read; its
/// error, if any, is the caller's answer (a shot is read again by the caller).
std::optional<std::string> probeRead(const std::string& path, bool frames) {
  auto shot = readShotLocked(path, {.frames = frames, .contained = false});
  if (shot) return std::nullopt;
  return shot.error().message;
}

/// libhdf5 can also loop for ever on a damaged global heap: a read that takes
/// far longer than the disk needs for the whole file is stopped.
double readTimeLimit(const std::string& path, const ReadOptions& options) {
  if (options.time_limit_s > 0) return options.time_limit_s;
  std::error_code ec;
  const double size = static_cast<double>(std::filesystem::file_size(path, ec));
  return 30.0 + (ec ? 0.0 : size / 20e6);  // a slow disk
}

}  // namespace

Result<hw::Shot> readShot(const std::string& path, const ReadOptions& options) {
  std::lock_guard lock(hdf5Mutex());
  // A stalled reader is tried once more; twice stalled, the file is read here
  // (it did not make the library loop: the reader sat idle).
  for (int attempt = 0; options.contained && attempt < 2; ++attempt) {
    const double limit_s = readTimeLimit(path, options);
    ProbeResult probe = probeInReaderProcess(path, options.frames, limit_s, probeRead);
    using End = ProbeResult::End;
    if (probe.end == End::Stalled) continue;
    if (probe.end == End::OwnCodeFailed)
      return fail("reading shot file " + path +
                  " found a memory error in Collide's own reader (a sanitizer build): a bug, not "
                  "the file's; please report it with the file");
    if (probe.end == End::Crashed)
      return fail("shot file " + path + " is corrupt: reading it crashed the HDF5 library (" +
                  probe.how + "); restore it from a backup, or move it out of the folder");
    if (probe.end == End::Looped)
      return fail("shot file " + path + " is corrupt: reading it did not finish within " +
                  std::to_string(static_cast<int>(limit_s)) +
                  " s (the HDF5 library loops on it); restore it from a backup, or move it out "
                  "of the folder");
    if (probe.error) return fail(*probe.error);  // the same read here would give the same
    if (!probe.strings) break;                   // no reader process, or its strings did not arrive
    h5::JournalScope scope(*probe.strings);
    return readShotLocked(path, options);
  }
  return readShotLocked(path, options);
}

// Why a copy rather than an in-place update: HDF5 1.10 has no journal. Replacing
// /results in place rewrites object headers, the group B-tree, the local heap
// and the superblock's end-of-file in several separate writes; a crash, a full
// disk or a kill between them can leave the whole file unreadable, burst
// included. Updating a copy and renaming it over the original keeps the
// recorded data safe at every instant, at the cost of one sequential copy per
// analysis (~0.3 s for a 92 MB burst), which is small next to the analysis.
Status storeResults(const std::string& path, const std::string& results_json) {
  return storeResults(path, results_json, {});
}

namespace {

// Copies the shot file, removes `object` from the copy and lets `write` put
// the new one in, then renames the copy over the original (through
// `at_commit` when given): the recorded data is safe at every instant.
Status replaceInCopy(const std::string& path, const char* object,
                     const std::function<void(h5::Writer&)>& write, const CommitHook& at_commit) {
  std::lock_guard lock(hdf5Mutex());
  // Temporary copies left by an earlier store that was killed midway.
  removeAbandonedTemps(path);
  h5::silenceErrorPrinting();
  {
    // Refuse anything that is not a readable shot file before copying it.
    auto check = openShotFile(path, H5F_ACC_RDONLY);
    if (!check) return check.error();
  }
  auto temp = AtomicFile::createCopyOf(path, path);
  if (!temp) return temp.error();
  {
    Handle fapl = fileAccess();
    Handle file(H5Fopen(temp->tempPath().c_str(), H5F_ACC_RDWR, fapl.get()), H5Fclose);
    if (!file.valid()) return fileError("update", path);
    h5::Writer w(file.get(), path);
    // Unlinking leaves the old object's few bytes unused in the file; not
    // worth a repack.
    if (H5Lexists(file.get(), object, H5P_DEFAULT) > 0 &&
        H5Ldelete(file.get(), object, H5P_DEFAULT) < 0)
      w.failHdf5(std::string("removing the old ") + object);
    write(w);
    closeFile(w, file);
    if (!w.ok()) return w.error();
  }
  if (!at_commit) return temp->commit();
  // The slow part (the copy on disk) is done outside the caller's lock.
  if (auto s = temp->flush(); !s) return s;
  return at_commit([&] { return temp->commit(); });
}

}  // namespace

Status storeResults(const std::string& path, const std::string& results_json,
                    const CommitHook& at_commit) {
  if (!results_json.empty()) {
    auto summary = summarizeResults(results_json);
    if (!summary) return fail("cannot store results in " + path + ": " + summary.error().message);
  }
  return replaceInCopy(
      path, "/results", [&](h5::Writer& w) { writeResults(w, results_json); }, at_commit);
}

Status storeNote(const std::string& path, const std::string& note, const CommitHook& at_commit) {
  return replaceInCopy(
      path, "/note", [&](h5::Writer& w) { writeNote(w, note); }, at_commit);
}

}  // namespace collide::app
