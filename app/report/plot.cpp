#include "app/report/plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

namespace collide::app {
namespace {

struct Rgb {
  int r, g, b;
};
// Colour-blind-safe palette (Okabe-Ito).
constexpr Rgb kPalette[] = {{0, 114, 178}, {213, 94, 0},   {0, 158, 115}, {204, 121, 167},
                            {230, 159, 0}, {86, 180, 233}, {0, 0, 0}};
Rgb paletteColour(int i) {
  constexpr int n = sizeof(kPalette) / sizeof(kPalette[0]);
  return kPalette[((i % n) + n) % n];
}
const Rgb kBlack{0, 0, 0};
const Rgb kGrid{225, 225, 225};

enum class Anchor { Start, Middle, End };

// Drawing primitives in pixel coordinates (y down). One layout function draws
// through this interface so the SVG and the PNG cannot disagree.
class Canvas {
 public:
  virtual ~Canvas() = default;
  virtual void line(double x0, double y0, double x1, double y1, Rgb c, double width) = 0;
  virtual void dot(double x, double y, double r, Rgb c) = 0;
  virtual void text(double x, double y, const std::string& s, double size, Anchor a, Rgb c,
                    bool vertical = false) = 0;
};

std::string xmlEscape(const std::string& s) {
  std::string out;
  for (char ch : s) {
    switch (ch) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += ch;
    }
  }
  return out;
}

class SvgCanvas : public Canvas {
 public:
  SvgCanvas(int w, int h) {
    out_ << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << w << "\" height=\"" << h
         << "\" viewBox=\"0 0 " << w << ' ' << h << "\" font-family=\"sans-serif\">\n"
         << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  }
  void line(double x0, double y0, double x1, double y1, Rgb c, double width) override {
    out_ << "<line x1=\"" << x0 << "\" y1=\"" << y0 << "\" x2=\"" << x1 << "\" y2=\"" << y1
         << "\" stroke=\"" << colour(c) << "\" stroke-width=\"" << width << "\"/>\n";
  }
  void dot(double x, double y, double r, Rgb c) override {
    out_ << "<circle cx=\"" << x << "\" cy=\"" << y << "\" r=\"" << r << "\" fill=\"" << colour(c)
         << "\"/>\n";
  }
  void text(double x, double y, const std::string& s, double size, Anchor a, Rgb c,
            bool vertical) override {
    const char* anchor = a == Anchor::Start ? "start" : a == Anchor::Middle ? "middle" : "end";
    out_ << "<text x=\"" << x << "\" y=\"" << y << "\" font-size=\"" << size << "\" text-anchor=\""
         << anchor << "\" fill=\"" << colour(c) << '"';
    if (vertical) out_ << " transform=\"rotate(-90 " << x << ' ' << y << ")\"";
    out_ << '>' << xmlEscape(s) << "</text>\n";
  }
  std::string finish() {
    out_ << "</svg>\n";
    return out_.str();
  }

 private:
  static std::string colour(Rgb c) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "#%02x%02x%02x", c.r, c.g, c.b);
    return buf;
  }
  std::ostringstream out_;
};

