#include "vision/footage.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <system_error>

#include "vision/footage_reader.hpp"

namespace collide::vision {
namespace detail {

Result<std::shared_ptr<const MappedFile>> MappedFile::open(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    if (err == ENOENT) return fail(path + " does not exist: check the path");
    return fail("cannot open " + path + ": " + std::generic_category().message(err));
  }
  struct stat st {};
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    return fail(path + " is not a regular file: give the footage file itself");
  }
  if (st.st_size == 0) {
    ::close(fd);
    return fail(path + " is empty (0 bytes): the copy or the recording did not finish");
  }
  void* p = mmap(nullptr, static_cast<std::size_t>(st.st_size), PROT_READ, MAP_PRIVATE, fd, 0);
  const int err = errno;
  ::close(fd);  // the mapping stays valid without the descriptor
  if (p == MAP_FAILED)
    return fail("cannot map " + path + " into memory: " + std::generic_category().message(err));
  std::shared_ptr<MappedFile> f(new MappedFile);
  f->data_ = static_cast<const std::uint8_t*>(p);
  f->size_ = static_cast<std::uint64_t>(st.st_size);
  f->path_ = path;
  return std::shared_ptr<const MappedFile>(std::move(f));
}

MappedFile::~MappedFile() {
  if (data_) munmap(const_cast<std::uint8_t*>(data_), static_cast<std::size_t>(size_));
}

void unpack12(const std::uint8_t* in, std::uint16_t* out, std::size_t pixels) {
  for (std::size_t i = 0; i + 1 < pixels; i += 2, in += 3) {
    const unsigned b0 = in[0], b1 = in[1], b2 = in[2];
    out[i] = static_cast<std::uint16_t>(b0 << 4 | b1 >> 4);
    out[i + 1] = static_cast<std::uint16_t>((b1 & 0x0F) << 8 | b2);
  }
}

void unpack10(const std::uint8_t* in, std::uint16_t* out, std::size_t pixels,
              const std::uint16_t* lut) {
  for (std::size_t i = 0; i + 3 < pixels; i += 4, in += 5) {
    const unsigned b0 = in[0], b1 = in[1], b2 = in[2], b3 = in[3], b4 = in[4];
    unsigned v[4] = {b0 << 2 | b1 >> 6, (b1 & 0x3F) << 4 | b2 >> 4, (b2 & 0x0F) << 6 | b3 >> 2,
                     (b3 & 0x03) << 8 | b4};
    for (int k = 0; k < 4; ++k) out[i + k] = static_cast<std::uint16_t>(lut ? lut[v[k]] : v[k]);
  }
}

}  // namespace detail

