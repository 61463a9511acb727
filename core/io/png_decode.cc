#include "core/io/png_decode.h"

#include <png.h>

#include <cstring>
#include <string>
#include <vector>

#include "core/io/libpng_callbacks.h"

namespace dfsm {
namespace {

struct Reader {
  std::string_view bytes;
  size_t at = 0;
  std::string error;
};

void ReadBytes(png_structp png, png_bytep data, png_size_t size) {
  auto* reader = static_cast<Reader*>(png_get_io_ptr(png));
  if (reader->bytes.size() - reader->at < size) png_error(png, "file truncated");
  std::memcpy(data, reader->bytes.data() + reader->at, size);
  reader->at += size;
}

// cv::imdecode(IMREAD_UNCHANGED)'s choice of channels (OpenCV 4.6,
// PngDecoder::readHeader): 4 with alpha or a tRNS chunk on colour, 3 for other
// colour and palettes, 1 for gray (a gray tRNS is dropped).
int ChannelsOf(png_structp png, png_infop info) {
  const int color_type = png_get_color_type(png, info);
  switch (color_type) {
    case PNG_COLOR_TYPE_RGB:
    case PNG_COLOR_TYPE_PALETTE:
      return png_get_valid(png, info, PNG_INFO_tRNS) ? 4 : 3;
    case PNG_COLOR_TYPE_GRAY_ALPHA:
    case PNG_COLOR_TYPE_RGB_ALPHA:
      return 4;
    default:
      return 1;
  }
}

// Decodes into `image`; false (Reader::error set) when libpng fails. Only
// `image` and the pointers are touched after setjmp, and `image` is a member
// of an object that outlives the call, so a longjmp leaves nothing undefined.
bool Decode(Reader* reader, cv::Mat* image, std::vector<png_bytep>* rows) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &reader->error,
                                           libpng::KeepErrorMessage, libpng::IgnoreWarning);
  if (!png) {
    reader->error = "out of memory";
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (!info || setjmp(png_jmpbuf(png))) {
    if (reader->error.empty()) reader->error = "out of memory";
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  png_set_read_fn(png, reader, ReadBytes);
  // The size was bounded by the caller; libpng's own default cap (1e6 x 1e6)
  // must not refuse what the caller admitted.
  png_set_user_limits(png, 0x7fffffff, 0x7fffffff);
  png_read_info(png, info);
  const int channels = ChannelsOf(png, info);
  const int bit_depth = png_get_bit_depth(png, info);
  const int color_type = png_get_color_type(png, info);
  if (bit_depth == 16 && !libpng::IsBigEndianHost()) png_set_swap(png);
  if (channels < 4)
    png_set_strip_alpha(png);
  else
    png_set_tRNS_to_alpha(png);
  if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if ((color_type & PNG_COLOR_MASK_COLOR) == 0 && bit_depth < 8)
    png_set_expand_gray_1_2_4_to_8(png);
  if (channels > 1) {
    if (color_type & PNG_COLOR_MASK_COLOR)
      png_set_bgr(png);
    else
      png_set_gray_to_rgb(png);
  }
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  const int width = static_cast<int>(png_get_image_width(png, info));
  const int height = static_cast<int>(png_get_image_height(png, info));
  image->create(height, width, CV_MAKETYPE(bit_depth == 16 ? CV_16U : CV_8U, channels));
  if (png_get_rowbytes(png, info) != image->cols * image->elemSize())
    png_error(png, "unexpected row size after the transformations");
  rows->resize(static_cast<size_t>(height));
  for (int y = 0; y < height; ++y) (*rows)[static_cast<size_t>(y)] = image->ptr<png_byte>(y);
  png_read_image(png, rows->data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

}  // namespace

cv::Mat DecodePngPixels(std::string_view bytes) {
  Reader reader;
  reader.bytes = bytes;
  cv::Mat image;
  std::vector<png_bytep> rows;
  if (!Decode(&reader, &image, &rows)) throw std::runtime_error(reader.error);
  return image;
}

}  // namespace dfsm
