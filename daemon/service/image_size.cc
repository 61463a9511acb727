#include "daemon/service/image_size.h"

namespace dfsm::service {
namespace {

uint32_t BigEndian(std::string_view bytes, size_t offset, size_t count) {
  uint32_t value = 0;
  for (size_t i = 0; i < count; ++i) {
    value = (value << 8) | static_cast<unsigned char>(bytes[offset + i]);
  }
  return value;
}

std::optional<ImageSize> PngSize(std::string_view bytes) {
  // Signature, then the IHDR chunk, which the format requires to come first:
  // length (4), "IHDR", width (4), height (4).
  constexpr std::string_view kSignature("\x89PNG\r\n\x1a\n", 8);
  if (bytes.size() < 24 || bytes.substr(0, 8) != kSignature) return std::nullopt;
  if (bytes.substr(12, 4) != "IHDR") return std::nullopt;
  return ImageSize{BigEndian(bytes, 16, 4), BigEndian(bytes, 20, 4)};
}

bool IsStartOfFrame(unsigned char marker) {
  // SOF0..SOF15, except DHT (C4), JPG (C8) and DAC (CC), which share the range.
  return marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 && marker != 0xcc;
}

std::optional<ImageSize> JpegSize(std::string_view bytes) {
  if (bytes.size() < 4 || static_cast<unsigned char>(bytes[0]) != 0xff ||
      static_cast<unsigned char>(bytes[1]) != 0xd8) {
    return std::nullopt;
  }
  size_t offset = 2;
  while (offset + 4 <= bytes.size()) {
    if (static_cast<unsigned char>(bytes[offset]) != 0xff) return std::nullopt;
    const unsigned char marker = static_cast<unsigned char>(bytes[offset + 1]);
    if (marker == 0xff) {  // fill byte
      ++offset;
      continue;
    }
    if (marker == 0x01 || (marker >= 0xd0 && marker <= 0xd7)) {  // no length field
      offset += 2;
      continue;
    }
    if (marker == 0xd9 || marker == 0xda) return std::nullopt;  // EOI or scan data before SOF
    const size_t length = BigEndian(bytes, offset + 2, 2);
    if (length < 2) return std::nullopt;
    if (IsStartOfFrame(marker)) {
      // Length (2), precision (1), height (2), width (2).
      if (length < 7 || offset + 9 > bytes.size()) return std::nullopt;
      return ImageSize{BigEndian(bytes, offset + 7, 2), BigEndian(bytes, offset + 5, 2)};
    }
    offset += 2 + length;
  }
  return std::nullopt;
}

}  // namespace

std::optional<ImageSize> ReadImageSize(std::string_view bytes) {
  if (std::optional<ImageSize> size = PngSize(bytes)) return size;
  return JpegSize(bytes);
}

}  // namespace dfsm::service
