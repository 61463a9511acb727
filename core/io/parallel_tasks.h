// Runs a handful of independent tasks (writing the files of one result, say)
// on OpenCV's thread pool, so they spread over the cores the way the pipeline's
// own loops do, on x86-64 and arm64 alike.
#pragma once

#include <exception>
#include <functional>
#include <opencv2/core.hpp>
#include <vector>

namespace dfsm {

// Returns when every task has run; rethrows the exception of the first task
// (in order) that threw, after all of them have finished.
inline void RunInParallel(const std::vector<std::function<void()>>& tasks) {
  // One task runs here: a parallel region would hold OpenCV's process-wide
  // nesting flag for its whole length and turn every other thread's
  // parallel_for_ serial meanwhile.
  if (tasks.size() == 1) return tasks.front()();
  std::vector<std::exception_ptr> errors(tasks.size());
  cv::parallel_for_(cv::Range(0, static_cast<int>(tasks.size())), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) {
      try {
        tasks[i]();
      } catch (...) {
        errors[i] = std::current_exception();
      }
    }
  });
  for (const std::exception_ptr& error : errors) {
    if (error) std::rethrow_exception(error);
  }
}

}  // namespace dfsm
