#include "core/parallel/shared_work.h"

#include <algorithm>
#include <opencv2/core.hpp>
#include <utility>

namespace dfsm {

SharedWork::SharedWork(std::vector<std::function<void()>> pieces)
    : pieces_(std::move(pieces)), errors_(pieces_.size()) {}

void SharedWork::Help(const std::function<bool()>& go_on) {
  while (!go_on || go_on()) {
    const int i = next_.fetch_add(1);
    if (i >= size()) return;
    try {
      pieces_[i]();
    } catch (...) {
      errors_[i] = std::current_exception();
    }
  }
}

void SharedWork::Finish() {
  if (next_.load() >= size()) return;
  // One helper per thread: each takes pieces until none is left.
  cv::parallel_for_(cv::Range(0, std::max(1, cv::getNumThreads())), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) Help();
  });
}

std::exception_ptr SharedWork::FirstError() const {
  for (const std::exception_ptr& error : errors_)
    if (error) return error;
  return nullptr;
}

}  // namespace dfsm
