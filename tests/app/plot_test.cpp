#include "app/report/plot.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <regex>

using namespace collide::app;

static int count(const std::string& s, const std::string& what) {
  int n = 0;
  for (auto p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
  return n;
}

TEST(Plot, NiceTicksCoverTheRangeWithRoundSteps) {
  for (auto [lo, hi] : {std::pair{0.0, 1.0}, {-0.93, 0.41}, {3.2, 1234.0}, {1e-4, 3e-4}}) {
    const auto t = niceTicks(lo, hi);
    ASSERT_GE(t.size(), 3u) << lo << ".." << hi;
    EXPECT_LE(t.front(), lo);
    EXPECT_GE(t.back(), hi - 1e-12);
    const double step = t[1] - t[0];
    const double mantissa = step / std::pow(10.0, std::floor(std::log10(step)));
    EXPECT_TRUE(std::abs(mantissa - 1) < 1e-9 || std::abs(mantissa - 2) < 1e-9 ||
                std::abs(mantissa - 2.5) < 1e-9 || std::abs(mantissa - 5) < 1e-9)
        << mantissa;
  }
}

TEST(Plot, SvgHasOneMarkerPerPointAndEscapesText) {
  PlotSpec p{.title = "beta <vs> x", .x_label = "x", .y_label = "beta"};
  p.series.push_back({.label = "shots", .x = {0, 1, 2, 3}, .y = {-1, 0, 0.4, 0.44}});
  p.series.push_back({.label = "", .style = Series::Style::Line, .x = {0, 3}, .y = {-1, 0.44}});
  const std::string svg = renderSvg(p);
  EXPECT_EQ(count(svg, "<circle"), 4 + 1);  // 4 points + the legend marker
  EXPECT_NE(svg.find("beta &lt;vs&gt; x"), std::string::npos);
  EXPECT_EQ(svg.find("beta <vs>"), std::string::npos);
}

TEST(Plot, PointsOutsideAFixedRangeAreNotDrawn) {
  PlotSpec p{.x_min = 0.0, .x_max = 1.0, .y_min = 0.0, .y_max = 1.0};
  p.series.push_back({.x = {0.5, 5.0, -3.0}, .y = {0.5, 0.5, 0.5}});
  EXPECT_EQ(count(renderSvg(p), "<circle"), 1);
}

TEST(Plot, SavesSvgAndPngShowingThePoints) {
  const auto dir = std::filesystem::temp_directory_path() / "collide_plot_test";
  std::filesystem::create_directories(dir);
  PlotSpec p{.title = "t",
             .x_label = "x (m)",
             .y_label = "y (m)",
             .x_min = 0.0,
             .x_max = 1.0,
             .y_min = 0.0,
             .y_max = 1.0};
  p.series.push_back({.label = "a", .x = {0.5}, .y = {0.5}});
  ASSERT_TRUE(savePlot(p, (dir / "p").string(), 800, 560).ok());
  ASSERT_TRUE(std::filesystem::exists(dir / "p.svg"));
  const cv::Mat img = cv::imread((dir / "p.png").string());
  ASSERT_FALSE(img.empty());
  // The point (0.5, 0.5) sits in the middle of the plot area: left 80, right 780, top 40, bottom
  // 500.
  const cv::Vec3b px = img.at<cv::Vec3b>(270, 430);
  EXPECT_LT(px[0] + px[1] + px[2], 3 * 200) << "expected a coloured marker at the point";
  EXPECT_FALSE(savePlot(p, "/nonexistent-dir/p").ok());
}
