// PNG decoding through libpng, with cv::imdecode's IMREAD_UNCHANGED conventions,
// so that OpenCV's image codecs (and the ~140 shared libraries they load: GDAL,
// poppler, HDF5, ...) stay out of dfsm and dfsmd.
#pragma once

#include <opencv2/core.hpp>
#include <stdexcept>
#include <string_view>

namespace dfsm {

// Gray PNGs decode to CV_8UC1, colour to CV_8UC3 BGR, anything with alpha or a
// transparency chunk to CV_8UC4 BGRA (gray replicated); 16-bit samples stay
// 16-bit (in the host's byte order), fewer than 8 bits become 8, palettes
// become BGR(A). Throws std::runtime_error with libpng's message for a damaged
// or truncated file. Decodes whatever size the header declares: bound it first
// (image_decode.h's DecodeImage does).
cv::Mat DecodePngPixels(std::string_view bytes);

}  // namespace dfsm
