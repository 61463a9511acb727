#include "bench/tum_pictures.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace dfsm {
namespace {

// Inverse depth of `depth` (metres, 0 = none) in the turbo map over
// [1/far, 1/near], black where there is none.
cv::Mat Colour(const cv::Mat& depth, double near, double far) {
  const cv::Mat valid = depth > 0.0f;
  cv::Mat inverse(depth.size(), CV_32FC1, cv::Scalar(0.0f));
  cv::divide(1.0, depth, inverse);
  const double low = 1.0 / far, high = 1.0 / near;
  cv::Mat normalized;
  inverse.convertTo(normalized, CV_8UC1, 255.0 / (high - low), -255.0 * low / (high - low));
  cv::Mat coloured;
  cv::applyColorMap(normalized, coloured, cv::COLORMAP_TURBO);
  coloured.setTo(cv::Scalar::all(0), ~valid);
  return coloured;
}

void Title(cv::Mat& panel, const std::string& text) {
  cv::putText(panel, text, cv::Point(6, 18), cv::FONT_HERSHEY_SIMPLEX, 0.42, cv::Scalar::all(0), 3,
              cv::LINE_AA);
  cv::putText(panel, text, cv::Point(6, 18), cv::FONT_HERSHEY_SIMPLEX, 0.42, cv::Scalar::all(255),
              1, cv::LINE_AA);
}

}  // namespace

cv::Mat TumComparisonRow(const cv::Mat& reference_color, const cv::Mat& depth, double scale,
                         const cv::Mat& truth, const std::string& title, const std::string& score,
                         const std::string& baseline) {
  std::vector<float> known;
  for (int v = 0; v < truth.rows; ++v)
    for (int u = 0; u < truth.cols; ++u)
      if (truth.at<float>(v, u) > 0.0f) known.push_back(truth.at<float>(v, u));
  double near = 0.5, far = 5.0;
  if (known.size() > 100) {
    std::sort(known.begin(), known.end());
    near = known[known.size() * 2 / 100];
    far = std::max<double>(known[known.size() * 98 / 100], near * 1.01);
  }
  cv::Mat scaled =
      depth.empty() ? cv::Mat(truth.size(), CV_32FC1, cv::Scalar(0.0f)) : cv::Mat(depth * scale);
  cv::Mat error(truth.size(), CV_8UC1, cv::Scalar(0));
  for (int v = 0; v < truth.rows; ++v)
    for (int u = 0; u < truth.cols; ++u) {
      const float d = scaled.at<float>(v, u), t = truth.at<float>(v, u);
      if (d > 0.0f && t > 0.0f) {
        const double relative = std::abs(d - t) / t;
        error.at<uchar>(v, u) =
            cv::saturate_cast<uchar>(255.0 * std::clamp((relative - 0.01) / 0.24, 0.0, 1.0));
      }
    }
  cv::Mat error_colour;
  cv::applyColorMap(error, error_colour, cv::COLORMAP_INFERNO);
  error_colour.setTo(cv::Scalar::all(0), (scaled <= 0.0f) | (truth <= 0.0f));

  cv::Mat reference = reference_color.clone();
  if (reference.channels() == 1) cv::cvtColor(reference, reference, cv::COLOR_GRAY2BGR);
  std::vector<cv::Mat> panels = {reference, Colour(scaled, near, far), Colour(truth, near, far),
                                 error_colour};
  const std::vector<std::string> titles = {title, "dfsm: " + score, "Kinect; " + baseline,
                                           "|error| / depth: 1 % (black) .. 25 %"};
  for (size_t i = 0; i < panels.size(); ++i) {
    cv::resize(panels[i], panels[i], panels[i].size() / 2, 0, 0, cv::INTER_AREA);
    Title(panels[i], titles[i]);
  }
  cv::Mat row;
  cv::hconcat(panels, row);
  return row;
}

}  // namespace dfsm
