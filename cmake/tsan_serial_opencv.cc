// Compiled into every target of a ThreadSanitizer build (DFSM_SANITIZE=thread,
// see CMakeLists.txt): makes cv::parallel_for_ run its body on the calling
// thread. OpenCV's pool is TBB, which is not built with TSan: TSan cannot see
// the synchronisation between a parallel_for_ and its workers, so every stripe
// a worker runs shows up as a race with the caller (51 such reports in
// capture_unit_test alone, all with libtbb frames), and OPENCV_FOR_THREADS_NUM
// has no effect on the TBB backend. The TSan stage checks our own threads
// (capture, scheduler, HTTP, watchdog); the data parallelism inside the
// pipeline is covered by the ASan stage and the release tests.
#include <opencv2/core/utility.hpp>

namespace {

struct SerialOpenCv {
  SerialOpenCv() { cv::setNumThreads(0); }
} serial_opencv;

}  // namespace