class ImageCanvas : public Canvas {
 public:
  ImageCanvas(int w, int h) : img_(h, w, CV_8UC3, cv::Scalar(255, 255, 255)) {}
  void line(double x0, double y0, double x1, double y1, Rgb c, double width) override {
    cv::line(img_, pt(x0, y0), pt(x1, y1), bgr(c), std::max(1, int(std::lround(width))),
             cv::LINE_AA, kShift);
  }
  void dot(double x, double y, double r, Rgb c) override {
    cv::circle(img_, pt(x, y), int(std::lround(r * (1 << kShift))), bgr(c), cv::FILLED, cv::LINE_AA,
               kShift);
  }
  void text(double x, double y, const std::string& s, double size, Anchor a, Rgb c,
            bool vertical) override {
    const double scale = size / 30.0;
    int baseline = 0;
    const cv::Size sz = cv::getTextSize(s, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &baseline);
    const double shift = a == Anchor::Start ? 0 : a == Anchor::Middle ? sz.width / 2.0 : sz.width;
    if (!vertical) {
      cv::putText(img_, s, cv::Point(int(x - shift), int(y)), cv::FONT_HERSHEY_SIMPLEX, scale,
                  bgr(c), 1, cv::LINE_AA);
      return;
    }
    // Draw horizontally on a patch, rotate it a quarter turn, and paste it.
    cv::Mat patch(sz.height + baseline + 2, sz.width + 2, CV_8UC3, cv::Scalar(255, 255, 255));
    cv::putText(patch, s, cv::Point(1, sz.height), cv::FONT_HERSHEY_SIMPLEX, scale, bgr(c), 1,
                cv::LINE_AA);
    cv::rotate(patch, patch, cv::ROTATE_90_COUNTERCLOCKWISE);
    const int left = int(x - patch.cols + baseline);
    const int top = int(y - patch.rows + shift);
    const cv::Rect dst =
        cv::Rect(left, top, patch.cols, patch.rows) & cv::Rect(0, 0, img_.cols, img_.rows);
    if (dst.area() > 0)
      patch(cv::Rect(dst.x - left, dst.y - top, dst.width, dst.height)).copyTo(img_(dst));
  }
  const cv::Mat& image() const { return img_; }

 private:
  static constexpr int kShift = 4;  // sub-pixel drawing precision
  static cv::Point pt(double x, double y) {
    return {int(std::lround(x * (1 << kShift))), int(std::lround(y * (1 << kShift)))};
  }
  static cv::Scalar bgr(Rgb c) { return cv::Scalar(c.b, c.g, c.r); }
  cv::Mat img_;
};

std::string tickLabel(double v, double step) {
  char buf[32];
  const int decimals = std::clamp(int(std::ceil(-std::log10(step) + 1e-9)), 0, 6);
  std::snprintf(buf, sizeof buf, "%.*f", decimals, std::abs(v) < step * 1e-9 ? 0.0 : v);
  return buf;
}

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
  }
  void settle(std::optional<double> fixed_lo, std::optional<double> fixed_hi) {
    if (!std::isfinite(lo)) lo = 0, hi = 1;
    if (hi - lo < 1e-12) lo -= 0.5, hi += 0.5;
    if (fixed_lo) lo = *fixed_lo;
    if (fixed_hi) hi = *fixed_hi;
  }
};

