#include "core/io/depth_tiff.h"

#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <vector>

#include "core/io/file_util.h"

namespace dfsm {

void WriteDepthTiff(const std::filesystem::path& path, const cv::Mat& depth, Flush flush) {
  if (depth.type() != CV_32FC1)
    throw std::runtime_error(path.string() + ": depth map must be CV_32FC1");
  std::vector<unsigned char> bytes;
  // Deflate keeps large maps small; OpenCV's TIFF writer stores float32 losslessly.
  const std::vector<int> params = {cv::IMWRITE_TIFF_COMPRESSION, 8 /* COMPRESSION_ADOBE_DEFLATE */};
  if (!cv::imencode(".tiff", depth, bytes, params))
    throw std::runtime_error(path.string() + ": cannot encode float32 TIFF");
  WriteFileAtomically(path, bytes, flush);
}

cv::Mat ReadDepthTiff(const std::filesystem::path& path) {
  const cv::Mat depth = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (depth.empty()) throw std::runtime_error(path.string() + ": missing or not a TIFF image");
  if (depth.type() != CV_32FC1)
    throw std::runtime_error(path.string() + ": expected single-channel float32, got type " +
                             std::to_string(depth.type()));
  return depth;
}

}  // namespace dfsm
