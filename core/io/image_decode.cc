#include "core/io/image_decode.h"

#include <turbojpeg.h>

#include <climits>
#include <cstring>
#include <memory>
#include <new>

#include "core/io/file_util.h"
#include "core/io/png_decode.h"

namespace dfsm {
namespace {

using Reason = ImageDecodeError::Reason;

constexpr std::string_view kPngSignature("\x89PNG\r\n\x1a\n", 8);

unsigned char Byte(std::string_view bytes, size_t i) {
  return static_cast<unsigned char>(bytes[i]);
}

bool IsJpeg(std::string_view bytes) {
  return bytes.size() >= 2 && Byte(bytes, 0) == 0xFF && Byte(bytes, 1) == 0xD8;
}

uint32_t BigEndian32(std::string_view bytes, size_t offset) {
  uint32_t value = 0;
  for (size_t i = 0; i < 4; ++i) value = (value << 8) | Byte(bytes, offset + i);
  return value;
}

ImageHeader ReadPngHeader(std::string_view bytes) {
  // Signature, then the IHDR chunk, which the format requires to come first:
  // length (4), "IHDR", width (4), height (4).
  if (bytes.size() < 24)
    throw ImageDecodeError(Reason::kCorrupt,
                           "PNG header cut short (" + std::to_string(bytes.size()) + " bytes)");
  if (bytes.substr(12, 4) != "IHDR")
    throw ImageDecodeError(Reason::kCorrupt, "PNG without an IHDR chunk first");
  ImageHeader header{ImageFormat::kPng, BigEndian32(bytes, 16), BigEndian32(bytes, 20)};
  if (header.width == 0 || header.height == 0)
    throw ImageDecodeError(Reason::kCorrupt, "PNG declares " + std::to_string(header.width) + "x" +
                                                 std::to_string(header.height) + " pixels");
  return header;
}

struct TjDestroyer {
  void operator()(void* handle) const { tjDestroy(handle); }
};
using TjHandle = std::unique_ptr<void, TjDestroyer>;

TjHandle NewDecompressor() {
  TjHandle handle(tjInitDecompress());
  if (!handle) throw std::bad_alloc();
  return handle;
}

struct JpegFrame {
  int width = 0;
  int height = 0;
  int colorspace = -1;  // TJCS_*, -1 when TurboJPEG does not know it
};

const unsigned char* Data(std::string_view bytes) {
  return reinterpret_cast<const unsigned char*>(bytes.data());
}

JpegFrame ReadJpegFrame(tjhandle handle, std::string_view bytes) {
  JpegFrame frame;
  int subsampling = -1;
  const int result = tjDecompressHeader3(handle, Data(bytes), bytes.size(), &frame.width,
                                         &frame.height, &subsampling, &frame.colorspace);
  // TurboJPEG 2.1 fills in the size as soon as libjpeg has read the frame
  // header, then fails for sampling factors it has no TJSAMP_* for, which
  // libjpeg decodes all the same; a warning (say, stray bytes between
  // segments) also makes it return -1. A size means the header was read.
  if (frame.width > 0 && frame.height > 0) return frame;
  if (result != 0)
    throw ImageDecodeError(Reason::kCorrupt,
                           std::string("unreadable JPEG header (") + tjGetErrorStr2(handle) + ")");
  // libjpeg reached an end-of-image marker, real or put in at the end of the
  // data, before any frame header and scan.
  throw ImageDecodeError(Reason::kTruncated, "JPEG ends before its first scan (" +
                                                 std::to_string(bytes.size()) +
                                                 " bytes): truncated, or tables only");
}

// What a walk over a JPEG's markers finds without decoding anything.
struct JpegLayout {
  int scans = 0;
  bool progressive = false;
  enum class End { kEndOfImage, kEndOfData, kBadSegment } end = End::kEndOfData;
};

// Walks the marker segments from SOI to the first EOI as libjpeg's marker
// reader does: a segment is skipped by its length, the entropy-coded data after
// a start-of-scan by looking for the next marker (inside it an FF is followed
// by 00, a stuffed FF, or a restart marker). Linear in the size and far cheaper
// than one scan's decoding, so a JPEG with too many scans is refused before
// its first is decoded. An end-of-image inside an APPn segment (an EXIF
// thumbnail's) is skipped with its segment, and bytes after the end-of-image
// (some cameras append a trailer) are never looked at.
JpegLayout WalkJpeg(std::string_view bytes) {
  JpegLayout layout;
  size_t i = 2;  // after SOI
  for (;;) {
    // The next marker: an FF, any fill FFs, then a code other than 00.
    for (;;) {
      const void* ff = std::memchr(bytes.data() + i, 0xFF, bytes.size() - i);
      if (ff == nullptr) return layout;
      i = static_cast<size_t>(static_cast<const char*>(ff) - bytes.data());
      if (i + 1 >= bytes.size()) return layout;
      const unsigned char next = Byte(bytes, i + 1);
      if (next != 0x00 && next != 0xFF) break;
      ++i;
    }
    const unsigned char marker = Byte(bytes, i + 1);
    i += 2;
    if (marker == 0xD9) {
      layout.end = JpegLayout::End::kEndOfImage;
      return layout;
    }
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD8))
      continue;  // TEM, RSTn, SOI: no length
    if (i + 2 > bytes.size()) return layout;
    const size_t length = (size_t{Byte(bytes, i)} << 8) | Byte(bytes, i + 1);
    if (length < 2) {
      layout.end = JpegLayout::End::kBadSegment;
      return layout;
    }
    if (marker == 0xDA) ++layout.scans;
    // SOF2, SOF6, SOF10, SOF14: progressive (Huffman or arithmetic coded).
    if (marker == 0xC2 || marker == 0xC6 || marker == 0xCA || marker == 0xCE)
      layout.progressive = true;
    if (length > bytes.size() - i) return layout;  // the segment is cut short
    i += length;
  }
}

