#include "core/io/depth_tiff.h"

#include <tiffio.h>

#include <algorithm>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace dfsm {
namespace {

// libtiff's client I/O over a growing byte buffer (writing) or a file's bytes
// (reading), so that the file is written atomically (file_util.h) and errors
// come back as messages rather than on stderr.
struct Buffer {
  std::vector<unsigned char> bytes;
  uint64_t at = 0;
  std::string error;
};

tmsize_t ReadProc(thandle_t handle, void* data, tmsize_t size) {
  auto* b = static_cast<Buffer*>(handle);
  const uint64_t n = std::min<uint64_t>(static_cast<uint64_t>(size),
                                        b->at < b->bytes.size() ? b->bytes.size() - b->at : 0);
  std::memcpy(data, b->bytes.data() + b->at, n);
  b->at += n;
  return static_cast<tmsize_t>(n);
}

tmsize_t WriteProc(thandle_t handle, void* data, tmsize_t size) {
  auto* b = static_cast<Buffer*>(handle);
  const uint64_t end = b->at + static_cast<uint64_t>(size);
  if (end > b->bytes.size()) b->bytes.resize(end);
  std::memcpy(b->bytes.data() + b->at, data, static_cast<size_t>(size));
  b->at = end;
  return size;
}

toff_t SeekProc(thandle_t handle, toff_t offset, int whence) {
  auto* b = static_cast<Buffer*>(handle);
  const int64_t base = whence == SEEK_CUR   ? static_cast<int64_t>(b->at)
                       : whence == SEEK_END ? static_cast<int64_t>(b->bytes.size())
                                            : 0;
  const int64_t target = base + static_cast<int64_t>(offset);
  if (target < 0) return static_cast<toff_t>(-1);
  b->at = static_cast<uint64_t>(target);
  return static_cast<toff_t>(target);
}

int CloseProc(thandle_t) { return 0; }
toff_t SizeProc(thandle_t handle) { return static_cast<Buffer*>(handle)->bytes.size(); }
int MapProc(thandle_t, void**, toff_t*) { return 0; }
void UnmapProc(thandle_t, void*, toff_t) {}

int KeepError(TIFF*, void* user_data, const char* module, const char* format, va_list args) {
  char message[512];
  std::vsnprintf(message, sizeof(message), format, args);
  auto* b = static_cast<Buffer*>(user_data);
  if (b->error.empty()) b->error = (module ? std::string(module) + ": " : "") + message;
  return 1;
}

int IgnoreWarning(TIFF*, void*, const char*, const char*, va_list) { return 1; }

using TiffHandle = std::unique_ptr<TIFF, void (*)(TIFF*)>;

TiffHandle Open(Buffer* buffer, const char* mode) {
  const std::unique_ptr<TIFFOpenOptions, void (*)(TIFFOpenOptions*)> options(TIFFOpenOptionsAlloc(),
                                                                             TIFFOpenOptionsFree);
  TIFFOpenOptionsSetErrorHandlerExtR(options.get(), KeepError, buffer);
  TIFFOpenOptionsSetWarningHandlerExtR(options.get(), IgnoreWarning, buffer);
  return TiffHandle(TIFFClientOpenExt("depth", mode, buffer, ReadProc, WriteProc, SeekProc,
                                      CloseProc, SizeProc, MapProc, UnmapProc, options.get()),
                    TIFFClose);
}

std::runtime_error Failure(const std::filesystem::path& path, const std::string& what,
                           const Buffer& buffer) {
  return std::runtime_error(path.string() + ": " + what +
                            (buffer.error.empty() ? "" : " (" + buffer.error + ")"));
}

}  // namespace

