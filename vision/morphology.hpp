#pragma once
// Grey-level closing (dilation, then erosion) with a square, for the dot
// detector's bare-sphere level. The same result as OpenCV's
// cv::morphologyEx(MORPH_CLOSE) with a square kernel and BORDER_REPLICATE |
// BORDER_ISOLATED, pixel for pixel, at a cost that does not grow with the
// square: down the columns, van Herk / Gil-Werman running extremes over
// blocks of the window's length, a whole row at a time; along the rows,
// windows of doubling length. Both vectorise.
#include <opencv2/core.hpp>

namespace collide::vision {

/// The closing of `src` (CV_8UC1 or CV_16UC1; a view into a larger image is
/// treated as if it were the whole image) with a square of side 2 half + 1
/// centred on each pixel, edges replicated. `dst` takes src's type and size.
void closeWithSquare(const cv::Mat& src, int half, cv::Mat& dst);

}  // namespace collide::vision
