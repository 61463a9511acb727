#include "bench/tum_sequence.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

namespace dfsm {

std::string TumFreiburg1CalibrationFile() {
  return std::string(DFSM_SOURCE_DIR) + "/bench/data/tum_freiburg1.yaml";
}

std::vector<Pose> PosesOfFrames(const std::vector<Pose>& poses, const std::vector<int>& kept) {
  std::vector<Pose> selected;
  if (!poses.empty())
    for (const int frame : kept) selected.push_back(poses[frame]);
  return selected;
}

double TranslationResidual(const std::vector<Pose>& estimated, const std::vector<Pose>& truth,
                           double* scale) {
  double dot = 0.0, estimated_sq = 0.0, true_sq = 0.0;
  for (size_t i = 0; i < truth.size(); ++i) {
    dot += estimated[i].T.dot(truth[i].T);
    estimated_sq += estimated[i].T.squaredNorm();
    true_sq += truth[i].T.squaredNorm();
  }
  const double best = estimated_sq > 0.0 ? dot / estimated_sq : 0.0;
  if (scale) *scale = best;
  double residual_sq = 0.0;
  for (size_t i = 0; i < truth.size(); ++i)
    residual_sq += (best * estimated[i].T - truth[i].T).squaredNorm();
  return true_sq > 0.0 ? std::sqrt(residual_sq / true_sq) : 0.0;
}

double WindowMedian(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n == 0 ? 0.0 : 0.5 * (values[(n - 1) / 2] + values[n / 2]);
}

TumSequence::TumSequence(std::string dataset, int downscale)
    : dataset_(std::move(dataset)),
      downscale_(downscale),
      rgb_(ReadList(dataset_ + "/rgb.txt")),
      depths_(ReadList(dataset_ + "/depth.txt")),
      trajectory_(ReadTrajectory(dataset_ + "/groundtruth.txt")) {
  if (downscale < 1 || downscale > kMaxDownscale || kWidth % downscale != 0 ||
      kHeight % downscale != 0)
    throw std::invalid_argument(
        "TUM downscale must divide " + std::to_string(kWidth) + " and " + std::to_string(kHeight) +
        " and be 1-" + std::to_string(kMaxDownscale) + ", got " + std::to_string(downscale));
}

std::vector<TumSequence::Stamped> TumSequence::ReadList(const std::string& path) {
  std::vector<Stamped> list;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    Stamped s;
    if (fields >> s.time >> s.file) list.push_back(s);
  }
  return list;
}

std::vector<TumSequence::StampedPose> TumSequence::ReadTrajectory(const std::string& path) {
  std::vector<StampedPose> trajectory;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    StampedPose p;
    double qx, qy, qz, qw;
    if (fields >> p.time >> p.centre.x() >> p.centre.y() >> p.centre.z() >> qx >> qy >> qz >> qw) {
      p.orientation = Eigen::Quaterniond(qw, qx, qy, qz).normalized();
      trajectory.push_back(p);
    }
  }
  return trajectory;
}

bool TumSequence::PoseAt(double time, Eigen::Vector3d* centre,
                         Eigen::Quaterniond* orientation) const {
  const auto after = std::lower_bound(trajectory_.begin(), trajectory_.end(), time,
                                      [](const StampedPose& p, double t) { return p.time < t; });
  if (after == trajectory_.begin() || after == trajectory_.end()) return false;
  const StampedPose& before = *(after - 1);
  const double w = (time - before.time) / (after->time - before.time);
  *centre = (1.0 - w) * before.centre + w * after->centre;
  *orientation = before.orientation.slerp(w, after->orientation);
  return true;
}

std::vector<Pose> TumSequence::TruePoses(int first, int frames) const {
  const int reference = first + frames / 2;
  Eigen::Vector3d c_ref;
  Eigen::Quaterniond q_ref;
  if (!PoseAt(rgb_.at(reference).time, &c_ref, &q_ref)) return {};
  std::vector<Pose> poses;
  for (int i = first; i < first + frames; ++i) {
    Eigen::Vector3d c;
    Eigen::Quaterniond q;
    if (!PoseAt(rgb_.at(i).time, &c, &q)) return {};
    // X_w = R_wi X_i + c_i for every frame, so X_i = R_wi^T (R_wr X_ref + c_r - c_i).
    Pose pose;
    pose.R = (q.conjugate() * q_ref).toRotationMatrix();
    pose.T = q.conjugate() * (c_ref - c);
    poses.push_back(pose);
  }
  return poses;
}

