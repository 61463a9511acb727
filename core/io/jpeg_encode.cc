#include "core/io/jpeg_encode.h"

#include <turbojpeg.h>

#include <memory>
#include <stdexcept>
#include <string>

namespace dfsm {

std::vector<unsigned char> EncodeJpeg(const cv::Mat& image, int quality) {
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3))
    throw std::runtime_error("cannot encode JPEG: expected an 8-bit gray or BGR image");
  if (quality < 1 || quality > 100)
    throw std::runtime_error("cannot encode JPEG: quality " + std::to_string(quality) +
                             " is outside 1..100");
  const std::unique_ptr<void, int (*)(tjhandle)> handle(tjInitCompress(), tjDestroy);
  if (!handle)
    throw std::runtime_error("cannot encode JPEG: " + std::string(tjGetErrorStr2(nullptr)));
  const bool gray = image.channels() == 1;
  unsigned char* jpeg = nullptr;
  unsigned long size = 0;
  const int status = tjCompress2(handle.get(), image.data, image.cols, static_cast<int>(image.step),
                                 image.rows, gray ? TJPF_GRAY : TJPF_BGR, &jpeg, &size,
                                 gray ? TJSAMP_GRAY : TJSAMP_420, quality,
                                 // libjpeg's (and cv::imencode's) accurate DCT:
                                 // TurboJPEG's own default is the fast one.
                                 TJFLAG_ACCURATEDCT);
  const std::unique_ptr<unsigned char, void (*)(unsigned char*)> owned(jpeg, tjFree);
  if (status != 0)
    throw std::runtime_error("cannot encode JPEG: " + std::string(tjGetErrorStr2(handle.get())));
  return std::vector<unsigned char>(jpeg, jpeg + size);
}

}  // namespace dfsm
