#include "daemon/capture/mjpeg_decoder.h"

#include <turbojpeg.h>

#include <stdexcept>
#include <string>

namespace dfsm::capture {

MjpegDecoder::MjpegDecoder() : handle_(tjInitDecompress()) {
  if (handle_ == nullptr)
    throw std::runtime_error(std::string("TurboJPEG: cannot create a decoder: ") +
                             tjGetErrorStr2(nullptr));
}

MjpegDecoder::~MjpegDecoder() { tjDestroy(static_cast<tjhandle>(handle_)); }

void MjpegDecoder::Decode(const uint8_t* data, size_t size, int width, int height, int pixel_format,
                          cv::Mat& out) {
  auto* handle = static_cast<tjhandle>(handle_);
  int jpeg_width = 0, jpeg_height = 0, subsampling = 0, colorspace = 0;
  if (tjDecompressHeader3(handle, data, static_cast<unsigned long>(size), &jpeg_width, &jpeg_height,
                          &subsampling, &colorspace) != 0)
    throw std::runtime_error(std::string("MJPEG frame without a valid header: ") +
                             tjGetErrorStr2(handle));
  if (jpeg_width != width || jpeg_height != height)
    throw std::runtime_error("MJPEG frame is " + std::to_string(jpeg_width) + "x" +
                             std::to_string(jpeg_height) + ", the stream was negotiated at " +
                             std::to_string(width) + "x" + std::to_string(height));
  out.create(height, width, pixel_format == TJPF_GRAY ? CV_8UC1 : CV_8UC3);
  // Corrupt entropy data is a warning to libjpeg-turbo (it fills the rest of
  // the frame grey); a burst must not contain such a frame, so it is an error.
  if (tjDecompress2(handle, data, static_cast<unsigned long>(size), out.data, width,
                    static_cast<int>(out.step), height, pixel_format, TJFLAG_FASTDCT) != 0)
    throw std::runtime_error(std::string("MJPEG frame does not decode: ") + tjGetErrorStr2(handle));
}

void MjpegDecoder::DecodeGray(const uint8_t* data, size_t size, int width, int height,
                              cv::Mat& gray) {
  Decode(data, size, width, height, TJPF_GRAY, gray);
}

void MjpegDecoder::DecodeBgr(const uint8_t* data, size_t size, int width, int height,
                             cv::Mat& bgr) {
  Decode(data, size, width, height, TJPF_BGR, bgr);
}

}  // namespace dfsm::capture