Burst TumSequence::Window(int first, int frames) const {
  Burst burst;
  burst.manifest.width = width();
  burst.manifest.height = height();
  burst.manifest.reference = frames / 2;  // the reference in the middle
  for (int i = 0; i < frames; ++i) {
    const std::string& file = rgb_.at(first + i).file;
    cv::Mat frame = cv::imread(dataset_ + "/" + file, cv::IMREAD_COLOR);
    if (frame.empty()) throw std::runtime_error("cannot read " + dataset_ + "/" + file);
    if (downscale_ > 1)
      cv::resize(frame, frame, cv::Size(width(), height()), 0.0, 0.0, cv::INTER_AREA);
    burst.gray.push_back(ToGray8(frame));
    if (i == frames / 2) burst.reference_color = frame;
    BurstFrameInfo info;
    info.file = file;
    burst.manifest.frames.push_back(info);
  }
  return burst;
}

cv::Mat TumSequence::ReferenceDepth(int first, int frames) const {
  const double time = rgb_.at(first + frames / 2).time;
  const auto nearest = std::min_element(depths_.begin(), depths_.end(), [&](auto& a, auto& b) {
    return std::abs(a.time - time) < std::abs(b.time - time);
  });
  const cv::Mat raw = cv::imread(dataset_ + "/" + nearest->file, cv::IMREAD_UNCHANGED);
  if (raw.empty()) throw std::runtime_error("cannot read " + dataset_ + "/" + nearest->file);
  cv::Mat metres;
  raw.convertTo(metres, CV_32F, 1.0 / 5000.0);
  if (downscale_ == 1) return metres;
  cv::Mat reduced(height(), width(), CV_32FC1, cv::Scalar(0.0f));
  const int n = downscale_;
  for (int y = 0; y < reduced.rows; ++y)
    for (int x = 0; x < reduced.cols; ++x) {
      float lowest = 0.0f, highest = 0.0f, sum = 0.0f;
      bool whole = true;
      for (int dy = 0; dy < n && whole; ++dy)
        for (int dx = 0; dx < n && whole; ++dx) {
          const float d = metres.at<float>(n * y + dy, n * x + dx);
          whole = d > 0.0f;
          lowest = dy + dx == 0 ? d : std::min(lowest, d);
          highest = std::max(highest, d);
          sum += d;
        }
      if (whole && highest <= (1.0f + kMaxBlockDepthSpread) * lowest)
        reduced.at<float>(y, x) = sum / (n * n);
    }
  return reduced;
}

CameraModel TumSequence::Scaled(CameraModel camera) const {
  if (camera.width != kWidth || camera.height != kHeight)
    throw std::invalid_argument("TUM calibration must be for " + std::to_string(kWidth) + "x" +
                                std::to_string(kHeight) + " frames, got " +
                                std::to_string(camera.width) + "x" + std::to_string(camera.height));
  camera.width = width();
  camera.height = height();
  camera.f /= downscale_;
  camera.cx = ReducedPixel(camera.cx, downscale_);  // exactly cx at downscale 1
  camera.cy = ReducedPixel(camera.cy, downscale_);
  return camera;
}

ImportedCalibration TumSequence::ReadCalibration(const std::string& file) const {
  ImportedCalibration imported = ReadCalibrationFile(file, kWidth, kHeight);
  imported.camera = Scaled(imported.camera);
  if (imported.lens) {
    OpenCvLens& lens = *imported.lens;
    lens.fx /= downscale_;
    lens.fy /= downscale_;
    lens.cx = ReducedPixel(lens.cx, downscale_);
    lens.cy = ReducedPixel(lens.cy, downscale_);
  }
  return imported;
}

}  // namespace dfsm
