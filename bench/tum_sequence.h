// A TUM RGB-D sequence as the benchmark and the tests read it
// (../shared/data/tum_fr1_xyz: rgb.txt and depth.txt list "timestamp file"
// per line; depth PNGs are 16-bit, metres * 5000, 0 = no depth).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/io/burst.h"

namespace dfsm {

// The published calibration of the Freiburg 1 sequences (fr1/xyz among them),
// fitted to ha2016-d2u: bench/data/tum_freiburg1.yaml.
std::string TumFreiburg1CalibrationFile();

// The median over windows as the benchmark reports it and the tests bound
// it: with an even count, the mean of the two middle values (0 when empty).
double WindowMedian(std::vector<double> values);

class TumSequence {
 public:
  // Reads the two lists; empty() when either is missing or too short.
  explicit TumSequence(std::string dataset);

  bool empty() const { return rgb_.size() < 3 || depths_.empty(); }
  int frames() const { return static_cast<int>(rgb_.size()); }
  const std::string& dataset() const { return dataset_; }

  // Frames [first, first + frames) as a burst (640x480, gray and the
  // reference's colour), the reference in the middle. Throws
  // std::runtime_error naming a frame it cannot read.
  Burst Window(int first, int frames) const;

  // The Kinect depth in metres (0 = none) nearest in time to the reference of
  // that window.
  cv::Mat ReferenceDepth(int first, int frames) const;

 private:
  struct Stamped {
    double time;
    std::string file;
  };
  static std::vector<Stamped> ReadList(const std::string& path);

  std::string dataset_;
  std::vector<Stamped> rgb_, depths_;
};

}  // namespace dfsm
