#include "core/io/image_decode.h"

#include <gtest/gtest.h>
#include <png.h>
#include <turbojpeg.h>

#include <chrono>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

namespace dfsm {
namespace {

using Reason = ImageDecodeError::Reason;

std::string Encode(const std::string& extension, const cv::Mat& image,
                   const std::vector<int>& params = {}) {
  std::vector<uchar> bytes;
  EXPECT_TRUE(cv::imencode(extension, image, bytes, params));
  return std::string(bytes.begin(), bytes.end());
}

cv::Mat Noise(int rows, int cols, int type) {
  cv::Mat image(rows, cols, type);
  cv::RNG rng(11);
  rng.fill(image, cv::RNG::UNIFORM, 0, CV_MAT_DEPTH(type) == CV_16U ? 65536 : 256);
  return image;
}

cv::Mat Reference(const std::string& bytes) {
  return cv::imdecode(std::vector<uchar>(bytes.begin(), bytes.end()), cv::IMREAD_UNCHANGED);
}

void ExpectSameImage(const cv::Mat& a, const cv::Mat& b) {
  ASSERT_EQ(a.type(), b.type());
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
}

// Decodes `bytes`, expecting an ImageDecodeError for `reason`; returns its message.
std::string DecodeError(const std::string& bytes, Reason reason,
                        const ImageDecodeLimits& limits = {}) {
  try {
    DecodeImage(bytes, limits);
  } catch (const ImageDecodeError& e) {
    EXPECT_EQ(static_cast<int>(e.reason()), static_cast<int>(reason)) << e.what();
    return e.what();
  }
  ADD_FAILURE() << "DecodeImage accepted it";
  return "";
}

// Offset of the first start-of-scan marker (OpenCV writes no segment whose
// payload could hold FF DA before it).
size_t FirstScan(const std::string& jpeg) { return jpeg.find("\xFF\xDA"); }

// A progressive JPEG with `extra` copies of its last scan inserted before the
// end-of-image marker: the shape of the attack (libjpeg decodes every scan,
// each a pass over the whole frame, warning at most about the progression).
std::string ManyScanJpeg(int extra, int rows = 64, int cols = 64) {
  const std::string jpeg = Encode(".jpg", cv::Mat(rows, cols, CV_8UC1, cv::Scalar(128)),
                                  {cv::IMWRITE_JPEG_PROGRESSIVE, 1});
  const size_t last_scan = jpeg.rfind("\xFF\xDA");
  const size_t end = jpeg.size() - 2;  // OpenCV's JPEG ends with FF D9
  EXPECT_EQ(jpeg.substr(end), "\xFF\xD9");
  const std::string scan = jpeg.substr(last_scan, end - last_scan);
  std::string crafted = jpeg.substr(0, end);
  crafted.reserve(jpeg.size() + scan.size() * extra);
  for (int i = 0; i < extra; ++i) crafted += scan;
  return crafted + "\xFF\xD9";
}

// `png` with the IHDR declaring width x height (the CRC no longer matches;
// the size is what matters, read before anything checks it).
std::string ForgedPng(uint32_t width, uint32_t height) {
  std::string png = Encode(".png", cv::Mat(4, 4, CV_8UC1, cv::Scalar(9)));
  for (int i = 0; i < 4; ++i) {
    png[16 + i] = static_cast<char>(width >> (24 - 8 * i));
    png[20 + i] = static_cast<char>(height >> (24 - 8 * i));
  }
  return png;
}

// A baseline JPEG whose frame header (SOF0) declares width x height.
std::string ForgedJpeg(uint16_t width, uint16_t height) {
  std::string jpeg = Encode(".jpg", cv::Mat(8, 8, CV_8UC1, cv::Scalar(9)));
  const size_t sof = jpeg.find("\xFF\xC0");
  EXPECT_NE(sof, std::string::npos);
  // FF C0, length (2), precision (1), height (2), width (2).
  jpeg[sof + 5] = static_cast<char>(height >> 8);
  jpeg[sof + 6] = static_cast<char>(height & 0xFF);
  jpeg[sof + 7] = static_cast<char>(width >> 8);
  jpeg[sof + 8] = static_cast<char>(width & 0xFF);
  return jpeg;
}

TEST(ImageDecodeTest, JpegDecodesAsCvImdecodeDoes) {
  for (const cv::Mat& image : {Noise(37, 53, CV_8UC1), Noise(37, 53, CV_8UC3)}) {
    for (const bool progressive : {false, true}) {
      const std::string jpeg = Encode(".jpg", image, {cv::IMWRITE_JPEG_PROGRESSIVE, progressive});
      const cv::Mat decoded = DecodeImage(jpeg);
      EXPECT_EQ(decoded.channels(), image.channels());
      ExpectSameImage(decoded, Reference(jpeg));
    }
  }
}

TEST(ImageDecodeTest, CmykJpegDecodesToBgrAsCvImdecodeDoes) {
  const cv::Mat cmyk = Noise(24, 40, CV_8UC4);
  tjhandle compressor = tjInitCompress();
  ASSERT_NE(compressor, nullptr);
  unsigned char* buffer = nullptr;
  unsigned long size = 0;
  ASSERT_EQ(tjCompress2(compressor, cmyk.data, cmyk.cols, static_cast<int>(cmyk.step), cmyk.rows,
                        TJPF_CMYK, &buffer, &size, TJSAMP_444, 90, 0),
            0)
      << tjGetErrorStr2(compressor);
  const std::string jpeg(reinterpret_cast<const char*>(buffer), size);
  tjFree(buffer);
  tjDestroy(compressor);
  const cv::Mat decoded = DecodeImage(jpeg);
  EXPECT_EQ(decoded.type(), CV_8UC3);
  ExpectSameImage(decoded, Reference(jpeg));
}

TEST(ImageDecodeTest, PngDecodesAsCvImdecodeDoes) {
  for (const int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1, CV_16UC3}) {
    const cv::Mat image = Noise(19, 23, type);
    const cv::Mat decoded = DecodeImage(Encode(".png", image));
    ExpectSameImage(decoded, image);  // lossless, 16-bit kept
  }
}

// A PNG of any colour type and bit depth, written by libpng from raw rows
// (cv::imencode writes only gray, BGR and BGRA): `row(y)` gives row y's bytes
// as PNG packs them.
struct PngSpec {
  int color_type, bit_depth;
  bool interlaced = false;
  bool transparency = false;  // a tRNS chunk (palette alpha, or one transparent colour)
};

void AppendToString(png_structp png, png_bytep data, png_size_t size) {
  static_cast<std::string*>(png_get_io_ptr(png))->append(reinterpret_cast<char*>(data), size);
}

std::string WritePng(const PngSpec& spec, int width, int height) {
  std::string out;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  if (setjmp(png_jmpbuf(png))) {
    ADD_FAILURE() << "libpng failed to write the test image";
    png_destroy_write_struct(&png, &info);
    return "";
  }
  png_set_write_fn(png, &out, AppendToString, nullptr);
  png_set_IHDR(png, info, width, height, spec.bit_depth, spec.color_type,
               spec.interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_color palette[16];
  png_byte alphas[16];
  for (int i = 0; i < 16; ++i) {
    palette[i] = {static_cast<png_byte>(16 * i), static_cast<png_byte>(255 - 9 * i),
                  static_cast<png_byte>(7 * i)};
    alphas[i] = static_cast<png_byte>(255 - 15 * i);
  }
  png_color_16 transparent{};
  transparent.red = transparent.green = transparent.blue = transparent.gray = 3;
  if (spec.color_type == PNG_COLOR_TYPE_PALETTE) {
    png_set_PLTE(png, info, palette, 16);
    if (spec.transparency) png_set_tRNS(png, info, alphas, 16, nullptr);
  } else if (spec.transparency) {
    png_set_tRNS(png, info, nullptr, 0, &transparent);
  }
  png_write_info(png, info);
  const int channels = png_get_channels(png, info);
  const size_t row_bytes = (static_cast<size_t>(width) * channels * spec.bit_depth + 7) / 8;
  std::vector<std::vector<png_byte>> rows(height, std::vector<png_byte>(row_bytes));
  std::vector<png_bytep> pointers;
  cv::RNG rng(5);
  for (auto& row : rows) {
    // Palette indices must name an entry: 4-bit samples below 16 everywhere.
    for (png_byte& b : row)
      b = static_cast<png_byte>(spec.color_type == PNG_COLOR_TYPE_PALETTE && spec.bit_depth == 8
                                    ? rng.uniform(0, 16)
                                    : rng.uniform(0, 256));
    pointers.push_back(row.data());
  }
  png_write_image(png, pointers.data());
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return out;
}

TEST(ImageDecodeTest, EveryKindOfPngDecodesAsCvImdecodeDoes) {
  const PngSpec specs[] = {
      {PNG_COLOR_TYPE_GRAY, 1},
      {PNG_COLOR_TYPE_GRAY, 2},
      {PNG_COLOR_TYPE_GRAY, 4},
      {PNG_COLOR_TYPE_GRAY, 8, false, true},
      {PNG_COLOR_TYPE_GRAY, 16, true},
      {PNG_COLOR_TYPE_GRAY_ALPHA, 8},
      {PNG_COLOR_TYPE_GRAY_ALPHA, 16},
      {PNG_COLOR_TYPE_PALETTE, 4},
      {PNG_COLOR_TYPE_PALETTE, 8, true},
      {PNG_COLOR_TYPE_PALETTE, 8, false, true},
      {PNG_COLOR_TYPE_RGB, 8, true},
      {PNG_COLOR_TYPE_RGB, 8, false, true},
      {PNG_COLOR_TYPE_RGB, 16},
      {PNG_COLOR_TYPE_RGB_ALPHA, 8},
      {PNG_COLOR_TYPE_RGB_ALPHA, 16, true},
  };
  for (const PngSpec& spec : specs) {
    SCOPED_TRACE("colour type " + std::to_string(spec.color_type) + ", " +
                 std::to_string(spec.bit_depth) + " bits" + (spec.interlaced ? ", Adam7" : "") +
                 (spec.transparency ? ", tRNS" : ""));
    const std::string png = WritePng(spec, 13, 11);
    const cv::Mat reference = Reference(png);
    ASSERT_FALSE(reference.empty());
    ExpectSameImage(DecodeImage(png), reference);
  }
}

TEST(ImageDecodeTest, ReadsTheSizeFromTheHeaderAlone) {
  const std::string png = Encode(".png", Noise(240, 320, CV_8UC1));
  const ImageHeader png_header = ReadImageHeader(std::string_view(png).substr(0, 24));
  EXPECT_EQ(png_header.format, ImageFormat::kPng);
  EXPECT_EQ(png_header.width, 320);
  EXPECT_EQ(png_header.height, 240);
  // A JPEG needs its segments up to the first scan, not the scan's data.
  const std::string jpeg = Encode(".jpg", Noise(1000, 17, CV_8UC3));
  const ImageHeader jpeg_header =
      ReadImageHeader(std::string_view(jpeg).substr(0, FirstScan(jpeg) + 20));
  EXPECT_EQ(jpeg_header.format, ImageFormat::kJpeg);
  EXPECT_EQ(jpeg_header.width, 17);
  EXPECT_EQ(jpeg_header.height, 1000);
  // Cut before the first scan, even behind the frame header, it has no size:
  // libjpeg's header reader stops at the first scan, TurboJPEG reports nothing
  // before.
  EXPECT_THROW(ReadImageHeader(std::string_view(jpeg).substr(0, FirstScan(jpeg))),
               ImageDecodeError);
  const ImageHeader forged = ReadImageHeader(ForgedPng(100000, 100000));
  EXPECT_EQ(forged.width, 100000);
  EXPECT_EQ(ReadImageHeader(ForgedJpeg(60000, 50000)).width, 60000);
}

TEST(ImageDecodeTest, RefusesADeclaredGigapixelFrameBeforeDecoding) {
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(DecodeError(ForgedPng(100000, 100000), Reason::kTooLarge),
            "frame declares 100000x100000 pixels, more than the limit of 268435456");
  EXPECT_EQ(DecodeError(ForgedJpeg(60000, 50000), Reason::kTooLarge),
            "frame declares 60000x50000 pixels, more than the limit of 268435456");
  ImageDecodeLimits small;
  small.max_pixels = 32 * 32;
  EXPECT_NE(DecodeError(Encode(".png", Noise(32, 33, CV_8UC1)), Reason::kTooLarge, small)
                .find("33x32 pixels, more than the limit of 1024"),
            std::string::npos);
  EXPECT_EQ(DecodeImage(Encode(".png", Noise(32, 32, CV_8UC1)), small).cols, 32);
  // Nothing of 10^10 pixels was allocated or decoded.
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
}

TEST(ImageDecodeTest, CountsTheScansOfAProgressiveJpeg) {
  // libjpeg's standard progression: 6 scans for gray, 10 for colour.
  ImageDecodeLimits limits;
  for (const auto& [type, scans] : {std::pair{CV_8UC1, 6}, std::pair{CV_8UC3, 10}}) {
    const std::string jpeg = Encode(".jpg", Noise(16, 16, type), {cv::IMWRITE_JPEG_PROGRESSIVE, 1});
    limits.max_jpeg_scans = scans;
    EXPECT_FALSE(DecodeImage(jpeg, limits).empty());
    limits.max_jpeg_scans = scans - 1;
    EXPECT_EQ(DecodeError(jpeg, Reason::kTooManyScans, limits),
              "progressive JPEG with " + std::to_string(scans) + " scans, more than the limit of " +
                  std::to_string(scans - 1));
  }
  limits.max_jpeg_scans = 1;  // a baseline JPEG has one scan
  EXPECT_FALSE(DecodeImage(Encode(".jpg", Noise(16, 16, CV_8UC3)), limits).empty());
}

TEST(ImageDecodeTest, RefusesAJpegWithThousandsOfScansWithoutDecodingThem) {
  const std::string jpeg = ManyScanJpeg(20000);
  // cv::imdecode reads it as an image: the attack works on OpenCV alone.
  EXPECT_EQ(Reference(ManyScanJpeg(50)).cols, 64);
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(DecodeError(jpeg, Reason::kTooManyScans),
            "progressive JPEG with 20006 scans, more than the limit of 100");
  ImageDecodeLimits most;
  most.max_jpeg_scans = ImageDecodeLimits::kMaxJpegScans;
  EXPECT_NE(DecodeError(jpeg, Reason::kTooManyScans, most).find("more than the limit of 500"),
            std::string::npos);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
  // Within the limit it decodes, warnings about the progression and all, as
  // cv::imdecode does.
  const std::string some = ManyScanJpeg(50);
  ExpectSameImage(DecodeImage(some), Reference(some));
}

TEST(ImageDecodeTest, RefusesATruncatedJpeg) {
  const std::string jpeg = Encode(".jpg", Noise(48, 64, CV_8UC3));
  EXPECT_EQ(DecodeError(jpeg.substr(0, jpeg.size() * 3 / 4), Reason::kTruncated),
            "truncated JPEG (" + std::to_string(jpeg.size() * 3 / 4) +
                " bytes, no end-of-image marker after the last scan)");
  EXPECT_NE(DecodeError(jpeg.substr(0, jpeg.size() - 1), Reason::kTruncated).find("truncated JPEG"),
            std::string::npos);
  // Cut inside the header, before any scan.
  EXPECT_NE(
      DecodeError(jpeg.substr(0, FirstScan(jpeg) - 10), Reason::kTruncated).find("truncated JPEG"),
      std::string::npos);
  const std::string progressive =
      Encode(".jpg", Noise(48, 64, CV_8UC3), {cv::IMWRITE_JPEG_PROGRESSIVE, 1});
  DecodeError(progressive.substr(0, progressive.size() / 2), Reason::kTruncated);
}

TEST(ImageDecodeTest, IgnoresMarkersInsideSegmentsAndAfterTheEnd) {
  const cv::Mat image = Noise(24, 32, CV_8UC3);
  const std::string jpeg = Encode(".jpg", image);
  // An APP1 segment (EXIF-like, with a thumbnail's markers in it) and a trailer.
  const std::string payload = std::string("Exif\0\0", 6) + "\xFF\xD8\xFF\xDA\x00\x02\xFF\xD9";
  std::string app1 = "\xFF\xE1";
  app1 += static_cast<char>(0);
  app1 += static_cast<char>(payload.size() + 2);
  const std::string dressed = jpeg.substr(0, 2) + app1 + payload + jpeg.substr(2) +
                              std::string(40, '\0') + "TRAILER\xFF\xDA";
  ExpectSameImage(DecodeImage(dressed), Reference(jpeg));
  ImageDecodeLimits one_scan;
  one_scan.max_jpeg_scans = 1;
  EXPECT_FALSE(DecodeImage(dressed, one_scan).empty());
}

TEST(ImageDecodeTest, TakesAJpegWithWarningsButNotOneLeftUnfinished) {
  const std::string jpeg = Encode(".jpg", Noise(24, 32, CV_8UC1));
  // Stray bytes before the end-of-image marker: libjpeg warns ("extraneous
  // bytes before marker 0xd9") and decodes the whole image, as does OpenCV.
  const std::string stray = jpeg.substr(0, jpeg.size() - 2) + "\x12\x34\xFF\xD9";
  ExpectSameImage(DecodeImage(stray), Reference(stray));
  // A warning (stray bytes before the first scan) and then a fatal error (the
  // second scan of a progressive JPEG names a component the frame does not
  // have): TurboJPEG reports only the warning, and the image is unfinished.
  const std::string progressive =
      Encode(".jpg", Noise(24, 32, CV_8UC1), {cv::IMWRITE_JPEG_PROGRESSIVE, 1});
  const size_t first = FirstScan(progressive);
  const size_t second = progressive.find("\xFF\xDA", first + 2);
  ASSERT_NE(second, std::string::npos);
  std::string broken = progressive;
  broken[second + 5] = 9;  // FF DA, length (2), count (1), first component id
  broken.insert(first, "\x12\x34");
  const std::string error = DecodeError(broken, Reason::kCorrupt);
  EXPECT_NE(error.find("unreadable JPEG (Invalid component ID 9 in SOS)"), std::string::npos)
      << error;
  EXPECT_TRUE(Reference(broken).empty());
}

TEST(ImageDecodeTest, RefusesOtherAndDamagedData) {
  EXPECT_EQ(DecodeError("", Reason::kNotAnImage), "not a PNG or JPEG");
  EXPECT_EQ(DecodeError("garbage", Reason::kNotAnImage), "not a PNG or JPEG");
  DecodeError(Encode(".bmp", Noise(8, 8, CV_8UC3)), Reason::kNotAnImage);
  const std::string png = Encode(".png", Noise(32, 32, CV_8UC3));
  EXPECT_EQ(DecodeError(png.substr(0, png.size() / 2), Reason::kCorrupt),
            "unreadable PNG (file truncated)");
  EXPECT_NE(DecodeError(png.substr(0, 20), Reason::kCorrupt).find("PNG header cut short"),
            std::string::npos);
  std::string flipped = png;
  for (size_t k = png.size() / 3; k < png.size(); k += 7) flipped[k] ^= 0x55;
  DecodeError(flipped, Reason::kCorrupt);
  EXPECT_THROW(ReadImageHeader("not an image"), ImageDecodeError);
  EXPECT_THROW(ReadImageHeader(std::string("\xFF\xD8\xFF\xE0\x00\x01", 6)), ImageDecodeError);
}

TEST(ImageDecodeTest, ChecksItsLimits) {
  ImageDecodeLimits limits;
  EXPECT_NO_THROW(limits.Check());
  limits.max_pixels = 0;
  EXPECT_THROW(limits.Check(), std::invalid_argument);
  limits = {};
  limits.max_jpeg_scans = ImageDecodeLimits::kMaxJpegScans + 1;
  EXPECT_THROW(limits.Check(), std::invalid_argument);
  EXPECT_THROW(DecodeImage(Encode(".png", Noise(4, 4, CV_8UC1)), limits), std::invalid_argument);
  limits.max_jpeg_scans = 0;
  EXPECT_THROW(limits.Check(), std::invalid_argument);
}

}  // namespace
}  // namespace dfsm
