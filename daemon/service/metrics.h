// The daemon's counters and histograms, rendered in the Prometheus text format
// (version 0.0.4). Capture counters are not copied here: they are read from
// the capture service when /metrics is rendered, so there is one source of truth.
// Thread-safe.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>

namespace dfsm::service {

class Histogram {
 public:
  // Upper bounds in seconds: from a fast stage on a small burst (10 ms) to a
  // dense sweep at full resolution (minutes).
  static constexpr std::array<double, 12> kBounds = {0.01, 0.025, 0.05, 0.1, 0.25, 0.5,
                                                     1.0,  2.5,   5.0,  10,  30,   120};
  void Observe(double seconds);
  // Appends the _bucket, _sum and _count lines of `name{labels}`.
  void Render(const std::string& name, const std::string& labels, std::string* out) const;

 private:
  std::array<uint64_t, kBounds.size()> buckets_{};  // non-cumulative
  uint64_t count_ = 0;
  double sum_ = 0.0;
};

struct GaugeSnapshot {
  // Capture (from CaptureService::Status).
  uint64_t frames_captured = 0, frames_dropped = 0, reconnects = 0;
  bool streaming = false;
  int ring_fill = 0;
  // Scheduler.
  int queue_depth = 0, queue_capacity = 0, jobs_processing = 0;
};

class Metrics {
 public:
  void JobFinished(bool succeeded);
  void JobRejected();  // queue full
  void StageDuration(const std::string& stage, double seconds);
  void JobDuration(double queued_seconds, double total_seconds);
  void HttpRequest(int status);

  std::string Render(const GaugeSnapshot& gauges) const;

 private:
  mutable std::mutex mutex_;
  uint64_t succeeded_ = 0, failed_ = 0, rejected_ = 0;
  std::map<std::string, Histogram> stages_;
  Histogram queue_wait_, job_total_;
  std::map<int, uint64_t> http_by_status_;
};

}  // namespace dfsm::service
