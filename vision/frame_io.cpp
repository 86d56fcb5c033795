#include "vision/frame_io.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <memory>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <optional>
#include <set>
#include <system_error>
#include <vector>

#include "vision/footage.hpp"

namespace collide::vision {
namespace {

namespace fs = std::filesystem;

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

bool isImageExtension(const fs::path& p) {
  static const std::set<std::string> kExtensions = {".png", ".tif", ".tiff", ".pgm",  ".ppm",
                                                    ".pnm", ".bmp", ".jpg",  ".jpeg", ".b16"};
  return kExtensions.count(lower(p.extension().string())) > 0;
}

std::string sizeText(const cv::Mat& m) {
  return std::to_string(m.cols) + "x" + std::to_string(m.rows);
}

int bitsOf(const cv::Mat& m) {
  return m.depth() == CV_8U ? 8 : 16;
}

// Brings a decoded image to one grey channel of 8 or 16 bits, or says why not.
Result<cv::Mat> toGrey(cv::Mat img, const std::string& what) {
  if (img.depth() != CV_8U && img.depth() != CV_16U)
    return fail(what + " has " + cv::typeToString(img.type()) +
                " pixels; only 8- or 16-bit unsigned images are supported: convert it to 8- or "
                "16-bit grey");
  switch (img.channels()) {
    case 1: return img;
    case 3: cv::cvtColor(img, img, cv::COLOR_BGR2GRAY); return img;
    case 4: cv::cvtColor(img, img, cv::COLOR_BGRA2GRAY); return img;
    default:
      return fail(what + " has " + std::to_string(img.channels()) +
                  " channels; convert it to grey (1 channel) or colour (3 channels)");
  }
}

// Mono12 when every pixel of a 16-bit burst fits in 12 bits (a 12-bit camera's
// data in 16-bit words), so the burst keeps its real full scale.
PixelFormat formatOf(const std::vector<Frame>& frames) {
  if (frames.empty() || frames.front().image.depth() == CV_8U) return PixelFormat::Mono8;
  for (const Frame& f : frames) {
    double hi = 0;
    cv::minMaxLoc(f.image, nullptr, &hi);
    if (hi > 4095) return PixelFormat::Mono16;
  }
  return PixelFormat::Mono12;
}

std::int64_t timestampNs(std::size_t i, double fps) {
  return std::llround(static_cast<double>(i) * 1e9 / fps);
}

std::string listSome(const std::vector<std::string>& names) {
  constexpr std::size_t kShown = 5;
  std::string s;
  for (std::size_t i = 0; i < names.size() && i < kShown; ++i) s += (i ? ", " : "") + names[i];
  if (names.size() > kShown) s += " and " + std::to_string(names.size() - kShown) + " more";
  return s;
}

int digitsOf(std::uint64_t n) {
  int d = 1;
  while (n >= 10) n /= 10, ++d;
  return d;
}

bool allDigits(const std::string& s) {
  return !s.empty() &&
         std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); });
}

// frame_<digits>_id[-]<digits>.png
bool isExportedFrameName(const std::string& name) {
  if (name.rfind("frame_", 0) != 0 || name.size() < 4 ||
      lower(name.substr(name.size() - 4)) != ".png")
    return false;
  const std::string stem = name.substr(6, name.size() - 10);
  const std::size_t sep = stem.find("_id");
  if (sep == std::string::npos) return false;
  std::string id = stem.substr(sep + 3);
  if (!id.empty() && id[0] == '-') id.erase(0, 1);
  return allDigits(stem.substr(0, sep)) && allDigits(id);
}

}  // namespace

bool naturalLess(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i]));
    const bool db = std::isdigit(static_cast<unsigned char>(b[j]));
    if (da && db) {
      // Compare the digit runs as numbers: skip leading zeros, then the longer
      // run is larger, else the first differing digit decides.
      std::size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      std::size_t is = i, js = j;
      while (is + 1 < ie && a[is] == '0') ++is;
      while (js + 1 < je && b[js] == '0') ++js;
      if (ie - is != je - js) return ie - is < je - js;
      const int c = a.compare(is, ie - is, b, js, je - js);
      if (c != 0) return c < 0;
      i = ie;
      j = je;
    } else {
      if (a[i] != b[j]) return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
      ++i;
      ++j;
    }
  }
  if ((a.size() - i) != (b.size() - j)) return a.size() - i < b.size() - j;
  return a < b;  // equal as numbers ("frame01" vs "frame1"): any fixed order
}

