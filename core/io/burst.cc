#include "core/io/burst.h"

#include <algorithm>
#include <cstdio>
#include <exception>
#include <opencv2/imgproc.hpp>
#include <system_error>

#include "core/io/bounded_json.h"
#include "core/io/exif_focal.h"
#include "core/io/file_util.h"
#include "core/io/image_decode.h"

namespace dfsm {
namespace fs = std::filesystem;

namespace {

// Every frame is decoded within these limits (image_decode.h): its size is
// checked against the manifest's from the header before, so max_pixels only
// matters for a manifest beyond it (the daemon's [limits] refuse those when the
// burst is uploaded).
const ImageDecodeLimits kFrameLimits;

int RequirePositiveInt(const nlohmann::json& j, const char* key, const std::string& origin) {
  if (!j.contains(key)) throw BurstError(origin + ": required field '" + key + "' is missing");
  if (!j[key].is_number_integer() || j[key].get<int64_t>() <= 0 || j[key].get<int64_t>() > 65535)
    throw BurstError(origin + ": '" + key + "' must be a positive integer (got " +
                     DescribeJsonValue(j[key]) + ")");
  return j[key].get<int>();
}

int64_t OptionalInt(const nlohmann::json& j, const char* key, int64_t fallback,
                    const std::string& where) {
  if (!j.contains(key)) return fallback;
  if (!j[key].is_number_integer())
    throw BurstError(where + ": '" + key + "' must be an integer (got " +
                     DescribeJsonValue(j[key]) + ")");
  return j[key].get<int64_t>();
}

}  // namespace

BurstManifest ParseBurstManifest(const std::string& text, const std::string& origin) {
  nlohmann::json j;
  try {
    j = ParseBoundedJson(text);
  } catch (const JsonInputError& e) {
    throw BurstError(origin + ": " + e.what());
  }
  if (!j.is_object()) throw BurstError(origin + ": the manifest must be a JSON object");
  if (!j.contains("format")) throw BurstError(origin + ": required field 'format' is missing");
  if (j["format"] != kBurstFormat)
    throw BurstError(origin + ": format is " + DescribeJsonValue(j["format"]) + ", expected \"" +
                     kBurstFormat + "\"");

  BurstManifest manifest;
  manifest.width = RequirePositiveInt(j, "width", origin);
  manifest.height = RequirePositiveInt(j, "height", origin);
  if (j.contains("pixel_format")) {
    if (!j["pixel_format"].is_string() ||
        (j["pixel_format"] != "gray8" && j["pixel_format"] != "bgr8"))
      throw BurstError(origin + ": pixel_format " + DescribeJsonValue(j["pixel_format"]) +
                       " is not \"gray8\" or \"bgr8\"");
    manifest.pixel_format = j["pixel_format"].get<std::string>();
  }
  if (!j.contains("frames")) throw BurstError(origin + ": required field 'frames' is missing");
  if (!j["frames"].is_array()) throw BurstError(origin + ": 'frames' must be an array");
  const auto& frames = j["frames"];
  if (frames.size() < 3)
    throw BurstError(origin + ": a burst needs at least 3 frames, the manifest lists " +
                     std::to_string(frames.size()));
  for (size_t i = 0; i < frames.size(); ++i) {
    const std::string where = origin + ": frames[" + std::to_string(i) + "]";
    const auto& frame = frames[i];
    if (!frame.is_object() || !frame.contains("file") || !frame["file"].is_string() ||
        frame["file"].get<std::string>().empty())
      throw BurstError(where + ": required field 'file' is missing or not a non-empty string");
    BurstFrameInfo info;
    info.file = frame["file"].get<std::string>();
    // Refused before any file system call sees the name: a NUL would end it
    // early ("000000.png\0.jpg" is "000000.png" to stat, open and the error
    // message alike), and no frame needs a control character.
    for (size_t k = 0; k < info.file.size(); ++k) {
      const unsigned char c = static_cast<unsigned char>(info.file[k]);
      if (c < 0x20 || c == 0x7F) {
        char code[8];
        std::snprintf(code, sizeof code, "0x%02X", c);
        throw BurstError(where + ": 'file' contains the control character " + code + " at byte " +
                         std::to_string(k));
      }
    }
    info.timestamp_ns = OptionalInt(frame, "timestamp_ns", 0, where);
    info.sequence = OptionalInt(frame, "sequence", static_cast<int64_t>(i), where);
    manifest.frames.push_back(std::move(info));
  }
  const int64_t reference = OptionalInt(j, "reference", 0, origin);
  if (reference < 0 || reference >= static_cast<int64_t>(frames.size()))
    throw BurstError(origin + ": reference " + std::to_string(reference) +
                     " is not an index into the " + std::to_string(frames.size()) + " frames");
  manifest.reference = static_cast<int>(reference);
  if (j.contains("source")) manifest.source = j["source"];
  return manifest;
}

std::vector<int> Burst::frame_indices() const {
  if (!source_indices.empty()) return source_indices;
  std::vector<int> indices(gray.size());
  for (size_t i = 0; i < indices.size(); ++i) indices[i] = static_cast<int>(i);
  return indices;
}

BurstManifest ReadBurstManifest(const fs::path& burst_dir) {
  const fs::path path = burst_dir / "manifest.json";
  std::error_code ec;
  if (!fs::is_directory(burst_dir, ec)) throw BurstError(burst_dir.string() + ": not a directory");
  if (!fs::is_regular_file(path, ec)) throw BurstError(path.string() + ": missing");
  std::string text;
  try {
    text = ReadFileToString(path);
  } catch (const std::runtime_error& e) {
    throw BurstError(e.what());
  }
  return ParseBurstManifest(text, path.string());
}

nlohmann::json ToJson(const BurstManifest& manifest) {
  nlohmann::json frames = nlohmann::json::array();
  for (const auto& frame : manifest.frames)
    frames.push_back(
        {{"file", frame.file}, {"timestamp_ns", frame.timestamp_ns}, {"sequence", frame.sequence}});
  nlohmann::json j = {{"format", kBurstFormat},          {"width", manifest.width},
                      {"height", manifest.height},       {"pixel_format", manifest.pixel_format},
                      {"reference", manifest.reference}, {"frames", frames}};
  if (!manifest.source.is_null()) j["source"] = manifest.source;
  return j;
}

cv::Mat ToBgr8(const cv::Mat& frame) {
  cv::Mat eight;
  frame.depth() == CV_16U ? frame.convertTo(eight, CV_8U, 1.0 / 257.0) : void(eight = frame);
  cv::Mat bgr;
  if (eight.channels() == 4)
    cv::cvtColor(eight, bgr, cv::COLOR_BGRA2BGR);
  else if (eight.channels() == 1)
    cv::cvtColor(eight, bgr, cv::COLOR_GRAY2BGR);
  else
    bgr = eight;
  return bgr;
}

cv::Mat ToGray8(const cv::Mat& frame) {
  cv::Mat eight;
  if (frame.depth() == CV_8U) {
    eight = frame;
  } else if (frame.depth() == CV_16U) {
    frame.convertTo(eight, CV_8U, 1.0 / 257.0);
  } else {
    frame.convertTo(eight, CV_8U);
  }
  cv::Mat gray;
  switch (eight.channels()) {
    case 1:
      gray = eight;
      break;
    case 3:
      cv::cvtColor(eight, gray, cv::COLOR_BGR2GRAY);
      break;
    case 4:
      cv::cvtColor(eight, gray, cv::COLOR_BGRA2GRAY);
      break;
    default:
      throw BurstError("unsupported channel count " + std::to_string(eight.channels()));
  }
  return gray;
}

Burst ReadBurst(const fs::path& burst_dir, const ReadBurstOptions& options) {
  return ReadBurstFrames(burst_dir, ReadBurstManifest(burst_dir), options,
                         (burst_dir / "manifest.json").string(), "the manifest says");
}

Burst ReadBurstFrames(const fs::path& burst_dir, BurstManifest listed,
                      const ReadBurstOptions& options, const std::string& origin,
                      const std::string& size_origin) {
  Burst burst;
  burst.manifest = std::move(listed);
  BurstManifest& manifest = burst.manifest;

  if (options.max_frames > 0 && options.max_frames < static_cast<int>(manifest.frames.size())) {
    if (options.max_frames < 3)
      throw BurstError("--frames " + std::to_string(options.max_frames) +
                       ": a burst needs at least 3 frames");
    const int count = options.max_frames;
    const int total = static_cast<int>(manifest.frames.size());
    const int first = std::clamp(manifest.reference - count / 2, 0, total - count);
    manifest.frames = std::vector<BurstFrameInfo>(manifest.frames.begin() + first,
                                                  manifest.frames.begin() + first + count);
    manifest.reference -= first;
    for (int i = 0; i < count; ++i) burst.source_indices.push_back(first + i);
  }

  std::error_code root_error;
  const fs::path root = fs::weakly_canonical(burst_dir, root_error);
  // Frames decode on every core (a 1080p PNG takes ~25 ms); a bad frame is
  // reported as a serial reader would: the first in manifest order.
  const auto read_frame = [&](size_t i) {
    std::error_code ec;
    const std::string& file = manifest.frames[i].file;
    const std::string where = origin + ": frames[" + std::to_string(i) + "] '" + file + "'";
    const fs::path relative(file);
    const fs::path path = burst_dir / relative;
    // Reject both lexical escapes ("../x", "/etc/x") and symlinks that lead out.
    if (relative.is_absolute() || !IsLexicallyInside(burst_dir, path) ||
        !IsLexicallyInside(root, fs::weakly_canonical(path, ec)))
      throw BurstError(where + ": path lies outside the burst directory");
    if (!fs::is_regular_file(path, ec)) throw BurstError(where + ": file is missing");
    std::string bytes;
    try {
      bytes = ReadFileToString(path);
    } catch (const std::exception& e) {
      throw BurstError(where + ": " + e.what());
    }
    if (bytes.empty()) throw BurstError(where + ": empty file");
    // The size comes from the header first: a frame that does not match the
    // manifest is refused before any pixel of it is decoded.
    cv::Mat frame;
    try {
      const ImageHeader header = ReadImageHeader(bytes);
      if (header.width != manifest.width || header.height != manifest.height)
        throw BurstError(where + ": frame is " + std::to_string(header.width) + "x" +
                         std::to_string(header.height) + ", " + size_origin + " " +
                         std::to_string(manifest.width) + "x" + std::to_string(manifest.height));
      frame = DecodeImage(bytes, kFrameLimits);
    } catch (const ImageDecodeError& e) {
      throw BurstError(where + ": " + e.Describe());
    }
    if (frame.channels() != 1 && frame.channels() != 3 && frame.channels() != 4)
      throw BurstError(where + ": " + std::to_string(frame.channels()) +
                       " channels; expected gray or BGR");
    burst.gray[i] = ToGray8(frame);
    if (static_cast<int>(i) == manifest.reference) {
      burst.exif_focal_35mm = ReadExifFocalLength35mm(bytes);
      if (frame.channels() == 1) {
        burst.reference_color = burst.gray[i];
      } else {
        burst.reference_color = ToBgr8(frame);
      }
    }
  };
  burst.gray.resize(manifest.frames.size());
  std::vector<std::exception_ptr> errors(manifest.frames.size());
  cv::parallel_for_(cv::Range(0, static_cast<int>(manifest.frames.size())),
                    [&](const cv::Range& range) {
                      for (int i = range.start; i < range.end; ++i) {
                        try {
                          read_frame(static_cast<size_t>(i));
                        } catch (...) {
                          errors[i] = std::current_exception();
                        }
                      }
                    });
  for (const std::exception_ptr& error : errors) {
    if (error) std::rethrow_exception(error);
  }
  return burst;
}

BurstManifest CompleteManifest(BurstManifest manifest, const std::vector<cv::Mat>& frames) {
  if (frames.size() < 3) throw BurstError("WriteBurst: a burst needs at least 3 frames");
  if (!manifest.frames.empty() && manifest.frames.size() != frames.size())
    throw BurstError("WriteBurst: manifest lists " + std::to_string(manifest.frames.size()) +
                     " frames but " + std::to_string(frames.size()) + " were given");
  manifest.frames.resize(frames.size());
  manifest.width = frames[0].cols;
  manifest.height = frames[0].rows;
  manifest.pixel_format = frames[0].channels() == 1 ? "gray8" : "bgr8";
  for (size_t i = 0; i < frames.size(); ++i) {
    if (frames[i].cols != manifest.width || frames[i].rows != manifest.height)
      throw BurstError("WriteBurst: frame " + std::to_string(i) + " differs in size");
    BurstFrameInfo& info = manifest.frames[i];
    if (info.file.empty()) {
      char name[32];
      std::snprintf(name, sizeof(name), "frames/%06zu.png", i);
      info.file = name;
      if (info.sequence == 0 && i > 0) info.sequence = static_cast<int64_t>(i);
    }
  }
  return manifest;
}

void WriteBurst(const fs::path& burst_dir, BurstManifest manifest,
                const std::vector<cv::Mat>& frames, const WriteBurstOptions& options) {
  manifest = CompleteManifest(std::move(manifest), frames);
  std::error_code ec;
  fs::create_directories(burst_dir / "frames", ec);
  if (ec) throw BurstError(burst_dir.string() + ": cannot create directory: " + ec.message());
  // Encoding is most of the cost (core/io/png_encode.h).
  std::vector<std::string> errors(frames.size());
  const auto encode = [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) {
      try {
        WriteFileAtomically(burst_dir / manifest.frames[i].file,
                            EncodePng(frames[i], options.compression), Flush::kBatched);
      } catch (const std::exception& e) {
        errors[i] = "WriteBurst: frame " + std::to_string(i) + ": " + e.what();
      }
    }
  };
  const cv::Range all(0, static_cast<int>(frames.size()));
  if (options.in_parallel) {
    cv::parallel_for_(all, encode);
  } else {
    encode(all);
  }
  for (const std::string& error : errors) {
    if (!error.empty()) throw BurstError(error);
  }
  try {
    WriteFileAtomically(burst_dir / "manifest.json", ToJson(manifest).dump(2) + "\n",
                        Flush::kBatched);
    SyncFileSystem(burst_dir);
  } catch (const std::runtime_error& e) {
    throw BurstError(e.what());
  }
}

}  // namespace dfsm