void draw(const PlotSpec& p, Canvas& c, int w, int h) {
  Range xr, yr;
  for (const auto& s : p.series) {
    for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      xr.add(s.x[i]);
      const double e = i < s.y_err.size() && std::isfinite(s.y_err[i]) ? s.y_err[i] : 0.0;
      yr.add(s.y[i] - e);
      yr.add(s.y[i] + e);
    }
  }
  xr.settle(p.x_min, p.x_max);
  yr.settle(p.y_min, p.y_max);
  const std::vector<double> xt = niceTicks(xr.lo, xr.hi), yt = niceTicks(yr.lo, yr.hi);
  if (!p.x_min) xr.lo = std::min(xr.lo, xt.front());
  if (!p.x_max) xr.hi = std::max(xr.hi, xt.back());
  if (!p.y_min) yr.lo = std::min(yr.lo, yt.front());
  if (!p.y_max) yr.hi = std::max(yr.hi, yt.back());

  const double left = 80, right = w - 20.0, top = 40, bottom = h - 60.0;
  auto X = [&](double v) { return left + (v - xr.lo) / (xr.hi - xr.lo) * (right - left); };
  auto Y = [&](double v) { return bottom - (v - yr.lo) / (yr.hi - yr.lo) * (bottom - top); };
  auto inside = [&](double px, double py) {
    return px >= left - 0.5 && px <= right + 0.5 && py >= top - 0.5 && py <= bottom + 0.5;
  };

  const double xstep = xt.size() > 1 ? xt[1] - xt[0] : 1, ystep = yt.size() > 1 ? yt[1] - yt[0] : 1;
  for (double v : xt) {
    if (v < xr.lo - 1e-12 || v > xr.hi + 1e-12) continue;
    c.line(X(v), top, X(v), bottom, kGrid, 1);
    c.text(X(v), bottom + 18, tickLabel(v, xstep), 13, Anchor::Middle, kBlack);
  }
  for (double v : yt) {
    if (v < yr.lo - 1e-12 || v > yr.hi + 1e-12) continue;
    c.line(left, Y(v), right, Y(v), kGrid, 1);
    c.text(left - 6, Y(v) + 4, tickLabel(v, ystep), 13, Anchor::End, kBlack);
  }
  c.line(left, bottom, right, bottom, kBlack, 1);
  c.line(left, top, left, bottom, kBlack, 1);
  c.text((left + right) / 2, 24, p.title, 16, Anchor::Middle, kBlack);
  c.text((left + right) / 2, h - 18.0, p.x_label, 14, Anchor::Middle, kBlack);
  c.text(22, (top + bottom) / 2, p.y_label, 14, Anchor::Middle, kBlack, true);

  double legend_y = top + 16;
  for (const auto& s : p.series) {
    const Rgb col = paletteColour(s.colour);
    if (s.style == Series::Style::Line) {
      // Clip by dropping segments with an end outside the frame: lines here are
      // densely sampled model curves, so this loses at most one sample's length.
      for (std::size_t i = 1; i < s.x.size() && i < s.y.size(); ++i) {
        const double x0 = X(s.x[i - 1]), y0 = Y(s.y[i - 1]), x1 = X(s.x[i]), y1 = Y(s.y[i]);
        if (std::isfinite(x0 + y0 + x1 + y1) && inside(x0, y0) && inside(x1, y1))
          c.line(x0, y0, x1, y1, col, 2);
      }
    } else {
      for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
        const double px = X(s.x[i]), py = Y(s.y[i]);
        if (!std::isfinite(px + py) || !inside(px, py)) continue;
        if (i < s.y_err.size() && std::isfinite(s.y_err[i]) && s.y_err[i] > 0) {
          const double y0 = std::max(top, Y(s.y[i] + s.y_err[i]));
          const double y1 = std::min(bottom, Y(s.y[i] - s.y_err[i]));
          c.line(px, y0, px, y1, col, 1);
        }
        c.dot(px, py, 3.5, col);
      }
    }
    if (!s.label.empty()) {
      if (s.style == Series::Style::Line)
        c.line(right - 170, legend_y - 4, right - 150, legend_y - 4, col, 2);
      else
        c.dot(right - 160, legend_y - 4, 3.5, col);
      c.text(right - 144, legend_y, s.label, 13, Anchor::Start, kBlack);
      legend_y += 18;
    }
  }
}

}  // namespace

std::vector<double> niceTicks(double lo, double hi, int target) {
  if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi)) return {lo};
  const double raw = (hi - lo) / std::max(1, target);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0}) {
    step = m * mag;
    if (step >= raw) break;
  }
  std::vector<double> ticks;
  for (double v = std::floor(lo / step) * step; v <= hi + step * 0.999; v += step)
    ticks.push_back(std::abs(v) < step * 1e-9 ? 0.0 : v);
  return ticks;
}

std::string renderSvg(const PlotSpec& plot, int width, int height) {
  SvgCanvas svg(width, height);
  draw(plot, svg, width, height);
  return svg.finish();
}

Status savePlot(const PlotSpec& plot, const std::string& path_stem, int width, int height) {
  const std::string svg_path = path_stem + ".svg", png_path = path_stem + ".png";
  {
    std::ofstream out(svg_path);
    out << renderSvg(plot, width, height);
    if (!out) return fail("cannot write " + svg_path + ": check the folder exists and is writable");
  }
  ImageCanvas img(width, height);
  draw(plot, img, width, height);
  try {
    if (!cv::imwrite(png_path, img.image()))
      return fail("cannot write " + png_path + ": check the folder exists and is writable");
  } catch (const cv::Exception& e) {
    return fail("cannot write " + png_path + ": " + e.what());
  }
  return Ok{};
}

}  // namespace collide::app