std::string frameFileName(std::size_t index, std::int64_t id, int digits) {
  std::string text = std::to_string(index);
  const std::size_t width = static_cast<std::size_t>(std::max(1, digits));
  if (text.size() < width) text.insert(0, width - text.size(), '0');
  return "frame_" + text + "_id" + std::to_string(id) + ".png";
}

Result<FrameFolder> listFrameFolder(const std::string& dir) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) return fail("frame folder " + dir + " does not exist: check the path");
  if (!fs::is_directory(dir, ec))
    return fail(dir + " is not a folder: give the folder that holds the frame images");
  std::vector<std::string> images, skipped;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (it->is_regular_file(ec) && isImageExtension(it->path()))
      images.push_back(name);
    else
      skipped.push_back(name);
  }
  if (ec) return fail("cannot list frame folder " + dir + ": " + ec.message());
  std::sort(skipped.begin(), skipped.end(), naturalLess);
  if (images.empty())
    return fail("frame folder " + dir + " holds no images (PNG or TIFF)" +
                (skipped.empty() ? std::string() : " (found only: " + listSome(skipped) + ")") +
                ": give the folder that holds the frames");
  std::sort(images.begin(), images.end(), naturalLess);
  FrameFolder out;
  for (const std::string& name : images) out.paths.push_back((fs::path(dir) / name).string());
  if (!skipped.empty())
    out.note = "skipped " + std::to_string(skipped.size()) +
               " entries that are not images: " + listSome(skipped);
  return out;
}

namespace {

// The format a frame file's name promises, checked against its first bytes
// before any decoder sees it: OpenCV picks its decoder by content, not by
// name, so a damaged ".jpg" that happens to read as DICOM or JPEG 2000 would
// reach a library that aborts the process on bad input (libgdcm's asserts).
// Only the formats isImageExtension() names get through.
Status checkSignature(const std::string& path) {
  const std::string ext = lower(fs::path(path).extension().string());
  unsigned char head[8] = {0};
  std::ifstream in(path, std::ios::binary);
  in.read(reinterpret_cast<char*>(head), sizeof head);
  const auto got = static_cast<std::size_t>(in.gcount());
  const auto starts = [&](std::initializer_list<unsigned char> magic) {
    return got >= magic.size() && std::equal(magic.begin(), magic.end(), head);
  };
  bool ok = false;
  std::string what;
  if (ext == ".png") {
    ok = starts({0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a}), what = "PNG";
  } else if (ext == ".tif" || ext == ".tiff") {
    ok = starts({'I', 'I', 42, 0}) || starts({'M', 'M', 0, 42}), what = "TIFF";
  } else if (ext == ".pgm" || ext == ".ppm" || ext == ".pnm") {
    ok = got >= 2 && head[0] == 'P' && head[1] >= '1' && head[1] <= '6', what = "PNM";
  } else if (ext == ".bmp") {
    ok = starts({'B', 'M'}), what = "BMP";
  } else if (ext == ".jpg" || ext == ".jpeg") {
    ok = starts({0xff, 0xd8, 0xff}), what = "JPEG";
  }
  if (ok) return Ok{};
  return fail(path + " is not a " + (what.empty() ? ext : what) +
              " file (its first bytes say otherwise): it is damaged or misnamed; replace it or "
              "move it out of the folder");
}

}  // namespace

Result<cv::Mat> readFrameImage(const std::string& path) {
  cv::Mat img;
  if (lower(fs::path(path).extension().string()) == ".b16") {  // pco: not an OpenCV format
    auto b16 = Footage::open(path);
    if (!b16) return b16.error();
    if (Status s = b16->read(0, img); !s) return s.error();
  } else {
    if (Status s = checkSignature(path); !s) return s.error();
    try {
      img = cv::imread(path, cv::IMREAD_UNCHANGED);
    } catch (const cv::Exception&) {
      img.release();
    }
  }
  if (img.empty())
    return fail("cannot decode " + path + " as an image: the file is damaged or not really " +
                lower(fs::path(path).extension().string()) +
                "; replace it or move it out of the folder");
  return toGrey(std::move(img), path);
}

Status checkSameFrame(const cv::Mat& first, const std::string& first_path, const cv::Mat& image,
                      const std::string& path) {
  if (image.size() != first.size())
    return fail(path + " is " + sizeText(image) + " pixels but the first frame " + first_path +
                " is " + sizeText(first) +
                ": all frames of a shot must be the same size; remove the odd file");
  if (image.depth() != first.depth())
    return fail(path + " is " + std::to_string(bitsOf(image)) + "-bit but the first frame " +
                first_path + " is " + std::to_string(bitsOf(first)) +
                "-bit: all frames of a shot must have the same bit depth");
  return Ok{};
}

