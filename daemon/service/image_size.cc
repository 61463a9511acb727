#include "daemon/service/image_size.h"

#include "core/io/image_decode.h"

namespace dfsm::service {

// The header is read as the frame will be decoded (core/io/image_decode): PNG
// from its IHDR chunk, JPEG by TurboJPEG's tjDecompressHeader3, which walks the
// markers up to the first scan as libjpeg does, so the upload check and the
// decoder cannot disagree about a file's size.
std::optional<ImageSize> ReadImageSize(std::string_view bytes) {
  try {
    const ImageHeader header = ReadImageHeader(bytes);
    return ImageSize{header.width, header.height};
  } catch (const ImageDecodeError&) {
    return std::nullopt;
  }
}

}  // namespace dfsm::service
