// The pixel size of a PNG or JPEG file, read from its header without decoding
// it. An uploaded frame is checked this way before OpenCV decodes it: a few
// kilobytes of PNG can declare a frame of a billion pixels, and decoding that
// would take gigabytes and get the daemon killed by its MemoryMax.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

namespace dfsm::service {

struct ImageSize {
  int64_t width = 0;
  int64_t height = 0;
};

// nullopt when `bytes` is neither a PNG (IHDR) nor a JPEG whose segments up to
// its first start-of-scan lie inside the data given (a prefix of the file will
// do; see ReadImageHeader in core/io/image_decode.h).
std::optional<ImageSize> ReadImageSize(std::string_view bytes);

}  // namespace dfsm::service
