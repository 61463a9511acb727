#include "core/io/png_encode.h"

#include <png.h>
#include <zlib.h>

#include <stdexcept>
#include <string>

#include "core/io/libpng_callbacks.h"

namespace dfsm {
namespace {

void AppendBytes(png_structp png, png_bytep data, png_size_t size) {
  auto* out = static_cast<std::vector<unsigned char>*>(png_get_io_ptr(png));
  out->insert(out->end(), data, data + size);
}

void NoFlush(png_structp) {}

struct PngSettings {
  int level;     // zlib level
  int strategy;  // zlib strategy
  int filter;    // PNG_FILTER_* (one filter for every row: no per-row search)
};

// Writes `image` into `out`; false with `error` set when libpng fails. The
// only locals touched after setjmp are the pointers it restores.
bool Write(const cv::Mat& image, const PngSettings& settings, std::vector<unsigned char>* out,
           std::string* error) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, error, libpng::KeepErrorMessage,
                                            libpng::IgnoreWarning);
  if (!png) {
    *error = "out of memory";
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (!info || setjmp(png_jmpbuf(png))) {
    if (error->empty()) *error = "out of memory";
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_set_write_fn(png, out, AppendBytes, NoFlush);
  const int bit_depth = image.depth() == CV_16U ? 16 : 8;
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.cols),
               static_cast<png_uint_32>(image.rows), bit_depth,
               image.channels() == 3 ? PNG_COLOR_TYPE_RGB : PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, settings.filter);
  png_set_compression_level(png, settings.level);
  png_set_compression_strategy(png, settings.strategy);
  // IDAT chunks of 1 MiB rather than libpng's 8 KiB.
  png_set_compression_buffer_size(png, 1 << 20);
  png_write_info(png, info);
  if (image.channels() == 3) png_set_bgr(png);
  // PNG samples are big-endian; cv::Mat holds them in the host's order.
  if (bit_depth == 16 && !libpng::IsBigEndianHost()) png_set_swap(png);
  for (int row = 0; row < image.rows; ++row)
    png_write_row(png, const_cast<png_bytep>(image.ptr<png_byte>(row)));
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return true;
}

}  // namespace

std::vector<unsigned char> EncodePng(const cv::Mat& image, PngCompression compression) {
  if (image.empty() || (image.depth() != CV_8U && image.depth() != CV_16U) ||
      (image.channels() != 1 && image.channels() != 3))
    throw std::runtime_error(
        "cannot encode PNG: expected an 8- or 16-bit image of 1 or 3 channels");
  // kStored: no filter, as OpenCV 4.6 cannot choose (with a filter the stored
  // encoding cost ~65 ms per 1080p frame instead of ~12 ms). kCompact: what
  // cv::imencode does by default, measured the fastest of its settings.
  const PngSettings settings =
      compression == PngCompression::kStored
          ? PngSettings{Z_NO_COMPRESSION, Z_DEFAULT_STRATEGY, PNG_FILTER_NONE}
          : PngSettings{Z_BEST_SPEED, Z_RLE, PNG_FILTER_SUB};
  std::vector<unsigned char> out;
  // Stored: rows plus a filter byte each, block headers and the chunks.
  if (compression == PngCompression::kStored)
    out.reserve(image.total() * image.elemSize() + static_cast<size_t>(image.rows) + 4096);
  std::string error;
  if (!Write(image, settings, &out, &error))
    throw std::runtime_error("cannot encode PNG: " + error);
  return out;
}

}  // namespace dfsm
