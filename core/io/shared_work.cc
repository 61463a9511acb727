#include "core/io/shared_work.h"

#include <algorithm>
#include <opencv2/core.hpp>
#include <utility>

namespace dfsm {

SharedWork::SharedWork(std::vector<std::function<void()>> pieces)
    : pieces_(std::move(pieces)), errors_(pieces_.size()) {}

void SharedWork::Help() {
  for (int i = next_.fetch_add(1); i < size(); i = next_.fetch_add(1)) {
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

void SharedWork::Rethrow() const {
  for (const std::exception_ptr& error : errors_)
    if (error) std::rethrow_exception(error);
}

}  // namespace dfsm
