#pragma once
// Test-only writers of small Photron MRAW (+ .cih / .cihx) and Phantom CINE
// files, written from the format descriptions (docs/footage.md), not from the
// readers, so round trips check the readers against an independent encoder.
// Also used by bench/footage_bench.cpp to make a large file to read.
#include <cstdint>
#include <fstream>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace collide::testing {

inline void writeBytes(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream os(path, std::ios::binary | std::ios::trunc);
  os.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

inline void writeText(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::trunc) << text;
}

/// One frame's MRAW bytes: 8-bit as is, 16-bit little-endian words (shifted
/// left by `shift` for data in the upper bits), 12-bit packed two in three
/// bytes, most significant first.
inline std::vector<std::uint8_t> mrawFrameBytes(const cv::Mat& img, int bits, int shift = 0) {
  std::vector<std::uint8_t> out;
  std::vector<unsigned> px;
  for (int r = 0; r < img.rows; ++r)
    for (int c = 0; c < img.cols; ++c)
      px.push_back(img.depth() == CV_8U ? img.at<std::uint8_t>(r, c) : img.at<std::uint16_t>(r, c));
  if (bits == 8) {
    for (unsigned v : px) out.push_back(static_cast<std::uint8_t>(v));
  } else if (bits == 16) {
    for (unsigned v : px) {
      v <<= shift;
      out.push_back(static_cast<std::uint8_t>(v & 0xFF));
      out.push_back(static_cast<std::uint8_t>(v >> 8));
    }
  } else {  // 12
    for (std::size_t i = 0; i + 1 < px.size(); i += 2) {
      out.push_back(static_cast<std::uint8_t>(px[i] >> 4));
      out.push_back(static_cast<std::uint8_t>((px[i] & 0xF) << 4 | px[i + 1] >> 8));
      out.push_back(static_cast<std::uint8_t>(px[i + 1] & 0xFF));
    }
  }
  return out;
}

/// An older-style .cih text header.
inline std::string cihText(int width, int height, int bits, long frames, double fps,
                           const std::string& shutter = "1/100000", long start = 0,
                           int effective = 0, const std::string& side = "Lower") {
  return "#Camera Information Header\n"
         "Date : 2026/3/14\n"
         "Camera Type : FASTCAM test\n"
         "Record Rate(fps) : " +
         std::to_string(static_cast<long>(fps)) + "\nShutter Speed(s) : " + shutter +
         "\nTotal Frame : " + std::to_string(frames) + "\nStart Frame : " + std::to_string(start) +
         "\nCorrect Trigger Frame : 0\nImage Width : " + std::to_string(width) +
         "\nImage Height : " + std::to_string(height) +
         "\nColor Type : Mono\nColor Bit : " + std::to_string(bits) +
         "\nFile Format : MRaw\nEffectiveBit Depth : " +
         std::to_string(effective ? effective : bits) + "\nEffectiveBit Side : " + side +
         "\n\nEND\n";
}

/// A .cihx: a binary preamble, then XML with the fields the reader uses.
inline std::string cihxText(int width, int height, int bits, long frames, double fps,
                            long shutter_ns, long start, const std::string& unit = "",
                            double size_of_pixel = 1.0) {
  std::string pre = "!!! This file can not be edited. !!!";
  pre.append(300 - pre.size(), '\0');
  const std::string res = "<resolution><width>" + std::to_string(width) + "</width><height>" +
                          std::to_string(height) + "</height></resolution>";
  return pre +
         "<?xml version='1.0' encoding='UTF-8'?>\n<cih>\n<imageFileInfo><fileFormat>Mraw"
         "</fileFormat>" +
         res + "</imageFileInfo>\n<imageDataInfo>" + res + "<colorInfo><type>Mono</type><bit>" +
         std::to_string(bits) + "</bit></colorInfo><effectiveBit><depth>" + std::to_string(bits) +
         "</depth><side>Lower</side></effectiveBit></imageDataInfo>\n<frameInfo><totalFrame>" +
         std::to_string(frames) + "</totalFrame><startFrame>" + std::to_string(start) +
         "</startFrame></frameInfo>\n<recordInfo><recordRate>" +
         std::to_string(static_cast<long>(fps)) + "</recordRate><shutterSpeedNsec>" +
         std::to_string(shutter_ns) +
         "</shutterSpeedNsec></recordInfo>\n<deviceInfo><deviceName>FASTCAM test</deviceName>"
         "</deviceInfo>\n<plugin><calibration><distanceUnit>" +
         unit + "</distanceUnit><sizeOfPixel>" + std::to_string(size_of_pixel) +
         "</sizeOfPixel></calibration></plugin>\n</cih>\n";
}

struct CineSpec {
  int width = 16, height = 8;
  int bit_count = 8;      ///< 8 or 16 (unpacked); ignored when packed10
  bool packed10 = false;  ///< 10-bit codes packed four in five bytes, rows top-down
  std::int32_t first_image_no = 0;
  std::uint32_t fps = 1000, shutter_ns = 50000, real_bpp = 8;
  std::uint32_t cfa = 0;
  std::uint16_t compression = 0;
};

