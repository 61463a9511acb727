// Independent pieces of work that the threads of a parallel region share out
// as each comes free. A region whose own tasks end at different times (the
// sparse stage's first focal start and its probe) leaves a core idle; pieces
// handed to it in a SharedWork fill that core, and once both tasks are done
// both threads take pieces, so the region ends with the last piece instead of
// one thread working through all of them.
//
// Why not more tasks in the region: with OpenCV on TBB, a region's range is
// split in halves and a free thread steals the oldest half, so a task listed
// after the region's own could start before one of them (the probe).
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <functional>
#include <vector>

namespace dfsm {

class SharedWork {
 public:
  explicit SharedWork(std::vector<std::function<void()>> pieces);

  // Runs pieces not yet taken, one at a time, until none is left, or, with
  // `go_on`, until it returns false (asked before each piece). Safe to call
  // from any number of threads at once; each piece runs exactly once. A piece
  // that throws is recorded (FirstError), not propagated here: the caller's
  // own work is not the pieces'.
  void Help(const std::function<bool()>& go_on = {});
  // Runs every piece not yet taken on OpenCV's pool (each thread helps), and
  // returns when all of them, wherever they ran, are done. Not from inside a
  // parallel region (it would run them serially) nor beside Help() calls.
  void Finish();
  // The exception of the first piece, in order, that threw; null if none did.
  std::exception_ptr FirstError() const;

  int size() const { return static_cast<int>(pieces_.size()); }
  // Pieces taken so far (the first ones, in order: pieces are taken in order).
  int taken() const { return std::min(next_.load(), size()); }

 private:
  std::vector<std::function<void()>> pieces_;
  std::vector<std::exception_ptr> errors_;
  std::atomic<int> next_{0};
};

}  // namespace dfsm
