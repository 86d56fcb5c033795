// closeWithSquare against OpenCV's closing (an implementation written
// elsewhere): the same pixels, for both sample types, squares wider and
// narrower than the image, and a view into a larger image.
#include "vision/morphology.hpp"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

using collide::vision::closeWithSquare;

namespace {

cv::Mat openCvClose(const cv::Mat& src, int half) {
  const cv::Mat square =
      cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * half + 1, 2 * half + 1));
  cv::Mat out;
  cv::morphologyEx(src, out, cv::MORPH_CLOSE, square, cv::Point(-1, -1), 1,
                   cv::BORDER_REPLICATE | cv::BORDER_ISOLATED);
  return out;
}

void expectSame(const cv::Mat& a, const cv::Mat& b, const std::string& what) {
  ASSERT_EQ(a.type(), b.type()) << what;
  ASSERT_EQ(a.size(), b.size()) << what;
  EXPECT_EQ(cv::countNonZero(a != b), 0) << what;
}

}  // namespace

TEST(CloseWithSquare, MatchesOpenCvOnRandomImages) {
  cv::RNG rng(7);
  for (int type : {CV_8UC1, CV_16UC1})
    for (const cv::Size size :
         {cv::Size(125, 119), cv::Size(40, 3), cv::Size(1, 1), cv::Size(7, 30)})
      for (int half : {0, 1, 2, 10, 25}) {
        cv::Mat img(size, type);
        rng.fill(img, cv::RNG::UNIFORM, 0, type == CV_8UC1 ? 256 : 4096);
        cv::Mat mine;
        closeWithSquare(img, half, mine);
        expectSame(mine, openCvClose(img, half),
                   "type " + std::to_string(type) + ", " + std::to_string(size.width) + " x " +
                       std::to_string(size.height) + ", half " + std::to_string(half));
      }
}

TEST(CloseWithSquare, FillsADarkDotAndKeepsABrightRamp) {
  // A ramp 0..245 across 50 columns with a dark 5 x 5 dot: the closing with
  // a 7 x 7 square fills the dot from its surroundings and leaves the ramp
  // (but for the 3 columns at the dark end, where the replicated edge
  // lifts it).
  cv::Mat img(40, 50, CV_8UC1);
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x)
      img.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(5 * x);
  cv::Mat ramp = img.clone();
  img(cv::Rect(20, 15, 5, 5)).setTo(0);
  cv::Mat closed;
  closeWithSquare(img, 3, closed);
  const cv::Rect inner(3, 0, img.cols - 3, img.rows);
  expectSame(closed(inner), ramp(inner), "ramp");
  expectSame(closed, openCvClose(img, 3), "ramp against OpenCV");
}

TEST(CloseWithSquare, AViewIsClosedOnItsOwn) {
  // The pixels around a view do not leak in (BORDER_ISOLATED's meaning).
  cv::Mat big(60, 60, CV_16UC1, cv::Scalar(4000));
  cv::Mat view = big(cv::Rect(10, 10, 30, 30));
  view.setTo(100);
  cv::Mat closed;
  closeWithSquare(view, 5, closed);
  EXPECT_EQ(cv::countNonZero(closed != 100), 0);
  expectSame(closed, openCvClose(view, 5), "view");
}

TEST(CloseWithSquare, RefusesOtherSampleTypes) {
  cv::Mat f(4, 4, CV_32FC1, cv::Scalar(1.0f)), out;
  EXPECT_THROW(closeWithSquare(f, 1, out), std::invalid_argument);
}
