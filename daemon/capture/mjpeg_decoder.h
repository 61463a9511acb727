// Decodes Motion-JPEG frames with TurboJPEG. Webcams often leave out the
// Huffman tables (DHT) of every frame; libjpeg-turbo then uses the standard
// tables of JPEG Annex K, which is what such cameras encode with.
#pragma once

#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>

namespace dfsm::capture {

class MjpegDecoder {
 public:
  MjpegDecoder();
  ~MjpegDecoder();
  MjpegDecoder(const MjpegDecoder&) = delete;
  MjpegDecoder& operator=(const MjpegDecoder&) = delete;

  // Decodes straight to 8-bit gray (chroma is never reconstructed, which is
  // what makes this cheap). `gray` is reused when it has the right size.
  // Throws std::runtime_error on a corrupt frame or one of another size.
  void DecodeGray(const uint8_t* data, size_t size, int width, int height, cv::Mat& gray);
  // Decodes to BGR8.
  void DecodeBgr(const uint8_t* data, size_t size, int width, int height, cv::Mat& bgr);

 private:
  void Decode(const uint8_t* data, size_t size, int width, int height, int pixel_format,
              cv::Mat& out);
  void* handle_;  // tjhandle
};

}  // namespace dfsm::capture