Result<Burst> loadFrameFolder(const std::string& dir, double fps) {
  if (!(fps > 0) || !std::isfinite(fps))
    return fail("frame rate " + std::to_string(fps) + " for " + dir +
                " is not > 0: give the frames/s the footage was recorded at");
  auto folder = listFrameFolder(dir);
  if (!folder) return folder.error();
  const std::vector<std::string>& paths = folder->paths;
  Burst burst;
  burst.fps = fps;
  burst.frames.reserve(paths.size());
  for (std::size_t i = 0; i < paths.size(); ++i) {
    Result<cv::Mat> grey = readFrameImage(paths[i]);
    if (!grey) return grey.error();
    if (!burst.frames.empty())
      if (Status st = checkSameFrame(burst.frames.front().image, paths[0], *grey, paths[i]); !st)
        return st.error();
    Frame f;
    f.id = static_cast<std::int64_t>(i);
    f.timestamp_ns = timestampNs(i, fps);
    f.image = std::move(*grey);
    burst.frames.push_back(std::move(f));
  }
  burst.format = formatOf(burst.frames);
  burst.stats.completed = burst.frames.size();
  burst.note = folder->note;
  return burst;
}

namespace {

// A video opened for decoding in order: OpenCV's capture (FFmpeg, or its own
// MJPEG reader) and the number of the frame it decodes next.
struct VideoReader {
  std::string path;
  double fps = 0;
  cv::VideoCapture cap;
  std::int64_t next = 0;
  cv::Size size;  ///< frame 0's, which every other must have

  std::string convert() const {
    return ": convert it to PNG frames (e.g. ffmpeg -i " + path +
           " frame_%05d.png) and load the folder instead";
  }
  Error decodeFailed(const cv::Exception& e) const {
    return fail("decoding " + path + " failed at frame " + std::to_string(next) + " (" + e.what() +
                ")" + convert());
  }
  Status open() {
    // Not CAP_ANY: on an undecodable file that also tries the GStreamer and
    // image-sequence backends, which print errors to stderr.
    cap.release();
    for (const int api : {cv::CAP_FFMPEG, cv::CAP_OPENCV_MJPEG}) {
      try {
        if (cap.open(path, api)) break;
      } catch (const cv::Exception&) {
        cap.release();
      }
    }
    next = 0;
    if (!cap.isOpened())
      return fail("cannot open " + path +
                  " as a video (damaged file, or a format this OpenCV build cannot decode)" +
                  convert());
    return Ok{};
  }
  /// The next frame, grey, or none at the end of the file.
  Result<std::optional<Frame>> readNext() {
    cv::Mat img;
    try {
      if (!cap.read(img)) return std::optional<Frame>{};
    } catch (const cv::Exception& e) {
      return decodeFailed(e);
    }
    Result<cv::Mat> grey = toGrey(img.clone(), path + " frame " + std::to_string(next));
    if (!grey) return grey.error();
    if (size.empty()) size = grey->size();
    if (grey->size() != size)
      return fail(path + " changes frame size at frame " + std::to_string(next) + convert());
    Frame f;
    f.id = next;
    f.timestamp_ns = timestampNs(static_cast<std::size_t>(next), fps);
    f.image = std::move(*grey);
    ++next;
    return std::optional<Frame>(std::move(f));
  }
  /// Frames skipped (decoded, not converted) until `next` is i or the file ends.
  Status skipTo(std::int64_t i) {
    try {
      while (next < i && cap.grab()) ++next;
    } catch (const cv::Exception& e) {
      return decodeFailed(e);
    }
    return Ok{};
  }
  /// Frame i: decoded forward from the last one read, the file opened again
  /// to go back.
  Result<Frame> read(std::int64_t i) {
    if (i < next)
      if (Status st = open(); !st) return st.error();
    if (Status st = skipTo(i); !st) return st.error();
    auto f = readNext();
    if (!f) return f.error();
    if (!*f) return fail(path + " ends before frame " + std::to_string(i));
    return std::move(**f);
  }
};

Result<std::shared_ptr<VideoReader>> openVideoReader(const std::string& path, double fps_or_0) {
  if (!(fps_or_0 >= 0) || !std::isfinite(fps_or_0))
    return fail("frame rate " + std::to_string(fps_or_0) + " for " + path +
                " must be > 0, or 0 to use the rate recorded in the file");
  std::error_code ec;
  if (!fs::is_regular_file(path, ec))
    return fail("video file " + path + " does not exist (or is not a file): check the path");
  auto v = std::make_shared<VideoReader>();
  v->path = path;
  if (Status st = v->open(); !st) return st.error();
  v->fps = fps_or_0;
  if (v->fps == 0) {
    v->fps = v->cap.get(cv::CAP_PROP_FPS);
    if (!(v->fps > 0) || !std::isfinite(v->fps))
      return fail(path + " does not record its frame rate: give the frames/s explicitly");
  }
  return v;
}

}  // namespace