std::string Dimensions(int64_t width, int64_t height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

void CheckPixels(int64_t width, int64_t height, const ImageDecodeLimits& limits) {
  if (width * height > limits.max_pixels)
    throw ImageDecodeError(Reason::kTooLarge, "frame declares " + Dimensions(width, height) +
                                                  " pixels, more than the limit of " +
                                                  std::to_string(limits.max_pixels));
}

// As OpenCV's icvCvt_CMYK2BGR_8u_C4C3R, so that a CMYK JPEG decodes to the
// same BGR as through cv::imdecode.
cv::Mat CmykToBgr(const cv::Mat& cmyk) {
  cv::Mat bgr(cmyk.size(), CV_8UC3);
  for (int y = 0; y < cmyk.rows; ++y) {
    const uchar* in = cmyk.ptr<uchar>(y);
    uchar* out = bgr.ptr<uchar>(y);
    for (int x = 0; x < cmyk.cols; ++x, in += 4, out += 3) {
      const int k = in[3];
      out[2] = static_cast<uchar>(k - ((255 - in[0]) * k >> 8));
      out[1] = static_cast<uchar>(k - ((255 - in[1]) * k >> 8));
      out[0] = static_cast<uchar>(k - ((255 - in[2]) * k >> 8));
    }
  }
  return bgr;
}

[[noreturn]] void ThrowTurboJpegError(const std::string& message) {
  // TJFLAG_LIMITSCANS's own message: "Progressive JPEG image has more than 500 scans".
  if (message.find("more than") != std::string::npos && message.find("scans") != std::string::npos)
    throw ImageDecodeError(Reason::kTooManyScans,
                           "progressive JPEG with more than " +
                               std::to_string(ImageDecodeLimits::kMaxJpegScans) +
                               " scans (refused by TurboJPEG)");
  throw ImageDecodeError(Reason::kCorrupt, "unreadable JPEG (" + message + ")");
}

cv::Mat DecodeJpeg(std::string_view bytes, const ImageDecodeLimits& limits) {
  const JpegLayout layout = WalkJpeg(bytes);
  if (layout.scans > limits.max_jpeg_scans)
    throw ImageDecodeError(Reason::kTooManyScans,
                           std::string(layout.progressive ? "progressive JPEG" : "JPEG") +
                               " with " + std::to_string(layout.scans) +
                               " scans, more than the limit of " +
                               std::to_string(limits.max_jpeg_scans));
  // libjpeg decodes a JPEG cut short with only a warning, filling the rest with
  // grey: a truncated frame would be processed as if it were whole.
  if (layout.end == JpegLayout::End::kEndOfData)
    throw ImageDecodeError(Reason::kTruncated, "truncated JPEG (" + std::to_string(bytes.size()) +
                                                   " bytes, no end-of-image marker after the " +
                                                   "last scan)");

  const TjHandle handle = NewDecompressor();
  const JpegFrame frame = ReadJpegFrame(handle.get(), bytes);
  CheckPixels(frame.width, frame.height, limits);

  int pixel_format = TJPF_BGR;
  int type = CV_8UC3;
  if (frame.colorspace == TJCS_GRAY) {
    pixel_format = TJPF_GRAY;
    type = CV_8UC1;
  } else if (frame.colorspace == TJCS_CMYK || frame.colorspace == TJCS_YCCK) {
    pixel_format = TJPF_CMYK;  // libjpeg converts CMYK to nothing but CMYK
    type = CV_8UC4;
  }
  cv::Mat image(frame.height, frame.width, type);
  const auto decode = [&](int flags) {
    return tjDecompress2(handle.get(), Data(bytes), bytes.size(), image.data, frame.width,
                         static_cast<int>(image.step), frame.height, pixel_format,
                         flags | TJFLAG_LIMITSCANS);
  };
  if (decode(0) != 0) {
    // A warning alone (say, stray bytes before a marker) leaves a whole
    // image, which cv::imdecode would return too. But TurboJPEG 2.1 still
    // reports TJERR_WARNING when a fatal error followed a warning and left the
    // image unfinished. libjpeg records the message of its first warning and
    // of a fatal error, so: if decoding again up to the first warning gives
    // the same message, no fatal error followed.
    const int code = tjGetErrorCode(handle.get());
    const std::string message = tjGetErrorStr2(handle.get());
    if (code != TJERR_WARNING) ThrowTurboJpegError(message);
    decode(TJFLAG_STOPONWARNING);
    const std::string first_warning = tjGetErrorStr2(handle.get());
    if (message != first_warning) ThrowTurboJpegError(message);
  }
  return type == CV_8UC4 ? CmykToBgr(image) : image;
}

cv::Mat DecodePng(std::string_view bytes, const ImageDecodeLimits& limits) {
  const ImageHeader header = ReadPngHeader(bytes);
  CheckPixels(header.width, header.height, limits);
  if (bytes.size() > static_cast<size_t>(INT_MAX))
    throw ImageDecodeError(Reason::kTooLarge,
                           "PNG of " + std::to_string(bytes.size()) + " bytes, over 2 GiB");
  try {
    return DecodePngPixels(bytes);
  } catch (const std::runtime_error& e) {
    throw ImageDecodeError(Reason::kCorrupt, std::string("unreadable PNG (") + e.what() + ")");
  }
}

}  // namespace

