#include "core/io/exif_focal.h"

#include <libexif/exif-data.h>

#include <cmath>
#include <memory>

namespace dfsm {

std::optional<double> ReadExifFocalLength35mm(const std::string& file_bytes) {
  // Only JPEGs (FF D8) carry the APP1 segment libexif looks for.
  if (file_bytes.size() < 4 || static_cast<unsigned char>(file_bytes[0]) != 0xFF ||
      static_cast<unsigned char>(file_bytes[1]) != 0xD8)
    return std::nullopt;
  std::unique_ptr<ExifData, decltype(&exif_data_unref)> data(
      exif_data_new_from_data(reinterpret_cast<const unsigned char*>(file_bytes.data()),
                              static_cast<unsigned int>(file_bytes.size())),
      &exif_data_unref);
  if (!data) return std::nullopt;
  ExifEntry* entry = exif_data_get_entry(data.get(), EXIF_TAG_FOCAL_LENGTH_IN_35MM_FILM);
  if (!entry || entry->format != EXIF_FORMAT_SHORT || entry->components < 1 || !entry->data ||
      entry->size < 2)
    return std::nullopt;
  const ExifShort focal = exif_get_short(entry->data, exif_data_get_byte_order(data.get()));
  if (focal == 0) return std::nullopt;  // "unknown" in the standard
  return static_cast<double>(focal);
}

namespace {
constexpr double kFilmDiagonalMm = 43.2666;  // hypot(36, 24)
}  // namespace

double FocalPixelsFrom35mm(double focal_35mm, int width, int height) {
  return focal_35mm * std::hypot(width, height) / kFilmDiagonalMm;
}

double Focal35mmFromPixels(double f_px, int width, int height) {
  return f_px * kFilmDiagonalMm / std::hypot(width, height);
}

}  // namespace dfsm
