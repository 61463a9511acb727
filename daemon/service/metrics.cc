#include "daemon/service/metrics.h"

#include <sstream>

namespace dfsm::service {
namespace {

std::string Number(double value) {
  std::ostringstream out;
  out.precision(9);
  out << value;
  return out.str();
}

void Header(const std::string& name, const std::string& type, const std::string& help,
            std::string* out) {
  *out += "# HELP " + name + " " + help + "\n# TYPE " + name + " " + type + "\n";
}

void Sample(const std::string& name, const std::string& labels, double value, std::string* out) {
  *out += name + (labels.empty() ? "" : "{" + labels + "}") + " " + Number(value) + "\n";
}

}  // namespace

void Histogram::Observe(double seconds) {
  for (size_t i = 0; i < kBounds.size(); ++i) {
    if (seconds <= kBounds[i]) {
      ++buckets_[i];
      break;
    }
  }
  ++count_;
  sum_ += seconds;
}

void Histogram::Render(const std::string& name, const std::string& labels, std::string* out) const {
  const std::string prefix = labels.empty() ? "" : labels + ",";
  uint64_t cumulative = 0;
  for (size_t i = 0; i < kBounds.size(); ++i) {
    cumulative += buckets_[i];
    Sample(name + "_bucket", prefix + "le=\"" + Number(kBounds[i]) + "\"",
           static_cast<double>(cumulative), out);
  }
  Sample(name + "_bucket", prefix + "le=\"+Inf\"", static_cast<double>(count_), out);
  Sample(name + "_sum", labels, sum_, out);
  Sample(name + "_count", labels, static_cast<double>(count_), out);
}

void Metrics::JobFinished(bool succeeded) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++(succeeded ? succeeded_ : failed_);
}

void Metrics::JobRejected() {
  std::lock_guard<std::mutex> lock(mutex_);
  ++rejected_;
}

void Metrics::StageDuration(const std::string& stage, double seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  stages_[stage].Observe(seconds);
}

void Metrics::JobDuration(double queued_seconds, double total_seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  queue_wait_.Observe(queued_seconds);
  job_total_.Observe(total_seconds);
}

void Metrics::HttpRequest(int status) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++http_by_status_[status];
}

std::string Metrics::Render(const GaugeSnapshot& g) const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string out;
  Header("dfsmd_frames_captured_total", "counter", "Frames delivered by the capture source.", &out);
  Sample("dfsmd_frames_captured_total", "", static_cast<double>(g.frames_captured), &out);
  Header("dfsmd_frames_dropped_total", "counter",
         "Frames lost: sequence gaps and buffers flagged with errors.", &out);
  Sample("dfsmd_frames_dropped_total", "", static_cast<double>(g.frames_dropped), &out);
  Header("dfsmd_capture_reconnects_total", "counter", "Times the capture device was reopened.",
         &out);
  Sample("dfsmd_capture_reconnects_total", "", static_cast<double>(g.reconnects), &out);
  Header("dfsmd_capture_streaming", "gauge", "1 while frames arrive.", &out);
  Sample("dfsmd_capture_streaming", "", g.streaming ? 1 : 0, &out);
  Header("dfsmd_ring_fill_frames", "gauge", "Frames held in the capture ring.", &out);
  Sample("dfsmd_ring_fill_frames", "", g.ring_fill, &out);

  Header("dfsmd_jobs_total", "counter", "Finished pipeline jobs by outcome.", &out);
  Sample("dfsmd_jobs_total", "outcome=\"succeeded\"", static_cast<double>(succeeded_), &out);
  Sample("dfsmd_jobs_total", "outcome=\"failed\"", static_cast<double>(failed_), &out);
  Header("dfsmd_jobs_rejected_total", "counter", "Requests refused because the queue was full.",
         &out);
  Sample("dfsmd_jobs_rejected_total", "", static_cast<double>(rejected_), &out);
  Header("dfsmd_queue_depth", "gauge", "Jobs waiting for a worker.", &out);
  Sample("dfsmd_queue_depth", "", g.queue_depth, &out);
  Header("dfsmd_queue_capacity", "gauge", "Jobs that may wait at most.", &out);
  Sample("dfsmd_queue_capacity", "", g.queue_capacity, &out);
  Header("dfsmd_jobs_processing", "gauge", "Jobs being processed.", &out);
  Sample("dfsmd_jobs_processing", "", g.jobs_processing, &out);

  Header("dfsmd_stage_duration_seconds", "histogram", "Pipeline stage durations.", &out);
  for (const auto& [stage, histogram] : stages_) {
    histogram.Render("dfsmd_stage_duration_seconds", "stage=\"" + stage + "\"", &out);
  }
  Header("dfsmd_job_queue_wait_seconds", "histogram", "Time from request to processing start.",
         &out);
  queue_wait_.Render("dfsmd_job_queue_wait_seconds", "", &out);
  Header("dfsmd_job_duration_seconds", "histogram", "Time from request to finished result.", &out);
  job_total_.Render("dfsmd_job_duration_seconds", "", &out);
  Header("dfsmd_http_responses_total", "counter", "HTTP responses by status code.", &out);
  for (const auto& [status, count] : http_by_status_) {
    Sample("dfsmd_http_responses_total", "code=\"" + std::to_string(status) + "\"",
           static_cast<double>(count), &out);
  }
  return out;
}

}  // namespace dfsm::service
