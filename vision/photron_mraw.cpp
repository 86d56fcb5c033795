// Photron MRAW: headerless raw frames, one after another, described by a .cihx
// (a binary preamble, then XML) or an older .cih ("Key : Value" text lines)
// with the same name. Pixels: 8-bit, 16-bit little-endian words, or 12-bit
// packed two in three bytes, most significant bits first.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <optional>
#include <string_view>
#include <vector>

#include "vision/footage_reader.hpp"

namespace collide::vision::detail {
namespace {

namespace fs = std::filesystem;

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

std::string lower(std::string_view s) {
  std::string r(s);
  std::transform(r.begin(), r.end(), r.begin(), [](unsigned char c) { return std::tolower(c); });
  return r;
}

std::optional<std::int64_t> toInt(std::string_view s) {
  s = trim(s);
  std::int64_t v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size()) return std::nullopt;
  return v;
}

std::optional<double> toDouble(std::string_view s) {
  const std::string t(trim(s));
  if (t.empty()) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(t.c_str(), &end);
  if (end != t.c_str() + t.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

/// Text inside the element reached by following `path` from the document,
/// each step looked for inside the previous element; nullopt if absent.
std::optional<std::string> xmlText(std::string_view xml,
                                   std::initializer_list<std::string_view> path) {
  std::size_t b = 0, e = xml.size();
  for (std::string_view name : path) {
    std::string open(1, '<');
    open.append(name);
    std::size_t at = b;
    for (;;) {
      at = xml.find(open, at);
      if (at == std::string_view::npos || at >= e) return std::nullopt;
      const std::size_t after = at + open.size();
      if (after < e && (xml[after] == '>' || xml[after] == ' ' || xml[after] == '/')) break;
      at = after;  // a longer name with this prefix
    }
    const std::size_t gt = xml.find('>', at);
    if (gt == std::string_view::npos || gt >= e) return std::nullopt;
    if (xml[gt - 1] == '/') {  // <name/>: present and empty
      b = e = gt + 1;
      continue;
    }
    std::string end_tag("</");
    end_tag.append(name).push_back('>');
    const std::size_t close = xml.find(end_tag, gt + 1);
    if (close == std::string_view::npos || close > e) return std::nullopt;
    b = gt + 1;
    e = close;
  }
  return std::string(trim(xml.substr(b, e - b)));
}

/// What the .cih or .cihx says, before checking.
struct Header {
  std::optional<std::int64_t> width, height, bits, effective_bits, total, start, save_step;
  std::optional<double> fps, exposure_s, pixel_size_m;
  std::string file_format, color_type, effective_side, camera;
};

Result<std::string> readHeaderFile(const std::string& path) {
  auto mapped = MappedFile::open(path);
  if (!mapped) return mapped.error();
  constexpr std::uint64_t kMaxHeader = 64u << 20;
  if ((*mapped)->size() > kMaxHeader)
    return fail(path + " is " + std::to_string((*mapped)->size() >> 20) +
                " MiB, too large for a Photron header (.cih/.cihx are kilobytes): is it the "
                "right file?");
  return std::string(reinterpret_cast<const char*>((*mapped)->data()), (*mapped)->size());
}

// Exposure from .cih "Shutter Speed(s)": "1/800000" or a decimal number of seconds.
std::optional<double> shutterSeconds(std::string_view v) {
  v = trim(v);
  if (const std::size_t slash = v.find('/'); slash != std::string_view::npos) {
    const auto n = toDouble(v.substr(0, slash)), d = toDouble(v.substr(slash + 1));
    if (n && d && *d > 0) return *n / *d;
    return std::nullopt;
  }
  return toDouble(v);
}

Result<Header> parseCihx(const std::string& path, const std::string& text) {
  const std::size_t at = text.find("<?xml");
  if (at == std::string::npos)
    return fail(path +
                " holds no XML (no '<?xml'): it is not a .cihx header, or it is damaged; "
                "use the .cihx saved with the .mraw");
  const std::string_view xml = std::string_view(text).substr(at);
  if (!xmlText(xml, {"cih"}))
    return fail(path + " has XML but no <cih> element: not a Photron .cihx header");
  Header h;
  auto i = [&](std::initializer_list<std::string_view> p) -> std::optional<std::int64_t> {
    auto t = xmlText(xml, p);
    return t ? toInt(*t) : std::nullopt;
  };
  auto d = [&](std::initializer_list<std::string_view> p) -> std::optional<double> {
    auto t = xmlText(xml, p);
    return t ? toDouble(*t) : std::nullopt;
  };
  h.width = i({"cih", "imageDataInfo", "resolution", "width"});
  if (!h.width) h.width = i({"cih", "imageFileInfo", "resolution", "width"});
  h.height = i({"cih", "imageDataInfo", "resolution", "height"});
  if (!h.height) h.height = i({"cih", "imageFileInfo", "resolution", "height"});
  h.bits = i({"cih", "imageDataInfo", "colorInfo", "bit"});
  h.effective_bits = i({"cih", "imageDataInfo", "effectiveBit", "depth"});
  h.effective_side = xmlText(xml, {"cih", "imageDataInfo", "effectiveBit", "side"}).value_or("");
  h.color_type = xmlText(xml, {"cih", "imageDataInfo", "colorInfo", "type"}).value_or("");
  h.file_format = xmlText(xml, {"cih", "imageFileInfo", "fileFormat"}).value_or("");
  h.total = i({"cih", "frameInfo", "totalFrame"});
  h.start = i({"cih", "frameInfo", "startFrame"});
  h.save_step = i({"cih", "frameInfo", "skipFrame"});
  h.fps = d({"cih", "recordInfo", "recordRate"});
  if (auto ns = d({"cih", "recordInfo", "shutterSpeedNsec"}); ns && *ns > 0)
    h.exposure_s = *ns * 1e-9;
  else if (auto inv = d({"cih", "recordInfo", "shutterSpeed"}); inv && *inv > 0)
    h.exposure_s = 1 / *inv;  // shutterSpeed is the denominator of 1/N s
  h.camera = xmlText(xml, {"cih", "deviceInfo", "deviceName"}).value_or("");
  // Calibration: sizeOfPixel in distanceUnit, only when a unit is set (an
  // uncalibrated file has an empty unit and sizeOfPixel 1.0).
  const std::string unit =
      lower(xmlText(xml, {"cih", "plugin", "calibration", "distanceUnit"}).value_or(""));
  const auto size = d({"cih", "plugin", "calibration", "sizeOfPixel"});
  static const std::map<std::string, double> kUnits = {
      {"m", 1.0}, {"cm", 1e-2}, {"mm", 1e-3}, {"um", 1e-6}, {"\xC2\xB5m", 1e-6}};
  if (auto u = kUnits.find(unit); u != kUnits.end() && size && *size > 0)
    h.pixel_size_m = *size * u->second;
  return h;
}

Result<Header> parseCih(const std::string& path, const std::string& text) {
  std::map<std::string, std::string> kv;
  std::string_view rest(text);
  while (!rest.empty()) {
    const std::size_t nl = rest.find('\n');
    std::string_view line = rest.substr(0, nl);
    rest = nl == std::string_view::npos ? std::string_view() : rest.substr(nl + 1);
    const std::size_t colon = line.find(':');
    if (colon == std::string_view::npos) continue;
    const std::string key(trim(line.substr(0, colon)));
    if (!key.empty() && key[0] != '#' && !kv.count(key)) kv[key] = trim(line.substr(colon + 1));
  }
  if (!kv.count("Image Width") || !kv.count("Total Frame"))
    return fail(path +
                " has no 'Image Width' / 'Total Frame' lines: not a Photron .cih header, "
                "or it is damaged; use the .cih saved with the .mraw");
  Header h;
  auto i = [&](const char* k) -> std::optional<std::int64_t> {
    auto it = kv.find(k);
    return it == kv.end() ? std::nullopt : toInt(it->second);
  };
  auto s = [&](const char* k) {
    auto it = kv.find(k);
    return it == kv.end() ? std::string() : it->second;
  };
  h.width = i("Image Width");
  h.height = i("Image Height");
  h.bits = i("Color Bit");
  h.effective_bits = i("EffectiveBit Depth");
  h.effective_side = s("EffectiveBit Side");
  h.color_type = s("Color Type");
  h.file_format = s("File Format");
  h.total = i("Total Frame");
  h.start = i("Start Frame");
  h.save_step = i("Save Step");
  if (auto it = kv.find("Record Rate(fps)"); it != kv.end()) h.fps = toDouble(it->second);
  if (auto ns = i("Shutter Type2(nsec)"); ns && *ns > 0)
    h.exposure_s = static_cast<double>(*ns) * 1e-9;
  else if (auto it = kv.find("Shutter Speed(s)"); it != kv.end())
    h.exposure_s = shutterSeconds(it->second);
  h.camera = s("Camera Type");
  return h;
}

class PhotronReader final : public FootageReader {
 public:
  std::shared_ptr<const MappedFile> file;
  int shift = 0;  // right shift of 16-bit words whose data sits in the upper bits

  Status decode(std::int64_t index, cv::Mat& out) const override {
    const std::uint8_t* src = file->data() + static_cast<std::uint64_t>(index) * info.frame_bytes;
    const std::size_t w = static_cast<std::size_t>(info.width);
    switch (info.stored_bits) {
      case 8:
        for (int r = 0; r < info.height; ++r) std::memcpy(out.ptr(r), src + r * w, w);
        break;
      case 16:
        for (int r = 0; r < info.height; ++r) {
          std::uint16_t* row = out.ptr<std::uint16_t>(r);
          const std::uint8_t* in = src + 2 * w * static_cast<std::size_t>(r);
          for (std::size_t c = 0; c < w; ++c)
            row[c] = static_cast<std::uint16_t>(le16(in + 2 * c) >> shift);
        }
        break;
      case 12: {
        const std::size_t pixels = w * static_cast<std::size_t>(info.height);
        if (out.isContinuous()) {
          unpack12(src, out.ptr<std::uint16_t>(0), pixels);
        } else {
          std::vector<std::uint16_t> tmp(pixels);
          unpack12(src, tmp.data(), pixels);
          for (int r = 0; r < info.height; ++r) std::memcpy(out.ptr(r), tmp.data() + r * w, 2 * w);
        }
        break;
      }
    }
    return Ok{};
  }
};

std::optional<std::string> sibling(const fs::path& p, std::initializer_list<const char*> exts) {
  std::error_code ec;
  for (const char* e : exts) {
    fs::path c = p;
    c.replace_extension(e);
    if (fs::is_regular_file(c, ec)) return c.string();
  }
  return std::nullopt;
}

}  // namespace

Result<std::unique_ptr<FootageReader>> openPhotron(const std::string& path) {
  const fs::path p(path);
  std::string ext = lower(p.extension().string());
  std::string header_path, data_path;
  if (ext == ".mraw") {
    data_path = path;
    auto h = sibling(p, {".cihx", ".CIHX", ".cih", ".CIH"});
    if (!h)
      return fail("no header " + p.stem().string() + ".cihx or .cih next to " + path +
                  ": an MRAW file holds only pixels; copy the .cihx/.cih saved with it into the "
                  "same folder");
    header_path = *h;
  } else {
    header_path = path;
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) return fail(path + " does not exist: check the path");
    auto d = sibling(p, {".mraw", ".MRAW"});
    if (!d)
      return fail("no " + p.stem().string() + ".mraw next to " + path +
                  ": the header describes pixels saved in an MRAW file of the same name; copy "
                  "it into the same folder (TIFF/AVI exports are not read as such)");
    data_path = *d;
  }
  Result<std::string> text = readHeaderFile(header_path);
  if (!text) return text.error();
  const bool xml = lower(fs::path(header_path).extension().string()) == ".cihx";
  Result<Header> parsed = xml ? parseCihx(header_path, *text) : parseCih(header_path, *text);
  if (!parsed) return parsed.error();
  const Header& h = *parsed;

  auto bad = [&](const std::string& what) {
    return fail(header_path + ": " + what + ": the header is damaged or not from a Photron camera");
  };
  if (!h.file_format.empty() && lower(h.file_format) != "mraw")
    return fail(header_path + " says the frames were saved as " + h.file_format +
                ", not MRaw: load those files (a folder of TIFF frames, or the video) instead");
  if (!h.color_type.empty() && lower(h.color_type) != "mono")
    return fail(header_path + " describes " + h.color_type +
                " footage; only monochrome MRAW is read: save the footage as Mono from PFV");
  if (!h.width || !h.height || *h.width < 1 || *h.height < 1 || *h.width > kMaxSide ||
      *h.height > kMaxSide || *h.width * *h.height > kMaxPixels)
    return bad("frame size " + std::to_string(h.width.value_or(0)) + " x " +
               std::to_string(h.height.value_or(0)) + " is missing or impossible");
  if (!h.bits || (*h.bits != 8 && *h.bits != 12 && *h.bits != 16))
    return fail(header_path + ": " +
                (h.bits ? std::to_string(*h.bits) + "-bit" : std::string("no bit depth")) +
                " MRAW; this reader decodes 8-, 12- (packed) and 16-bit Mono MRAW");
  if (*h.bits == 12 && (*h.width * *h.height) % 2 != 0)
    return bad("12-bit frames of an odd number of pixels cannot be packed two in three bytes");
  if (!h.total || *h.total < 1)
    return bad("frame count " + std::to_string(h.total.value_or(0)) + " is missing or < 1");

  auto mapped = MappedFile::open(data_path);
  if (!mapped) return mapped.error();
  auto r = std::make_unique<PhotronReader>();
  r->file = std::move(*mapped);
  FootageInfo& in = r->info;
  in.format = "Photron MRAW";
  in.data_path = data_path;
  in.header_path = header_path;
  in.camera = h.camera;
  in.width = static_cast<int>(*h.width);
  in.height = static_cast<int>(*h.height);
  in.stored_bits = static_cast<int>(*h.bits);
  in.packed = in.stored_bits == 12;
  in.frame_bytes = static_cast<std::uint64_t>(*h.width * *h.height) *
                   static_cast<std::uint64_t>(in.stored_bits) / 8;
  in.effective_bits = in.stored_bits;
  if (h.effective_bits && *h.effective_bits >= 1 && *h.effective_bits <= in.stored_bits)
    in.effective_bits = static_cast<int>(*h.effective_bits);
  if (in.stored_bits == 16 && in.effective_bits < 16 && lower(h.effective_side) == "higher")
    r->shift = 16 - in.effective_bits;
  in.pixel_format = pixelFormatFor(in.stored_bits, in.effective_bits);
  const std::uint64_t held = r->file->size() / in.frame_bytes;
  if (held < static_cast<std::uint64_t>(*h.total))
    return fail(data_path + " holds " + std::to_string(held) + " complete frame" +
                (held == 1 ? "" : "s") + " of " + std::to_string(in.frame_bytes) +
                " bytes but its header " + header_path + " says " + std::to_string(*h.total) +
                ": the file is truncated (an interrupted copy?) or the header belongs to another "
                "recording; copy it again");
  in.frame_count = *h.total;
  if (h.fps && *h.fps > 0) in.fps = *h.fps;
  if (h.exposure_s && *h.exposure_s > 0) in.exposure_s = *h.exposure_s;
  if (h.start) {
    in.first_frame = *h.start;
    in.trigger_known = true;
  }
  if (h.pixel_size_m) in.pixel_size_m = *h.pixel_size_m;
  if (h.save_step && *h.save_step > 1)
    in.note = "the header gives a save step (skip) of " + std::to_string(*h.save_step) +
              "; frames are taken as 1/fps apart: if every Nth frame was saved, give the real "
              "rate with --fps";
  if (r->file->size() > static_cast<std::uint64_t>(*h.total) * in.frame_bytes)
    in.note +=
        std::string(in.note.empty() ? "" : "; ") + "the MRAW file holds " +
        std::to_string(r->file->size() - static_cast<std::uint64_t>(*h.total) * in.frame_bytes) +
        " bytes more than the header's frames (ignored)";
  return std::unique_ptr<FootageReader>(std::move(r));
}

}  // namespace collide::vision::detail