namespace {

namespace fs = std::filesystem;

std::string lowerExtension(const std::string& path) {
  std::string e = fs::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  return e;
}

std::string num(double v, const char* format = "%g") {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

}  // namespace

bool isFootageFile(const std::string& path) {
  const std::string e = lowerExtension(path);
  return e == ".mraw" || e == ".cih" || e == ".cihx" || e == ".cine" || e == ".b16";
}

Footage::Footage(std::shared_ptr<const detail::FootageReader> reader)
    : reader_(std::move(reader)) {}

Result<Footage> Footage::open(const std::string& path) {
  const std::string e = lowerExtension(path);
  Result<std::unique_ptr<detail::FootageReader>> r =
      e == ".cine"  ? detail::openCine(path)
      : e == ".b16" ? detail::openB16(path)
      : (e == ".mraw" || e == ".cih" || e == ".cihx")
          ? detail::openPhotron(path)
          : Result<std::unique_ptr<detail::FootageReader>>(
                fail(path + " is not a camera file this program reads (.mraw with its .cih/.cihx, "
                            "a .cine, or a pco .b16): convert it to PNG frames or a video"));
  if (!r) return r.error();
  return Footage(std::shared_ptr<const detail::FootageReader>(std::move(*r)));
}

const FootageInfo& Footage::info() const {
  return reader_->info;
}

Status Footage::read(std::int64_t index, cv::Mat& out) const {
  const FootageInfo& in = reader_->info;
  if (index < 0 || index >= in.frame_count)
    return fail("frame index " + std::to_string(index) + " is outside " + in.data_path +
                ", which holds frames 0 to " + std::to_string(in.frame_count - 1));
  out.create(in.height, in.width, cvType(in.pixel_format));
  return reader_->decode(index, out);
}

Result<Frame> Footage::frame(std::int64_t index) const {
  Frame f;
  if (Status s = read(index, f.image); !s) return s.error();
  const FootageInfo& in = reader_->info;
  f.id = in.first_frame + index;
  f.timestamp_ns = in.fps > 0 ? std::llround(static_cast<double>(f.id) * 1e9 / in.fps) : 0;
  return f;
}

Result<Burst> loadFootage(const std::string& path, double fps_or_0, const FootageRange& range,
                          std::uint64_t max_bytes) {
  Result<Footage> footage = Footage::open(path);
  if (!footage) return footage.error();
  return loadFootage(*footage, fps_or_0, range, max_bytes);
}

Result<Burst> loadFootage(const Footage& footage, double fps_or_0, const FootageRange& range,
                          std::uint64_t max_bytes) {
  const FootageInfo& in = footage.info();
  const std::string& path = in.data_path;
  if (!(fps_or_0 >= 0) || !std::isfinite(fps_or_0))
    return fail("frame rate " + num(fps_or_0) + " for " + path +
                " must be > 0, or 0 to use the rate recorded in the file");
  const double fps = fps_or_0 > 0 ? fps_or_0 : in.fps;
  if (!(fps > 0))
    return fail(path + " does not record its frame rate: give the frames/s explicitly (--fps)");

  const std::int64_t lo_id = in.first_frame, hi_id = in.first_frame + in.frame_count - 1;
  const std::int64_t first = range.first_id.value_or(lo_id), last = range.last_id.value_or(hi_id);
  if (first > last || first < lo_id || last > hi_id)
    return fail("frames " + std::to_string(first) + " to " + std::to_string(last) + " are not in " +
                path + ", which holds frames " + std::to_string(lo_id) + " to " +
                std::to_string(hi_id) + ": choose a range inside those");
  const std::uint64_t count = static_cast<std::uint64_t>(last - first + 1);
  const std::uint64_t bytes = count * static_cast<std::uint64_t>(in.width) *
                              static_cast<std::uint64_t>(in.height) *
                              (in.pixel_format == PixelFormat::Mono8 ? 1 : 2);
  if (bytes > max_bytes)
    return fail(path + ": frames " + std::to_string(first) + " to " + std::to_string(last) +
                " would take " + num(static_cast<double>(bytes) / (1 << 20), "%.0f") +
                " MiB decoded (limit " + num(static_cast<double>(max_bytes) / (1 << 20), "%.0f") +
                " MiB): choose a shorter range of frames around the collision");

  Burst burst;
  burst.format = in.pixel_format;
  burst.fps = fps;
  burst.exposure_us = in.exposure_s * 1e6;
  burst.frames.reserve(count);
  for (std::int64_t id = first; id <= last; ++id) {
    Frame f;
    if (Status s = footage.read(id - in.first_frame, f.image); !s) return s.error();
    f.id = id;
    f.timestamp_ns = std::llround(static_cast<double>(id) * 1e9 / fps);
    burst.frames.push_back(std::move(f));
  }
  burst.stats.completed = burst.frames.size();
  burst.note = in.note;
  return burst;
}

std::string describeFootage(const FootageInfo& in) {
  std::string s;
  auto line = [&](const std::string& key, const std::string& value) {
    s += key;
    s.append(key.size() < 14 ? 14 - key.size() : 1, ' ');
    s += value + "\n";
  };
  line("file", in.data_path);
  if (!in.header_path.empty()) line("header", in.header_path);
  line("format", in.format);
  if (!in.camera.empty()) line("camera", in.camera);
  line("size", std::to_string(in.width) + " x " + std::to_string(in.height) + " pixels");
  line("frames", std::to_string(in.frame_count));
  line("frame rate", in.fps > 0 ? num(in.fps) + " frames/s" : "not recorded (give --fps)");
  if (in.fps > 0 && in.frame_count > 0)
    line("duration", num(static_cast<double>(in.frame_count) / in.fps * 1e3, "%.6g") + " ms");
  line("exposure", in.exposure_s > 0 ? num(in.exposure_s * 1e6, "%.6g") + " us" : "not recorded");
  line("bits", std::to_string(in.stored_bits) + (in.packed ? " packed" : "") + " stored, " +
                   std::to_string(in.effective_bits) + " effective (frames decode to " +
                   toString(in.pixel_format) + ")");
  const std::int64_t last = in.first_frame + in.frame_count - 1;
  line("frame ids", std::to_string(in.first_frame) + " to " + std::to_string(last) +
                        (in.trigger_known ? " (trigger = frame 0)" : " (no trigger in the file)"));
  line("pixel size", in.pixel_size_m > 0
                         ? num(in.pixel_size_m * 1e3, "%.6g") + " mm (from the file)"
                         : "not recorded (scale from --diameter-mm)");
  if (in.sensor_pixel_m > 0)
    line("sensor pitch", num(in.sensor_pixel_m * 1e6, "%.4g") + " um (sensor, not object plane)");
  if (!in.note.empty()) line("note", in.note);
  return s;
}

}  // namespace collide::vision
