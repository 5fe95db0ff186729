// Preloaded (LD_PRELOAD) into every program scripts/check.sh runs under ThreadSanitizer: runs
// TBB's and OpenCV's parallel loops on the calling thread. Debian's libtbb and libopencv are not
// instrumented, so TSan does not see the synchronisation inside them and reports every result a
// worker wrote and the caller read after the loop as a race. With them serial, TSan checks ovo's
// own threads: the online pipeline's, the offline runner's two stages and image prefetcher, the
// RANSAC thread pool. Built without sanitizers (it must not pull in the TSan runtime ahead of
// the program's).
#include <tbb/global_control.h>

#include <memory>
#include <opencv2/core.hpp>

namespace {

struct SerialLibraries {
  std::unique_ptr<tbb::global_control> tbb_serial;
  SerialLibraries() {
    tbb_serial =
        std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, 1);
    cv::setNumThreads(0);  // 0: OpenCV's loops run sequentially on the caller
  }
};

const SerialLibraries serial_libraries;

}  // namespace
