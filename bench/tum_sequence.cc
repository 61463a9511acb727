#include "bench/tum_sequence.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <stdexcept>

namespace dfsm {

std::string TumFreiburg1CalibrationFile() {
  return std::string(DFSM_SOURCE_DIR) + "/bench/data/tum_freiburg1.yaml";
}

double WindowMedian(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n == 0 ? 0.0 : 0.5 * (values[(n - 1) / 2] + values[n / 2]);
}

TumSequence::TumSequence(std::string dataset)
    : dataset_(std::move(dataset)),
      rgb_(ReadList(dataset_ + "/rgb.txt")),
      depths_(ReadList(dataset_ + "/depth.txt")) {}

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

Burst TumSequence::Window(int first, int frames) const {
  Burst burst;
  burst.manifest.width = 640;
  burst.manifest.height = 480;
  burst.manifest.reference = frames / 2;  // the reference in the middle
  for (int i = 0; i < frames; ++i) {
    const std::string& file = rgb_.at(first + i).file;
    const cv::Mat frame = cv::imread(dataset_ + "/" + file, cv::IMREAD_COLOR);
    if (frame.empty()) throw std::runtime_error("cannot read " + dataset_ + "/" + file);
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
  return metres;
}

}  // namespace dfsm
