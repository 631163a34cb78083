// OpenCV's own worker threads off while mcvo runs (issue 58).
//
// mcvo parallelises over cameras, camera pairs and images itself
// (util/parallel.h, runtime.threads). OpenCV's functions (remap, pyramids,
// LK, corner responses, ORB) would otherwise start their own parallel_for_
// over the machine's cores inside each of those workers: on 2 cores,
// `--threads 2` then ran 2 x 2 busy threads and paid more CPU per frame
// than `--threads 1`, and `--threads 1` was not one thread. Inside a
// ScopedSerialOpenCv, OpenCV runs every function on the calling thread
// (cv::setNumThreads(0)); the results are the same, only the threads
// differ.
//
// Nested and concurrent scopes (two runs in one process, e.g. from Python
// threads) share one count: the first scope saves OpenCV's setting, the
// last one to close restores it.
#ifndef MCVO_FRONTEND_OPENCV_THREADS_H_
#define MCVO_FRONTEND_OPENCV_THREADS_H_

namespace mcvo {

class ScopedSerialOpenCv {
 public:
  ScopedSerialOpenCv();
  ~ScopedSerialOpenCv();
  ScopedSerialOpenCv(const ScopedSerialOpenCv&) = delete;
  ScopedSerialOpenCv& operator=(const ScopedSerialOpenCv&) = delete;
};

}  // namespace mcvo

#endif  // MCVO_FRONTEND_OPENCV_THREADS_H_
