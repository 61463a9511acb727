// Decoding PNG and JPEG frames with the work bounded before it starts.
//
// cv::imdecode trusts the file: a few kilobytes of PNG can declare a frame of a
// billion pixels (gigabytes allocated before a row is read), and a progressive
// JPEG can carry tens of thousands of scans, each a pass over every block of the
// frame (87 000 scans in 1 MB took 17.7 s to decode). DecodeImage reads the size
// from the header first and refuses a frame over ImageDecodeLimits::max_pixels,
// counts a JPEG's scans before decoding it, and decodes JPEG through TurboJPEG
// with TJFLAG_LIMITSCANS as a second guard. The result has cv::imdecode's
// IMREAD_UNCHANGED conventions: gray JPEG CV_8UC1, colour JPEG CV_8UC3 BGR
// (CMYK converted as OpenCV does), PNG exactly as OpenCV decodes it (gray, BGR,
// BGRA; 16-bit kept 16-bit).
#pragma once

#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>
#include <string_view>

namespace dfsm {

// Thrown for a frame that is not a PNG or JPEG, is damaged, or exceeds the
// limits; the message names the problem (not the file: the caller knows it).
class ImageDecodeError : public std::runtime_error {
 public:
  enum class Reason {
    kNotAnImage,    // neither PNG nor JPEG
    kCorrupt,       // a PNG or JPEG the decoder cannot read
    kTruncated,     // a JPEG cut short (libjpeg would fill the rest with grey)
    kTooLarge,      // more pixels than ImageDecodeLimits::max_pixels
    kTooManyScans,  // more scans than ImageDecodeLimits::max_jpeg_scans
  };

  ImageDecodeError(Reason reason, const std::string& message)
      : std::runtime_error(message), reason_(reason) {}

  Reason reason() const { return reason_; }

  // The reason for a user: "unreadable or not an image (...)" for a file that
  // is no image or a damaged one, the decoder's message otherwise.
  std::string Describe() const;

 private:
  Reason reason_;
};

struct ImageDecodeLimits {
  // Above this, a frame is refused from its header, before any allocation. The
  // default (2^28, 268 MP) admits every camera sensor of today and caps a frame
  // at 0.8 GB as 8-bit BGR.
  int64_t max_pixels = int64_t{1} << 28;
  // A JPEG with more scans than this is refused before it is decoded. Every
  // scan is a pass over the frame. libjpeg's standard progression (cjpeg
  // -progressive, OpenCV's IMWRITE_JPEG_PROGRESSIVE) has 10 scans for colour, 6
  // for gray; a baseline JPEG has 1. At most kMaxJpegScans: TurboJPEG's own
  // guard (TJFLAG_LIMITSCANS) stops at that fixed number.
  int max_jpeg_scans = 100;

  static constexpr int kMaxJpegScans = 500;

  // Throws std::invalid_argument naming a field out of range.
  void Check() const;
};

enum class ImageFormat { kPng, kJpeg };

struct ImageHeader {
  ImageFormat format = ImageFormat::kPng;
  int64_t width = 0;
  int64_t height = 0;
};

// The format and size a PNG (IHDR) or JPEG (frame header, read by TurboJPEG's
// tjDecompressHeader3) declares, without decoding. `bytes` may be a prefix of
// the file: a PNG needs its first 24 bytes, a JPEG everything up to its first
// start-of-scan marker. Throws ImageDecodeError (kNotAnImage, kCorrupt).
ImageHeader ReadImageHeader(std::string_view bytes);

// Decodes a whole PNG or JPEG file within `limits` (see the top of this file).
// Throws ImageDecodeError; std::invalid_argument when `limits` fail Check().
cv::Mat DecodeImage(std::string_view bytes, const ImageDecodeLimits& limits = {});

// Reads and decodes a PNG or JPEG file (DecodeImage). Throws std::runtime_error
// whose message starts with the path: the file cannot be read, or
// ImageDecodeError's reason.
cv::Mat ReadImageFile(const std::filesystem::path& path, const ImageDecodeLimits& limits = {});

}  // namespace dfsm