Result<Burst> loadVideo(const std::string& path, double fps_or_0) {
  auto v = openVideoReader(path, fps_or_0);
  if (!v) return v.error();
  Burst burst;
  burst.fps = (*v)->fps;
  for (;;) {
    auto f = (*v)->readNext();
    if (!f) return f.error();
    if (!*f) break;
    burst.frames.push_back(std::move(**f));
  }
  if (burst.frames.empty())
    return fail("no frames could be decoded from " + path + (*v)->convert());
  burst.format = formatOf(burst.frames);
  burst.stats.completed = burst.frames.size();
  return burst;
}

Result<VideoStream> openVideoStream(const std::string& path, double fps_or_0) {
  auto v = openVideoReader(path, fps_or_0);
  if (!v) return v.error();
  VideoReader& r = **v;
  // Frame 0 for the size and format, then the rest only counted.
  auto f0 = r.readNext();
  if (!f0) return f0.error();
  if (!*f0) return fail("no frames could be decoded from " + path + r.convert());
  VideoStream out;
  out.fps = r.fps;
  out.width = (*f0)->image.cols;
  out.height = (*f0)->image.rows;
  out.format = formatOf({**f0});
  if (Status st = r.skipTo(std::numeric_limits<std::int64_t>::max()); !st) return st.error();
  out.count = r.next;  // at the end: the first read opens the file again
  auto shared = std::make_shared<std::mutex>();
  out.read = [v = *v, shared](std::int64_t i) -> Result<Frame> {
    std::lock_guard lock(*shared);
    return v->read(i);
  };
  return out;
}

Status writeFramePng(const Frame& frame, const std::string& path) {
  if (frame.image.empty())
    return fail("frame " + std::to_string(frame.id) + " has no image; nothing to write to " + path);
  if (frame.image.type() != CV_8UC1 && frame.image.type() != CV_16UC1)
    return fail("frame " + std::to_string(frame.id) + " has " +
                cv::typeToString(frame.image.type()) +
                " pixels; only 8- or 16-bit grey can be "
                "written to " +
                path);
  if (lower(fs::path(path).extension().string()) != ".png")
    return fail(path + " does not end in .png: frames are written as PNG files");
  const fs::path parent = fs::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty() && !fs::is_directory(parent, ec))
    return fail("cannot write " + path + ": folder " + parent.string() + " does not exist");
  bool written = false;
  try {
    written = cv::imwrite(path, frame.image);
  } catch (const cv::Exception&) {
    written = false;
  }
  if (!written) return fail("cannot write " + path + ": check permissions and free disk space");
  return Ok{};
}

Result<PngExportReport> exportBurstPng(const Burst& burst, const std::string& dir,
                                       const PngExportOptions& options) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir, ec))
    return fail("cannot create export folder " + dir + ": check the path and permissions");

  const int digits = std::max(4, digitsOf(burst.frames.empty() ? 0 : burst.frames.size() - 1));
  std::set<std::int64_t> ids;
  std::set<std::string> names;
  for (std::size_t i = 0; i < burst.frames.size(); ++i) {
    const Frame& f = burst.frames[i];
    if (!ids.insert(f.id).second)
      return fail("the burst has two frames with id " + std::to_string(f.id) +
                  "; nothing was written to " + dir);
    names.insert(frameFileName(i, f.id, digits));
  }

  // Frames left by an earlier export would be read back as part of this one.
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (isExportedFrameName(name) && names.count(name) == 0)
      return fail(dir + " already holds frames from another export (" + name +
                  "): choose an empty folder or delete them");
  }

  const bool stretch = options.stretch_mono12 && burst.format == PixelFormat::Mono12;
  PngExportReport report;
  for (std::size_t i = 0; i < burst.frames.size(); ++i) {
    Frame f = burst.frames[i];
    if (f.image.empty()) {
      ++report.skipped;
      continue;
    }
    if (stretch) f.image.convertTo(f.image, CV_16U, 16.0);
    const Status s = writeFramePng(f, (fs::path(dir) / frameFileName(i, f.id, digits)).string());
    if (!s) return s.error();
    ++report.written;
  }
  return report;
}

}  // namespace collide::vision
