// Linked into every target of a ThreadSanitizer build (CMakeLists.txt,
// COLLIDE_SANITIZE=thread): OpenCV runs its own parallel loops (resize,
// remap, filters) on the calling thread instead of on TBB's worker threads.
//
// Why: OpenCV and TBB are not instrumented, so TSan cannot see how a TBB
// worker hands its results back; it then reports OpenCV's own buffers (one a
// worker allocates and the caller frees after the loop) as races between the
// worker and our thread (seen 2026-11-25 in hw/camera_sim_test: "operator new
// in libopencv_imgproc by thread T2, created by libtbb.so.12" against
// "operator delete in libopencv_imgproc by the main thread"). Running those
// loops serially removes the invisible threads instead of suppressing reports:
// every thread left is one of ours, and a race of ours that touches an OpenCV
// call is still reported. Not checked this way: OpenCV's own parallel loops
// (third party). Our code never starts a TBB or cv::parallel_for_ loop itself.
#include <opencv2/core/utility.hpp>

namespace {

const bool opencv_runs_serially = [] {
  cv::setNumThreads(0);  // 0: every OpenCV function runs on the calling thread
  return true;
}();

}  // namespace
