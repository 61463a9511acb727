#include "core/io/image_sequence.h"

#include <fnmatch.h>

#include <algorithm>
#include <cctype>
#include <stdexcept>

#include "core/io/file_util.h"
#include "core/io/image_decode.h"

namespace dfsm {
namespace fs = std::filesystem;
namespace {

bool HasGlob(const std::string& text) { return text.find_first_of("*?[") != std::string::npos; }

bool IsImageFile(const fs::path& path) {
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension == ".png" || extension == ".jpg" || extension == ".jpeg";
}

// Name order with digit runs compared as numbers.
bool NaturalLess(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) &&
        std::isdigit(static_cast<unsigned char>(b[j]))) {
      size_t i_end = i, j_end = j;
      while (i_end < a.size() && std::isdigit(static_cast<unsigned char>(a[i_end]))) ++i_end;
      while (j_end < b.size() && std::isdigit(static_cast<unsigned char>(b[j_end]))) ++j_end;
      // Without leading zeros, a longer run is a larger number.
      const std::string x = a.substr(i, i_end - i), y = b.substr(j, j_end - j);
      const std::string u = x.substr(std::min(x.find_first_not_of('0'), x.size()));
      const std::string v = y.substr(std::min(y.find_first_not_of('0'), y.size()));
      if (u.size() != v.size()) return u.size() < v.size();
      if (u != v) return u < v;
      i = i_end, j = j_end;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i, ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

// The listing as a manifest: the first image's size and colour, frames one
// interval apart.
BurstManifest ManifestOf(const std::vector<fs::path>& images, const fs::path& dir) {
  BurstManifest manifest;
  const std::string first = ReadFileToString(images.front());
  try {
    const ImageHeader header = ReadImageHeader(first);
    manifest.width = static_cast<int>(header.width);
    manifest.height = static_cast<int>(header.height);
  } catch (const ImageDecodeError& e) {
    throw BurstError(images.front().string() + ": " + e.Describe());
  }
  manifest.pixel_format = "bgr8";
  for (size_t i = 0; i < images.size(); ++i) {
    BurstFrameInfo info;
    info.file = fs::relative(images[i], dir).string();
    info.sequence = static_cast<int64_t>(i);
    info.timestamp_ns = static_cast<int64_t>(i) * 33'333'333;  // 30 fps, nominal
    manifest.frames.push_back(info);
  }
  manifest.source = {{"driver", "images"}, {"input", dir.string()}};
  return manifest;
}

}  // namespace

void ImageSequenceOptions::Check() const {
  if (start < 0) throw std::invalid_argument("start must be >= 0, got " + std::to_string(start));
  if (frames != 0 && frames < 3)
    throw std::invalid_argument("frames must be 0 (all) or >= 3, got " + std::to_string(frames));
}

bool IsImageSequence(const std::string& input) {
  const fs::path path(input);
  if (HasGlob(path.filename().string())) return true;
  std::error_code error;
  return fs::is_directory(path, error) && !fs::exists(path / "manifest.json", error);
}

std::vector<fs::path> ListImageSequence(const std::string& input) {
  const fs::path path(input);
  const bool glob = HasGlob(path.filename().string());
  const fs::path dir = glob ? (path.has_parent_path() ? path.parent_path() : ".") : path;
  std::error_code error;
  if (!fs::is_directory(dir, error))
    throw BurstError("'" + dir.string() + "' is not a directory of images");
  std::vector<fs::path> images;
  // increment(error), not ++: a directory that fails mid-listing is a
  // BurstError like the rest, not a filesystem_error.
  for (fs::directory_iterator it(dir, error), end; !error && it != end; it.increment(error)) {
    const fs::path& file = it->path();
    std::error_code type_error;
    if (!it->is_regular_file(type_error) || !IsImageFile(file)) continue;
    if (glob && fnmatch(path.filename().c_str(), file.filename().c_str(), 0) != 0) continue;
    images.push_back(file);
  }
  if (error) throw BurstError("cannot list '" + dir.string() + "': " + error.message());
  std::sort(images.begin(), images.end(), [](const fs::path& a, const fs::path& b) {
    return NaturalLess(a.filename().string(), b.filename().string());
  });
  if (images.empty())
    throw BurstError("'" + input + "' names no PNG or JPEG images" +
                     (glob ? "" : " (and holds no manifest.json of a burst)"));
  return images;
}

Burst ReadImageSequence(const std::string& input, const ImageSequenceOptions& options) {
  try {
    options.Check();
  } catch (const std::invalid_argument& e) {
    throw BurstError(e.what());
  }
  std::vector<fs::path> images = ListImageSequence(input);
  const int available = std::max(0, static_cast<int>(images.size()) - options.start);
  const int count = options.frames > 0 ? options.frames : available;
  const std::string has = "'" + input + "' has " + std::to_string(images.size()) + " images" +
                          (options.start > 0 ? " (" + std::to_string(available) + " from image " +
                                                   std::to_string(options.start) + " on)"
                                             : "");
  if (available < 3) throw BurstError(has + "; a burst needs at least 3");
  if (count > available)
    throw BurstError(has + "; " + std::to_string(count) + " frames were asked for");
  images =
      std::vector<fs::path>(images.begin() + options.start, images.begin() + options.start + count);
  const fs::path dir = images.front().parent_path();
  return ReadBurstFrames(dir, ManifestOf(images, dir), {}, "'" + input + "'", "the first image is");
}

}  // namespace dfsm