void ImageDecodeLimits::Check() const {
  if (max_pixels < 1)
    throw std::invalid_argument("ImageDecodeLimits::max_pixels must be positive (got " +
                                std::to_string(max_pixels) + ")");
  if (max_jpeg_scans < 1 || max_jpeg_scans > kMaxJpegScans)
    throw std::invalid_argument("ImageDecodeLimits::max_jpeg_scans must lie in 1.." +
                                std::to_string(kMaxJpegScans) + " (got " +
                                std::to_string(max_jpeg_scans) + ")");
}

ImageHeader ReadImageHeader(std::string_view bytes) {
  if (bytes.substr(0, kPngSignature.size()) == kPngSignature) return ReadPngHeader(bytes);
  if (IsJpeg(bytes)) {
    const TjHandle handle = NewDecompressor();
    const JpegFrame frame = ReadJpegFrame(handle.get(), bytes);
    return ImageHeader{ImageFormat::kJpeg, frame.width, frame.height};
  }
  throw ImageDecodeError(Reason::kNotAnImage, "not a PNG or JPEG");
}

cv::Mat DecodeImage(std::string_view bytes, const ImageDecodeLimits& limits) {
  limits.Check();
  if (bytes.substr(0, kPngSignature.size()) == kPngSignature) return DecodePng(bytes, limits);
  if (IsJpeg(bytes)) return DecodeJpeg(bytes, limits);
  throw ImageDecodeError(Reason::kNotAnImage, "not a PNG or JPEG");
}

cv::Mat ReadImageFile(const std::filesystem::path& path, const ImageDecodeLimits& limits) {
  std::string bytes;
  try {
    bytes = ReadFileToString(path);
    return DecodeImage(bytes, limits);
  } catch (const std::exception& e) {
    throw std::runtime_error(path.string() + ": " + e.what());
  }
}

std::string ImageDecodeError::Describe() const {
  switch (reason_) {
    case Reason::kNotAnImage:
    case Reason::kCorrupt:
      return std::string("unreadable or not an image (") + what() + ")";
    default:
      return what();
  }
}

}  // namespace dfsm
