#include "core/io/exif_focal.h"

#include <gtest/gtest.h>
#include <libexif/exif-data.h>

#include <cstdlib>
#include <opencv2/imgcodecs.hpp>
#include <vector>

namespace dfsm {
namespace {

// A JPEG whose APP1 segment carries FocalLengthIn35mmFilm = focal_35mm, as a
// phone writes it (libexif builds the segment, OpenCV the image).
std::string JpegWithFocal(int focal_35mm) {
  std::vector<uchar> jpeg;
  cv::imencode(".jpg", cv::Mat(48, 64, CV_8UC3, cv::Scalar(90, 120, 200)), jpeg);
  ExifData* exif = exif_data_new();
  exif_data_set_byte_order(exif, EXIF_BYTE_ORDER_INTEL);
  ExifEntry* entry = exif_entry_new();
  exif_content_add_entry(exif->ifd[EXIF_IFD_EXIF], entry);
  exif_entry_initialize(entry, EXIF_TAG_FOCAL_LENGTH_IN_35MM_FILM);
  exif_set_short(entry->data, EXIF_BYTE_ORDER_INTEL, static_cast<ExifShort>(focal_35mm));
  exif_entry_unref(entry);
  unsigned char* segment = nullptr;
  unsigned int size = 0;
  exif_data_save_data(exif, &segment, &size);  // "Exif\0\0" + TIFF structure
  exif_data_unref(exif);
  std::string bytes(jpeg.begin(), jpeg.begin() + 2);  // SOI
  const unsigned int length = size + 2;
  bytes += "\xFF\xE1";
  bytes += static_cast<char>(length >> 8);
  bytes += static_cast<char>(length & 0xFF);
  bytes.append(reinterpret_cast<const char*>(segment), size);
  bytes.append(jpeg.begin() + 2, jpeg.end());
  std::free(segment);
  return bytes;
}

TEST(ExifFocal, ReadsThe35mmEquivalentOfAPhoneJpeg) {
  const std::string jpeg = JpegWithFocal(26);
  EXPECT_EQ(ReadExifFocalLength35mm(jpeg), 26.0);
  // Still a JPEG OpenCV decodes: the segment sits where a camera puts it.
  EXPECT_FALSE(
      cv::imdecode(std::vector<uchar>(jpeg.begin(), jpeg.end()), cv::IMREAD_COLOR).empty());
}

TEST(ExifFocal, NothingForPngsPlainJpegsZeroAndGarbage) {
  std::vector<uchar> png, jpeg;
  cv::imencode(".png", cv::Mat(8, 8, CV_8UC1, cv::Scalar(7)), png);
  cv::imencode(".jpg", cv::Mat(8, 8, CV_8UC1, cv::Scalar(7)), jpeg);
  EXPECT_FALSE(ReadExifFocalLength35mm(std::string(png.begin(), png.end())));
  EXPECT_FALSE(ReadExifFocalLength35mm(std::string(jpeg.begin(), jpeg.end())));
  EXPECT_FALSE(ReadExifFocalLength35mm(JpegWithFocal(0)));  // 0 means unknown
  EXPECT_FALSE(
      ReadExifFocalLength35mm(std::string("\xFF\xD8\xFF\xE1\xFF\xFF"
                                          "Exif",
                                          10)));
  EXPECT_FALSE(ReadExifFocalLength35mm(""));
}

TEST(ExifFocal, ThirtyFiveMillimetreEquivalenceIsByTheDiagonal) {
  // 36 x 24 mm film at 36 px per mm: f in pixels is the focal length in mm x 36.
  EXPECT_NEAR(FocalPixelsFrom35mm(50.0, 1296, 864), 50.0 * 36.0, 0.01);
  // A 4:3 phone at 26 mm, 4000 x 3000: 26 * 5000 / 43.27.
  EXPECT_NEAR(FocalPixelsFrom35mm(26.0, 4000, 3000), 3004.6, 0.1);
}

}  // namespace
}  // namespace dfsm
