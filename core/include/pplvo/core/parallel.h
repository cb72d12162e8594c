#pragma once
/// Runs independent tasks on OpenCV's thread pool, or in order on the calling thread.

#include <algorithm>
#include <opencv2/core/utility.hpp>

namespace pplvo {

/// Calls task(i) for i = 0..n-1: in order on this thread when threads <= 1, else on up to
/// `threads` threads of OpenCV's pool (parallel_for_). Tasks must write disjoint data; callers
/// that need results independent of `threads` split their work into a fixed n.
template <class Task>
void forEachTask(int n, int threads, const Task& task) {
  if (threads <= 1 || n <= 1) {
    for (int i = 0; i < n; ++i) task(i);
    return;
  }
  cv::parallel_for_(
      cv::Range(0, n),
      [&](const cv::Range& r) {
        for (int i = r.start; i < r.end; ++i) task(i);
      },
      std::min(threads, n));
}

}  // namespace pplvo
