#include "daemon/service/retention.h"

#include <algorithm>

namespace dfsm::service {

std::vector<std::string> SelectExpiredJobs(const std::vector<Job>& jobs,
                                           const RetentionSection& limits, int64_t now_ms) {
  std::vector<const Job*> finished;
  for (const Job& job : jobs) {
    if (IsFinished(job.status)) finished.push_back(&job);
  }
  // Newest first: ids sort by creation time.
  std::sort(finished.begin(), finished.end(), [](const Job* a, const Job* b) {
    return a->created_ms != b->created_ms ? a->created_ms > b->created_ms : a->id > b->id;
  });
  // Results first: failed jobs (a bad upload fails cheaply, in its job) are
  // kept only when every result fits, in the room left, so they never push a
  // result out.
  std::stable_partition(finished.begin(), finished.end(),
                        [](const Job* job) { return job->status == JobStatus::kSucceeded; });
  std::vector<std::string> expired;
  int kept = 0;
  int64_t kept_bytes = 0;
  bool keeping = true;  // once one job is over a limit, every older one is too
  for (const Job* job : finished) {
    const int64_t finished_ms = job->finished_ms ? job->finished_ms : job->created_ms;
    const bool too_old = limits.max_age_s > 0 && now_ms - finished_ms > limits.max_age_s * 1000;
    const bool too_many = limits.max_jobs > 0 && kept + 1 > limits.max_jobs;
    const bool too_big = limits.max_bytes > 0 && kept_bytes + job->bytes > limits.max_bytes;
    keeping = keeping && !too_old && !too_many && !too_big;
    if (!keeping) {
      expired.push_back(job->id);
    } else {
      ++kept;
      kept_bytes += job->bytes;
    }
  }
  // Oldest first.
  std::sort(expired.begin(), expired.end());
  return expired;
}

}  // namespace dfsm::service