/// A CINE file of `frames` (CV_8UC1 for 8-bit, CV_16UC1 otherwise; for
/// packed10 the 10-bit codes). Unpacked rows are written bottom-up.
inline std::vector<std::uint8_t> cineBytes(const CineSpec& s, const std::vector<cv::Mat>& frames) {
  std::vector<std::uint8_t> b;
  auto put16 = [&](std::size_t at, unsigned v) {
    b[at] = v & 0xFF;
    b[at + 1] = (v >> 8) & 0xFF;
  };
  auto put32 = [&](std::size_t at, std::uint32_t v) {
    for (int k = 0; k < 4; ++k) b[at + k] = (v >> (8 * k)) & 0xFF;
  };
  const std::size_t off_bmi = 44, off_setup = 84, setup_len = 5700;
  const std::size_t off_offsets = off_setup + setup_len;
  const std::size_t n = frames.size();
  b.assign(off_offsets + 8 * n, 0);
  b[0] = 'C';
  b[1] = 'I';
  put16(2, 44);
  put16(4, s.compression);
  put16(6, 1);
  put32(8, static_cast<std::uint32_t>(s.first_image_no));
  put32(12, static_cast<std::uint32_t>(n));
  put32(16, static_cast<std::uint32_t>(s.first_image_no));
  put32(20, static_cast<std::uint32_t>(n));
  put32(24, off_bmi);
  put32(28, off_setup);
  put32(32, static_cast<std::uint32_t>(off_offsets));
  put32(off_bmi, 40);
  put32(off_bmi + 4, static_cast<std::uint32_t>(s.width));
  put32(off_bmi + 8, static_cast<std::uint32_t>(s.height));
  put16(off_bmi + 12, 1);
  put16(off_bmi + 14, s.packed10 ? 16 : s.bit_count);
  put32(off_bmi + 16, s.packed10 ? 256 : 0);
  b[off_setup + 140] = 'S';
  b[off_setup + 141] = 'T';
  put16(off_setup + 142, setup_len);
  put32(off_setup + 768, s.fps);
  put32(off_setup + 808, s.cfa);
  put32(off_setup + 896, s.real_bpp);
  put32(off_setup + 1568, s.shutter_ns);
  for (std::size_t i = 0; i < n; ++i) {
    const cv::Mat& m = frames[i];
    std::vector<std::uint8_t> px;
    if (s.packed10) {
      std::vector<unsigned> v;
      for (int r = 0; r < m.rows; ++r)
        for (int c = 0; c < m.cols; ++c) v.push_back(m.at<std::uint16_t>(r, c) & 0x3FF);
      for (std::size_t k = 0; k + 3 < v.size(); k += 4) {
        px.push_back(static_cast<std::uint8_t>(v[k] >> 2));
        px.push_back(static_cast<std::uint8_t>((v[k] & 3) << 6 | v[k + 1] >> 4));
        px.push_back(static_cast<std::uint8_t>((v[k + 1] & 15) << 4 | v[k + 2] >> 6));
        px.push_back(static_cast<std::uint8_t>((v[k + 2] & 63) << 2 | v[k + 3] >> 8));
        px.push_back(static_cast<std::uint8_t>(v[k + 3] & 0xFF));
      }
    } else {
      for (int r = m.rows - 1; r >= 0; --r)  // bottom-up
        for (int c = 0; c < m.cols; ++c) {
          if (s.bit_count == 8) {
            px.push_back(m.at<std::uint8_t>(r, c));
          } else {
            px.push_back(m.at<std::uint16_t>(r, c) & 0xFF);
            px.push_back(m.at<std::uint16_t>(r, c) >> 8);
          }
        }
    }
    const std::size_t at = b.size();
    b.resize(at + 8 + px.size());
    put32(at, 8);  // annotation: its size, then the image size
    put32(at + 4, static_cast<std::uint32_t>(px.size()));
    std::copy(px.begin(), px.end(), b.begin() + static_cast<std::ptrdiff_t>(at + 8));
    for (int k = 0; k < 8; ++k)
      b[off_offsets + 8 * i + k] = (static_cast<std::uint64_t>(at) >> (8 * k)) & 0xFF;
  }
  return b;
}

/// A pco .b16 image: 20-byte header plus the extended flag and colour mode,
/// then 16-bit little-endian pixels at the header size.
inline std::vector<std::uint8_t> b16Bytes(const cv::Mat& img, std::uint32_t header = 1024) {
  std::vector<std::uint8_t> b(header + 2 * img.total(), 0);
  auto put32 = [&](std::size_t at, std::uint32_t v) {
    for (int k = 0; k < 4; ++k) b[at + k] = (v >> (8 * k)) & 0xFF;
  };
  b[0] = 'P', b[1] = 'C', b[2] = 'O', b[3] = '-';
  put32(4, static_cast<std::uint32_t>(b.size()));
  put32(8, header);
  put32(12, static_cast<std::uint32_t>(img.cols));
  put32(16, static_cast<std::uint32_t>(img.rows));
  put32(20, 0xFFFFFFFFu);  // extended header follows
  put32(24, 0);            // monochrome
  std::size_t at = header;
  for (int r = 0; r < img.rows; ++r)
    for (int c = 0; c < img.cols; ++c, at += 2) {
      b[at] = img.at<std::uint16_t>(r, c) & 0xFF;
      b[at + 1] = img.at<std::uint16_t>(r, c) >> 8;
    }
  return b;
}

}  // namespace collide::testing