void WriteDepthTiff(const std::filesystem::path& path, const cv::Mat& depth, Flush flush) {
  if (depth.type() != CV_32FC1)
    throw std::runtime_error(path.string() + ": depth map must be CV_32FC1");
  Buffer buffer;
  buffer.bytes.reserve(depth.total() * sizeof(float) + 65536);
  {
    const TiffHandle tiff = Open(&buffer, "w");
    if (!tiff) throw Failure(path, "cannot encode float32 TIFF", buffer);
    // Uncompressed: deflate (as OpenCV wrote it before) took 15-30 ms of a
    // 1080p result and saved nothing on a float map (8 301 026 bytes for
    // 8 294 400 of samples).
    const uint32_t rows_per_strip =
        std::max(1u, static_cast<uint32_t>((1u << 16) / (depth.cols * sizeof(float))));
    bool ok = TIFFSetField(tiff.get(), TIFFTAG_IMAGEWIDTH, static_cast<uint32_t>(depth.cols)) &&
              TIFFSetField(tiff.get(), TIFFTAG_IMAGELENGTH, static_cast<uint32_t>(depth.rows)) &&
              TIFFSetField(tiff.get(), TIFFTAG_BITSPERSAMPLE, 32) &&
              TIFFSetField(tiff.get(), TIFFTAG_SAMPLEFORMAT, SAMPLEFORMAT_IEEEFP) &&
              TIFFSetField(tiff.get(), TIFFTAG_SAMPLESPERPIXEL, 1) &&
              TIFFSetField(tiff.get(), TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK) &&
              TIFFSetField(tiff.get(), TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG) &&
              TIFFSetField(tiff.get(), TIFFTAG_COMPRESSION, COMPRESSION_NONE) &&
              TIFFSetField(tiff.get(), TIFFTAG_ROWSPERSTRIP, rows_per_strip);
    for (int row = 0; ok && row < depth.rows; ++row)
      ok = TIFFWriteScanline(tiff.get(), const_cast<float*>(depth.ptr<float>(row)),
                             static_cast<uint32_t>(row), 0) == 1;
    if (ok) ok = TIFFWriteDirectory(tiff.get()) == 1;
    if (!ok) throw Failure(path, "cannot encode float32 TIFF", buffer);
  }
  WriteFileAtomically(path, buffer.bytes, flush);
}

cv::Mat ReadDepthTiff(const std::filesystem::path& path) {
  Buffer buffer;
  {
    std::error_code error;
    if (!std::filesystem::is_regular_file(path, error))
      throw std::runtime_error(path.string() + ": missing or not a TIFF image");
    const std::string bytes = ReadFileToString(path);
    buffer.bytes.assign(bytes.begin(), bytes.end());
  }
  const TiffHandle tiff = Open(&buffer, "r");
  if (!tiff) throw Failure(path, "missing or not a TIFF image", buffer);
  uint32_t width = 0, height = 0;
  uint16_t bits = 0, samples = 1, format = SAMPLEFORMAT_UINT, planar = PLANARCONFIG_CONTIG;
  TIFFGetField(tiff.get(), TIFFTAG_IMAGEWIDTH, &width);
  TIFFGetField(tiff.get(), TIFFTAG_IMAGELENGTH, &height);
  TIFFGetFieldDefaulted(tiff.get(), TIFFTAG_BITSPERSAMPLE, &bits);
  TIFFGetFieldDefaulted(tiff.get(), TIFFTAG_SAMPLESPERPIXEL, &samples);
  TIFFGetFieldDefaulted(tiff.get(), TIFFTAG_SAMPLEFORMAT, &format);
  TIFFGetFieldDefaulted(tiff.get(), TIFFTAG_PLANARCONFIG, &planar);
  if (bits != 32 || samples != 1 || format != SAMPLEFORMAT_IEEEFP)
    throw std::runtime_error(path.string() + ": expected single-channel float32, got " +
                             std::to_string(samples) + " channel(s) of " + std::to_string(bits) +
                             "-bit " + (format == SAMPLEFORMAT_IEEEFP ? "float" : "integer") +
                             " samples");
  if (width == 0 || height == 0 || width > (1u << 16) || height > (1u << 16))
    throw std::runtime_error(path.string() + ": implausible size " + std::to_string(width) + "x" +
                             std::to_string(height));
  cv::Mat depth(static_cast<int>(height), static_cast<int>(width), CV_32FC1);
  if (TIFFIsTiled(tiff.get())) {
    uint32_t tile_width = 0, tile_height = 0;
    TIFFGetField(tiff.get(), TIFFTAG_TILEWIDTH, &tile_width);
    TIFFGetField(tiff.get(), TIFFTAG_TILELENGTH, &tile_height);
    if (tile_width == 0 || tile_height == 0) throw Failure(path, "tiles of no size", buffer);
    std::vector<float> tile(static_cast<size_t>(tile_width) * tile_height);
    for (uint32_t y = 0; y < height; y += tile_height) {
      for (uint32_t x = 0; x < width; x += tile_width) {
        if (TIFFReadTile(tiff.get(), tile.data(), x, y, 0, 0) < 0)
          throw Failure(path, "unreadable tile", buffer);
        for (uint32_t ty = 0; ty < tile_height && y + ty < height; ++ty)
          std::memcpy(depth.ptr<float>(static_cast<int>(y + ty)) + x,
                      tile.data() + static_cast<size_t>(ty) * tile_width,
                      std::min(tile_width, width - x) * sizeof(float));
      }
    }
  } else {
    for (uint32_t row = 0; row < height; ++row)
      if (TIFFReadScanline(tiff.get(), depth.ptr<float>(static_cast<int>(row)), row, 0) != 1)
        throw Failure(path, "unreadable row " + std::to_string(row), buffer);
  }
  return depth;
}

}  // namespace dfsm
